"""Reference policies: the report's controllers (PID, VSC1-4, feedforward) with the
stable-baselines3 ``predict`` interface, and the evaluation harness (``agents.evaluation``)."""

from agents.controllers import ALL_SPECS, BASE_SPECS, Controller, ControllerSpec, spec_by_label
from agents.policies import AgentPolicy, ControllerPolicy, ResistanceCalibration, SelfSensingPolicy, load_policy

__all__ = [
    "ALL_SPECS",
    "AgentPolicy",
    "BASE_SPECS",
    "Controller",
    "ControllerPolicy",
    "ControllerSpec",
    "ResistanceCalibration",
    "SelfSensingPolicy",
    "load_policy",
    "spec_by_label",
]

"""Reference policies: the report's controllers (PID, VSC1-4, feedforward) with the
stable-baselines3 ``predict`` interface, trained agents (:mod:`agents.trained`), the
evaluation harness (:mod:`agents.evaluation`) and training (:mod:`agents.training`).

Imports go one way: ``agents`` uses ``sma_gym``; ``sma_gym`` never imports ``agents``
(its ``sma-gym`` command finds ``fidelity`` and ``evaluate`` through the
``sma_gym.commands`` entry points that :mod:`agents.commands` declares)."""

from agents.card import PolicyCard
from agents.controllers import ALL_SPECS, BASE_SPECS, Controller, ControllerSpec, spec_by_label
from agents.policies import ControllerPolicy, ResistanceCalibration, SelfSensingPolicy
from agents.trained import AgentPolicy, load_policy, save_policy

__all__ = [
    "ALL_SPECS",
    "AgentPolicy",
    "BASE_SPECS",
    "Controller",
    "ControllerPolicy",
    "ControllerSpec",
    "PolicyCard",
    "ResistanceCalibration",
    "SelfSensingPolicy",
    "load_policy",
    "save_policy",
    "spec_by_label",
]

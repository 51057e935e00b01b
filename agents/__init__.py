"""Reference policies: the report's controllers (PID, VSC1-4, feedforward) with the
stable-baselines3 ``predict`` interface, trained agents (:mod:`sma_gym_agents.trained`), the
evaluation harness (:mod:`sma_gym_agents.evaluation`) and training (:mod:`sma_gym_agents.training`).

Imports go one way: ``agents`` uses ``sma_gym``; ``sma_gym`` never imports ``agents``
(its ``sma-gym`` command finds ``fidelity`` and ``evaluate`` through the
``sma_gym.commands`` entry points that :mod:`sma_gym_agents.commands` declares)."""

from sma_gym_agents.card import PolicyCard
from sma_gym_agents.controllers import ALL_SPECS, BASE_SPECS, Controller, ControllerSpec, spec_by_label
from sma_gym_agents.policies import ControllerPolicy, ResistanceCalibration, SelfSensingPolicy
from sma_gym_agents.trained import AgentPolicy, load_policy, save_policy

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

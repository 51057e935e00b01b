"""sma-gym: a shape-memory-alloy wire actuator as Gymnasium environments."""

from sma_gym.effects import EFFECTS, EffectSet, EffectSetting, effect_names
from sma_gym.electrical.multiplexer import Multiplexer
from sma_gym.model import ModelConfig, load_model
from sma_gym.params import ActuatorParams, preset, preset_names
from sma_gym.simulator import Simulator

__version__ = "0.4.0.dev0"

from sma_gym.envs import ENV_IDS, register_envs

register_envs()

__all__ = [
    "ActuatorParams",
    "EFFECTS",
    "ENV_IDS",
    "EffectSet",
    "EffectSetting",
    "ModelConfig",
    "Multiplexer",
    "Simulator",
    "effect_names",
    "load_model",
    "preset",
    "preset_names",
]

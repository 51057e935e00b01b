"""The card of a trained model: what is needed to run it as it trained, tied to its zip.

Every model ``<name>.zip`` that training writes has a card ``<name>.json`` beside it
(:data:`CARD_SUFFIX`, the only spelling): the env id and make kwargs, the history
features, the residual base controller, the frame stack, and the SHA-256 of the zip. A
card is written by :meth:`PolicyCard.save` (``train.py``) and read by
:meth:`PolicyCard.load` (:func:`sma_gym_agents.trained.load_policy`, ``sma-gym evaluate
--policy``); both go through the same frozen dataclass and the same checks, so a field
cannot be written in one spelling and read in another.

The JSON document (version 1)::

    {"format": "sma-gym-policy", "version": 1, "algo": "SAC", "name": "SAC agent",
     "env_id": "SMATracking-v0", "env_kwargs": {...}, "frame_stack": 1, "history": "ema",
     "residual": "VSC3 + FF", "residual_scale": 0.5, "seed": 0,
     "timesteps": 400000, "train_time_s": 780.1, "validation_return": -12.3,
     "model_sha256": "..."}

``timesteps``, ``train_time_s`` and ``validation_return`` are written only when known;
``residual_allocation`` (a bank agent's base on a shared budget, :data:`ALLOCATIONS`) only
when it is not ``"proportional"``, and ``residual_filter_s`` (the residual's low-pass) only
when it is not 0, so cards written before they existed read as they were.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from sma_gym._io import read_json_object, sha256_file, write_json
from sma_gym.model import load_model, model_names
from sma_gym_agents.history import HISTORIES

CARD_FORMAT = "sma-gym-policy"
CARD_VERSION = 1
CARD_SUFFIX = ".json"
"""A card is ``<name>.json`` beside ``<name>.zip``."""

CARD_ALGOS = ("SAC", "PPO", "TD3")
"""Algorithms a card may name (stable-baselines3 class names)."""

BANK_ENV_ID = "SMAMultiplexed-v0"
"""The env whose agent is one policy shared by every actuator of the bank: its model sees
per-actuator rows (:mod:`sma_gym_agents.bank`), not the env's observation."""
CARD_ENV_IDS = ("SMATracking-v0", "SMASelfSensing-v0", "SMARobust-v0", BANK_ENV_ID)
"""Env ids a card may name: those train.py trains on (which experiments of ``sma-gym
evaluate`` score each: :data:`sma_gym_agents.evaluation.AGENT_EXPERIMENTS`)."""


ALLOCATIONS = ("proportional", "priority")
"""How a bank baseline on a shared budget grants a cycle its actuators overrun: every ask
scaled by one factor (:class:`sma_gym_agents.bank.BudgetAllocator`, the default) or one
actuator after another (:class:`sma_gym_agents.bank.PriorityAllocator`)."""


def card_path(model_path: str | Path) -> Path:
    """The card of a model zip: ``<name>.json`` beside ``<name>.zip``."""
    return Path(model_path).with_suffix(CARD_SUFFIX)


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


FILTER_S_EXPECTED = "a time constant >= 0 s (0: no filter)"
"""What a residual's low-pass time constant ``filter_s`` may be (card, run, ResidualStep)."""


def card_model(model: Any) -> Any:
    """A model as a card holds it: a preset or twin name as given, anything else (a model
    file's path, ActuatorParams, ModelConfig, a dict) as its full configuration, so the card
    runs the agent on the actuator it trained on even after the file is edited or moved."""
    if model is None:
        return None
    if isinstance(model, (str, os.PathLike)) and os.fspath(model) in model_names():
        return os.fspath(model)
    return load_model(model).to_dict()


def is_filter_time_constant(value: Any) -> bool:
    """True for a residual low-pass time constant: a finite number >= 0 s (0: no filter)."""
    return _is_number(value) and math.isfinite(value) and value >= 0.0


def _problems(values: Mapping[str, Any]) -> list[tuple[str, str]]:
    """``(field, expected)`` for every field of ``values`` that a card cannot hold."""
    checks: tuple[tuple[str, bool, str], ...] = (
        ("format", values.get("format", CARD_FORMAT) == CARD_FORMAT, f"{CARD_FORMAT!r} (a card written by train.py)"),
        ("algo", values.get("algo") in CARD_ALGOS, f"one of {', '.join(CARD_ALGOS)}"),
        ("env_id", values.get("env_id") in CARD_ENV_IDS, f"one of {', '.join(CARD_ENV_IDS)}"),
        ("env_kwargs", isinstance(values.get("env_kwargs", {}), dict), "a JSON object of make kwargs"),
        ("frame_stack", _is_int(values.get("frame_stack", 1)) and values.get("frame_stack", 1) >= 1, "an integer >= 1"),
        ("history", values.get("history", "none") in HISTORIES, f"one of {', '.join(map(repr, HISTORIES))}"),
        (
            "residual",
            values.get("residual") is None or isinstance(values.get("residual"), str),
            "null or a controller label such as 'VSC3 + FF'",
        ),
        (
            "residual_scale",
            _is_number(values.get("residual_scale", 0.5)) and 0.0 < values.get("residual_scale", 0.5) <= 1.0,
            "a number in (0, 1]",
        ),
        ("residual_filter_s", is_filter_time_constant(values.get("residual_filter_s", 0.0)), FILTER_S_EXPECTED),
        (
            "residual_allocation",
            values.get("residual_allocation", "proportional") in ALLOCATIONS,
            f"one of {', '.join(ALLOCATIONS)}",
        ),
        ("name", isinstance(values.get("name", ""), str), "a string"),
        # The run's record: a wrong type here would be shown in tables as if it were true.
        ("seed", values.get("seed") is None or _is_int(values.get("seed")), "null or an integer"),
        (
            "timesteps",
            values.get("timesteps") is None or (_is_int(values.get("timesteps")) and values.get("timesteps") >= 0),
            "null or an integer >= 0",
        ),
        (
            "train_time_s",
            values.get("train_time_s") is None
            or (
                _is_number(values.get("train_time_s"))
                and math.isfinite(values.get("train_time_s"))
                and values.get("train_time_s") >= 0
            ),
            "null or a time >= 0 s",
        ),
        (
            "validation_return",
            values.get("validation_return") is None
            or (_is_number(values.get("validation_return")) and math.isfinite(values.get("validation_return"))),
            "null or a finite number",
        ),
        (
            "version",
            _is_int(values.get("version", CARD_VERSION)) and 1 <= values.get("version", CARD_VERSION) <= CARD_VERSION,
            f"an integer from 1 to {CARD_VERSION} (a card of a newer sma-gym? its fields may mean more than this one reads)",
        ),
    )
    return [(name, expected) for name, ok, expected in checks if not ok]


@dataclass(frozen=True)
class PolicyCard:
    """What a trained model needs to be run as it trained (see the module docstring)."""

    algo: str
    """stable-baselines3 class name, one of :data:`CARD_ALGOS`."""
    env_id: str
    """Registered env id the model trained on, one of :data:`CARD_ENV_IDS`."""
    name: str = ""
    """The name tables and plots show (empty: the zip's name)."""
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    """Make kwargs of the training env; its ``model`` is a preset or twin name, or the model's
    full configuration (:func:`card_model`), never a path that could change."""
    frame_stack: int = 1
    """Stacked observations (stable-baselines3's ``VecFrameStack``) the model expects."""
    history: str = "none"
    """``"ema"`` or ``"ema+error"``: :class:`sma_gym_agents.history.HistoryFeatures` appended to
    the observation (:data:`sma_gym_agents.history.HISTORIES`)."""
    residual: str | None = None
    """Controller label the model corrects (:mod:`sma_gym_agents.residual`), or None."""
    residual_scale: float = 0.5
    """Largest correction of the residual, as a fraction of full duty."""
    residual_filter_s: float = 0.0
    """Time constant of the low-pass the residual's correction passes [s] (0: none;
    :class:`sma_gym_agents.residual.ResidualStep`)."""
    residual_allocation: str = "proportional"
    """A bank agent's base on a shared budget: how it grants an overrun cycle (:data:`ALLOCATIONS`)."""
    seed: int | None = None
    timesteps: int | None = None
    """Environment steps the model had trained for when saved."""
    train_time_s: float | None = None
    validation_return: float | None = None
    """Mean return on the validation references when this model was chosen as the best."""
    model_sha256: str | None = None
    """SHA-256 of the zip the card describes; set by :meth:`save`, checked by :meth:`load`."""
    version: int = CARD_VERSION

    def __post_init__(self) -> None:
        model = self.env_kwargs.get("model")
        if model is not None and not isinstance(model, (str, os.PathLike)):
            # A configuration given in Python (ActuatorParams, ModelConfig) is held as its JSON form.
            object.__setattr__(self, "env_kwargs", {**self.env_kwargs, "model": card_model(model)})
        problems = _problems(self.as_dict())
        if problems:
            name, expected = problems[0]
            raise ValueError(f"policy card: {name} = {getattr(self, name)!r}: expected {expected}")

    # ------------------------------------------------------------------------------------
    @classmethod
    def from_dict(cls, values: Mapping[str, Any], where: str = "policy card") -> PolicyCard:
        """A card from its JSON fields; ``ValueError`` naming ``where`` and the field when invalid.

        Fields a card does not know are ignored (an older or newer writer may add some).
        """
        problems = _problems(values)
        if problems:
            name, expected = problems[0]
            raise ValueError(f"{where}: {name} = {values.get(name)!r}: expected {expected}")
        known = {f for f in cls.__dataclass_fields__ if f in values}
        kwargs = {f: values[f] for f in known}
        kwargs["env_kwargs"] = dict(kwargs.get("env_kwargs", {}))
        for key in ("residual_scale", "residual_filter_s"):
            if key in kwargs:
                kwargs[key] = float(kwargs[key])
        return cls(**kwargs)

    def as_dict(self) -> dict[str, Any]:
        """The JSON fields, in the order they are written; unknown optional fields left out."""
        out: dict[str, Any] = {
            "format": CARD_FORMAT,
            "version": self.version,
            "algo": self.algo,
            "name": self.name,
            "env_id": self.env_id,
            "env_kwargs": self.env_kwargs,
            "frame_stack": self.frame_stack,
            "history": self.history,
            "residual": self.residual,
            "residual_scale": self.residual_scale,
            "seed": self.seed,
        }
        if self.residual_filter_s != 0.0:
            out["residual_filter_s"] = self.residual_filter_s
        if self.residual_allocation != "proportional":
            out["residual_allocation"] = self.residual_allocation
        for key in ("timesteps", "train_time_s", "validation_return", "model_sha256"):
            if getattr(self, key) is not None:
                out[key] = getattr(self, key)
        return out

    # ------------------------------------------------------------------------------------
    def save(self, model_path: str | Path) -> Path:
        """Write (atomically) this card beside the existing zip ``model_path``, with the zip's
        SHA-256; returns the card's path."""
        digest = sha256_file(model_path)
        card = replace(self, model_sha256=digest)
        if "model" in self.env_kwargs:
            card = replace(card, env_kwargs={**self.env_kwargs, "model": card_model(self.env_kwargs["model"])})
        return write_json(card_path(model_path), card.as_dict())

    @classmethod
    def load(cls, model_path: str | Path) -> PolicyCard:
        """The validated card of the zip ``model_path``.

        Raises ``ValueError`` naming the card file when it is missing, is not a JSON object,
        has an invalid field, or when its ``model_sha256`` is not the hash of the zip beside
        it (the zip was replaced, e.g. by another run).
        """
        zip_path = Path(model_path)
        path = card_path(zip_path)
        if not path.exists():
            raise ValueError(
                f"policy {str(zip_path)!r}: no card {str(path)!r} beside it; a model without its card is "
                "incomplete (interrupted training?) or not written by train.py. A model you trained yourself on "
                "a plain env: write its card with sma_gym_agents.PolicyCard(algo='SAC', env_id='SMATracking-v0', "
                f"env_kwargs={{...}}).save({str(zip_path)!r}) (the algo and env it trained on, and the env's kwargs); "
                "one trained by RL Zoo on hyperparams/*.yml also gives its entry's wrappers: history='ema' for "
                "HistoryVecEnv, residual=<base>, residual_scale=<scale>, residual_filter_s=<filter_s> for ResidualVecEnv"
            )
        values = read_json_object(path, "policy card")
        where = f"policy card {str(path)!r}"
        card = cls.from_dict(values, where)
        digest = values.get("model_sha256")
        if not isinstance(digest, str) or len(digest) != 64:
            raise ValueError(
                f"{where}: model_sha256 = {digest!r}: expected the SHA-256 (64 hex digits) of the model zip it describes"
            )
        if digest != sha256_file(zip_path):
            raise ValueError(
                f"policy {str(zip_path)!r}: its card {str(path)!r} describes another model (SHA-256 mismatch); "
                "the zip was replaced after the card was written, so the card cannot be trusted"
            )
        return card

"""Reference policies with stable-baselines3's ``predict`` interface.

>>> import gymnasium as gym
>>> from stable_baselines3.common.evaluation import evaluate_policy
>>> from agents import ControllerPolicy
>>> env = gym.make("sma_gym:SMATracking-v0", control_period_s=1e-3, max_episode_steps=6000)
>>> policy = ControllerPolicy("VSC3 + FF", env)
>>> mean_reward, _ = evaluate_policy(policy, env, n_eval_episodes=1)   # doctest: +SKIP

A :class:`ControllerPolicy` runs one of the report's controllers (:mod:`agents.controllers`)
on what a real controller reads: the measured position, the reference and its rate (from
the observation, scaled back to metres with the env's ``position_scale_m``) and its own time
step (the env's ``control_period_s``; the report's loop runs at 1 kHz). It never reads the
simulator's hidden state. Batches of observations (SB3 vector envs, the multiplexed env's
n actuators) are handled at once; integrators and filters restart where
``episode_start`` is True.

:class:`SelfSensingPolicy` is the same controller fed by a position estimated from the
resistance, with a calibration fitted to a heating sweep (§4.2).

:func:`load_policy` opens a trained stable-baselines3 model written by ``train.py``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from agents.controllers import Controller, ControllerSpec, spec_by_label


def _env_attr(env: Any, name: str, per_env: bool = False) -> Any:
    """Read an attribute of a Gymnasium env, vector env or SB3 VecEnv.

    ``per_env``: a number that may differ between sub-envs (a scale): an adapter's
    ``get_attr`` gives one entry per sub-env, kept as an array (a native vector env's own
    attribute already is one).
    """
    if hasattr(env, "get_attr"):
        values = env.get_attr(name)
        return np.asarray(values, dtype=float) if per_env else values[0]
    target = getattr(env, "unwrapped", env)
    return getattr(target, name)


class ControllerPolicy:
    """One of the report's controllers as a policy (see the module docstring)."""

    def __init__(self, spec: ControllerSpec | str, env: Any, filter_cutoff_hz: float | None = None):
        self.spec = spec_by_label(spec) if isinstance(spec, str) else spec
        self.name = self.spec.label
        self.feature_names = tuple(_env_attr(env, "feature_names"))
        self.k = len(self.feature_names)
        self.dt = float(_env_attr(env, "control_period_s"))
        self.duty_range = tuple(_env_attr(env, "duty_range"))
        self.position_scale_m = np.asarray(_env_attr(env, "position_scale_m", per_env=True), dtype=float)
        self.resistance_scale_ohm = np.asarray(_env_attr(env, "resistance_scale_ohm", per_env=True), dtype=float)
        self._filter_cutoff_hz = filter_cutoff_hz
        self._controller: Controller | None = None
        self._index = {name: i for i, name in enumerate(self.feature_names)}

    def reset(self) -> None:
        self._controller = None

    def position_m(self, features: np.ndarray, scale: np.ndarray) -> np.ndarray:
        """Measured position [m] from the features (shape (batch, units, k))."""
        if "position" not in self._index:
            raise ValueError(
                f"{self.name}: the observation has no position feature ({self.feature_names}); "
                "use SelfSensingPolicy with a resistance calibration"
            )
        return features[..., self._index["position"]] * scale

    def predict(self, observation: np.ndarray, state: Any = None, episode_start: Any = None, deterministic: bool = True):
        obs = np.asarray(observation, dtype=float)
        single = obs.ndim == 1
        batch = obs.reshape(1 if single else obs.shape[0], -1, self.k)
        n_batch, units, _ = batch.shape
        n = n_batch * units
        if self._controller is None or self._controller.n != n:
            kwargs = {} if self._filter_cutoff_hz is None else {"filter_cutoff_hz": self._filter_cutoff_hz}
            self._controller = Controller(self.spec, n=n, dt=self.dt, **kwargs)
        elif episode_start is not None:
            starts = np.repeat(np.asarray(episode_start, dtype=bool).reshape(-1), units)
            if starts.any():
                self._controller.reset(starts)
        scale = self._scale(self.position_scale_m, n_batch, units)
        x = self.position_m(batch, scale).reshape(n)
        r = (batch[..., self._index["reference"]] * scale).reshape(n)
        rate = (batch[..., self._index["reference_rate"]] * scale).reshape(n)
        x = np.broadcast_to(x, (n,)) if np.ndim(x) == 0 else x
        duty = self._controller(x, r, rate)
        # The env's duty range applies as a cap (multiplexed: at most 1/n per actuator, §9.1).
        lo, hi = self.duty_range
        action = 2.0 * (np.clip(duty, lo, hi) - lo) / (hi - lo) - 1.0
        action = action.reshape(n_batch, units).astype(np.float32)
        return (action[0] if single else action), None

    @staticmethod
    def _scale(scale: np.ndarray, n_batch: int, units: int) -> np.ndarray | float:
        s = np.asarray(scale, dtype=float)
        if s.ndim == 0:
            return float(s)
        return s.reshape(-1, 1)


@dataclass(frozen=True)
class ResistanceCalibration:
    """Position from resistance: x = slope * R + offset, fitted while heating (§4.2).

    The report finds R(x) linear while heating above 1 mm and uses that for self-sensing;
    below the fitted range the estimate is clipped at 0.
    """

    slope_m_per_ohm: float
    offset_m: float
    fit_range_m: tuple[float, float]
    r_squared: float

    def position_m(self, resistance_ohm: np.ndarray) -> np.ndarray:
        return np.maximum(0.0, self.slope_m_per_ohm * np.asarray(resistance_ohm) + self.offset_m)

    @classmethod
    def fit(cls, model: Any = "standard", seconds: float = 40.0, duty_range: tuple[float, float] = (0.05, 0.8)) -> "ResistanceCalibration":
        """Fit on a heating sweep: duty ramped slowly across ``duty_range`` with the position
        sensor still fitted (a lab calibration before the sensor is removed)."""
        from sma_gym import Simulator

        sim = Simulator(model)
        steps = int(seconds * 1000)
        lo, hi = duty_range
        duty = np.linspace(lo, hi, steps)
        rec = sim.run(duty, record=("position_measured_m", "resistance_measured_ohm"))
        x = rec["position_measured_m"][:, 0]
        r = rec["resistance_measured_ohm"][:, 0]
        stroke = float(np.nanmax(x))
        band = (x > 1e-3) & (x < 0.9 * stroke) & np.isfinite(r)
        if band.sum() < 10:
            raise ValueError("resistance calibration: the heating sweep did not move the actuator through 1 mm")
        slope, offset = np.polyfit(r[band], x[band], 1)
        resid = x[band] - (slope * r[band] + offset)
        r2 = 1.0 - resid.var() / x[band].var()
        return cls(float(slope), float(offset), (1e-3, 0.9 * stroke), float(r2))


class SelfSensingPolicy(ControllerPolicy):
    """A report controller fed by the position estimated from resistance (no sensor)."""

    def __init__(self, spec: ControllerSpec | str, env: Any, calibration: ResistanceCalibration | None = None, model: Any = None):
        super().__init__(spec, env)
        self.name = f"{self.spec.label} (self-sensing)"
        if calibration is None:
            if model is None:
                model = _env_attr(env, "settings").model
            calibration = ResistanceCalibration.fit(model, duty_range=tuple(_env_attr(env, "duty_range")))
        self.calibration = calibration

    def position_m(self, features: np.ndarray, scale: np.ndarray) -> np.ndarray:
        r_scale = self._scale(self.resistance_scale_ohm, features.shape[0], features.shape[1])
        resistance = r_scale * (1.0 + features[..., self._index["resistance"]] / 10.0)
        return self.calibration.position_m(resistance)


# --------------------------------------------------------------------------------------
# Trained agents
# --------------------------------------------------------------------------------------
POLICY_CARD_SUFFIX = ".json"


def _sb3(name: str) -> Any:
    import stable_baselines3

    return getattr(stable_baselines3, name)


POLICY_ALGOS = {"SAC": lambda: _sb3("SAC"), "PPO": lambda: _sb3("PPO"), "TD3": lambda: _sb3("TD3")}
"""Algorithms a card may name, each a loader of its stable-baselines3 class (imported lazily)."""

POLICY_ENV_IDS = ("SMATracking-v0", "SMASelfSensing-v0", "SMARobust-v0")
"""Env ids a card may name: those train.py trains on and ``sma-gym evaluate`` scores (an agent
of any other id would be silently left out of every table)."""


@dataclass
class AgentPolicy:
    """A trained stable-baselines3 model plus what is needed to evaluate it like it trained.

    ``frame_stack`` is the number of stacked observations (SB3's ``VecFrameStack``) the
    model expects; the evaluation harness wraps its env accordingly.
    """

    model: Any
    name: str
    env_id: str
    env_kwargs: dict
    frame_stack: int = 1
    history: str = "none"
    """``"ema"``: the model expects :class:`agents.history.HistoryFeatures` appended; the
    policy computes them from the observations it is given, as training did."""
    residual: str | None = None
    """A controller label (e.g. ``"VSC3 + FF"``): the model is a residual on top of it
    (:mod:`agents.residual`); the policy runs that controller, as training did."""
    residual_scale: float = 0.5

    def __post_init__(self) -> None:
        self._features = None
        self._residual = None

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        obs = np.asarray(observation, dtype=float)
        single = obs.ndim == 1
        batch = obs[None, :] if single else obs
        if episode_start is not None:
            starts = np.asarray(episode_start, dtype=bool).reshape(-1)
        else:  # no flags: the first call starts an episode, later calls continue it
            starts = np.full(len(batch), self._features is None and self._residual is None)
        if self.residual is not None:
            if self._residual is None:
                import gymnasium as gym

                import sma_gym  # noqa: F401
                from agents.residual import ResidualStep

                env = gym.make("sma_gym:" + self.env_id, **self.env_kwargs)
                self._residual = ResidualStep(env, self.residual, self.residual_scale)
                env.close()
            batch = self._residual.observe(batch, starts)
        if self.history == "ema":
            batch = self._with_history(batch, starts)
        action, state = self.model.predict(batch, state=state, episode_start=episode_start, deterministic=deterministic)
        if self._residual is not None:
            action = self._residual.action(action)
        return (action[0] if single else action), state

    def _with_history(self, batch: np.ndarray, starts: np.ndarray) -> np.ndarray:
        from agents.history import HistoryFeatures

        if self._features is None or self._features.n != batch.shape[0]:
            self._features = HistoryFeatures.for_env(batch.shape[0], self.env_id, self.env_kwargs)
            return self._features.reset(batch)
        out, _ = self._features.update(batch, starts)
        return out

    def reset(self) -> None:
        self._features = None
        self._residual = None


def card_path(model_path: str | Path) -> Path:
    """The card of a model zip: ``<name>.json`` beside ``<name>.zip``."""
    return Path(model_path).with_suffix(POLICY_CARD_SUFFIX)


def save_policy(model: Any, path: str | Path, card: dict[str, Any]) -> Path:
    """Save ``model`` to ``path`` (a ``.zip``) and then its card, each atomically.

    The card records the SHA-256 of the zip it describes, so a card can never be read as
    describing another run's model (:func:`read_card` checks it). The zip is written
    first: an interrupt between the two leaves a zip whose card is missing or stale, which
    the reader refuses by name, never a card pointing at a model that does not exist.
    """
    from sma_gym._io import atomic_path

    target = Path(path)
    with atomic_path(target) as tmp:
        model.save(tmp)
    write_card(target, card)
    return target


def write_card(model_path: str | Path, card: dict[str, Any]) -> Path:
    """Write (atomically) the card of an existing model zip, with the zip's SHA-256."""
    from sma_gym._io import sha256_file, write_json

    return write_json(card_path(model_path), {**card, "model_sha256": sha256_file(model_path)})


def read_card(model_path: str | Path) -> dict[str, Any]:
    """The validated card of a model zip written by ``train.py``.

    Raises ``ValueError`` naming the file when the card is missing, is not a JSON object,
    lacks a field, names an unknown env id or algorithm, or when its ``model_sha256`` is
    not the hash of the zip beside it (the zip was replaced, e.g. by another run).
    """
    from sma_gym._io import read_json_object, sha256_file

    zip_path = Path(model_path)
    path = card_path(zip_path)
    if not path.exists():
        raise ValueError(
            f"policy {str(zip_path)!r}: no card {str(path)!r} beside it; a model without its card is "
            "incomplete (interrupted training?) or not written by train.py"
        )
    card = read_json_object(path, "policy card")

    def bad(field: str, expected: str) -> ValueError:
        return ValueError(f"policy card {str(path)!r}: {field} = {card.get(field)!r}: expected {expected}")

    if card.get("format") != "sma-gym-policy":
        raise bad("format", "'sma-gym-policy' (a card written by train.py)")
    if card.get("algo") not in POLICY_ALGOS:
        raise bad("algo", f"one of {', '.join(POLICY_ALGOS)}")
    if card.get("env_id") not in POLICY_ENV_IDS:
        raise bad("env_id", f"one of {', '.join(POLICY_ENV_IDS)}")
    if not isinstance(card.get("env_kwargs", {}), dict):
        raise bad("env_kwargs", "a JSON object of make kwargs")
    frame_stack = card.get("frame_stack", 1)
    if isinstance(frame_stack, bool) or not isinstance(frame_stack, int) or frame_stack < 1:
        raise bad("frame_stack", "an integer >= 1")
    if card.get("history", "none") not in ("none", "ema"):
        raise bad("history", "'none' or 'ema'")
    if card.get("residual") is not None and not isinstance(card.get("residual"), str):
        raise bad("residual", "null or a controller label such as 'VSC3 + FF'")
    scale = card.get("residual_scale", 0.5)
    if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not 0.0 < scale <= 1.0:
        raise bad("residual_scale", "a number in (0, 1]")
    digest = card.get("model_sha256")
    if not isinstance(digest, str) or len(digest) != 64:
        raise bad("model_sha256", "the SHA-256 (64 hex digits) of the model zip it describes")
    if digest != sha256_file(zip_path):
        raise ValueError(
            f"policy {str(zip_path)!r}: its card {str(path)!r} describes another model (SHA-256 mismatch); "
            "the zip was replaced after the card was written, so the card cannot be trusted"
        )
    return card


def load_policy(path: str | Path, name: str | None = None) -> AgentPolicy:
    """Open a model saved by ``train.py`` (``<name>.zip`` with its card ``<name>.json``).

    The card is required and must describe this very zip (see :func:`read_card`).
    """
    p = Path(path)
    if p.suffix != ".zip":
        p = p.with_suffix(".zip")
    if not p.is_file():
        raise ValueError(f"policy = {str(path)!r}: no such file (expected a stable-baselines3 .zip written by train.py)")
    card = read_card(p)
    try:
        model = POLICY_ALGOS[card["algo"]]().load(str(p), device="cpu")
    except Exception as err:  # noqa: BLE001 - SB3 raises many types for a corrupt zip
        raise ValueError(f"policy = {str(path)!r}: not a {card['algo']} model ({err})") from None
    return AgentPolicy(
        model=model,
        name=name or card.get("name") or p.stem,
        env_id=card["env_id"],
        env_kwargs=dict(card.get("env_kwargs", {})),
        frame_stack=int(card.get("frame_stack", 1)),
        history=str(card.get("history", "none")),
        residual=card.get("residual"),
        residual_scale=float(card.get("residual_scale", 0.5)),
    )

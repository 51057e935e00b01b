"""Reference policies with stable-baselines3's ``predict`` interface.

>>> import gymnasium as gym
>>> from stable_baselines3.common.evaluation import evaluate_policy
>>> from sma_gym_agents import ControllerPolicy
>>> env = gym.make("sma_gym:SMATracking-v0", control_period_s=1e-3, max_episode_steps=6000)
>>> policy = ControllerPolicy("VSC3 + FF", env)
>>> mean_reward, _ = evaluate_policy(policy, env, n_eval_episodes=1)   # doctest: +SKIP

A :class:`ControllerPolicy` runs one of the report's controllers (:mod:`sma_gym_agents.controllers`)
on what a real controller reads: the measured position, the reference and its rate (from
the observation, scaled back to metres with the env's ``position_scale_m``) and its own time
step (the env's ``control_period_s``; the report's loop runs at 1 kHz). It never reads the
simulator's hidden state. Batches of observations (SB3 vector envs, the multiplexed env's
n actuators) are handled at once; integrators and filters restart where
``episode_start`` is True.

Unlike an SB3 model's ``predict``, these policies keep state between calls (a controller's
integrator, filter and previous error), as a real controller does. SB3's
``evaluate_policy`` passes ``episode_start``; a loop of your own passes it, or calls
:meth:`ControllerPolicy.reset` after ``env.reset()``. Without either, an episode starts
from the last one's state (measured: the PID's return on the same seeded step went -30.8,
-24.9, -21.8 over three episodes).

:class:`SelfSensingPolicy` is the same controller fed by a position estimated from the
resistance, with a calibration fitted to a heating sweep (§4.2).

Trained models (written by ``train.py``) are opened by :func:`sma_gym_agents.trained.load_policy`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from sma_gym.envs.task import DutyRange
from sma_gym_agents.controllers import Controller, ControllerSpec, require_filter_cutoff_hz, spec_by_label


def env_attr(env: Any, name: str, per_env: bool = False) -> Any:
    """Read an attribute of a Gymnasium env, vector env or SB3 VecEnv.

    ``per_env``: a number that may differ between sub-envs (a scale): an adapter's
    ``get_attr`` gives one entry per sub-env, kept as an array (a native vector env's own
    attribute already is one).
    """
    try:
        if hasattr(env, "get_attr"):
            values = env.get_attr(name)
            return np.asarray(values, dtype=float) if per_env else values[0]
        return getattr(getattr(env, "unwrapped", env), name)
    except AttributeError:
        # Another package's env (CartPole, say) has none of the features a controller reads.
        spec = getattr(env, "spec", None)
        which = getattr(spec, "id", None) or type(getattr(env, "unwrapped", env)).__name__
        raise ValueError(
            f"env {which!r} has no {name!r}: expected an sma-gym env (gym.make('sma_gym:SMATracking-v0'), "
            "its vector env or sma_gym.envs.sb3.SB3VecEnv around one)"
        ) from None


def _layers(env: Any) -> list[Any]:
    """``env`` and what it wraps, outermost first: Gymnasium wrappers (``.env``), SB3 vector
    wrappers and the adapter (``.venv``), SB3's ``DummyVecEnv`` (its first env)."""
    layers, layer = [], env
    while layer is not None and len(layers) < 64:
        layers.append(layer)
        envs = layer.__dict__.get("envs") if hasattr(layer, "__dict__") else None
        layer = getattr(layer, "env", None) or getattr(layer, "venv", None) or (envs[0] if envs else None)
    return layers


def _shape(layer: Any) -> tuple[int, ...] | None:
    space = getattr(layer, "single_observation_space", None) or getattr(layer, "observation_space", None)
    shape = getattr(space, "shape", None)
    return tuple(int(k) for k in shape) if shape else None


def require_raw_observations(env: Any, who: str) -> int | None:
    """The width of the raw observations ``env`` gives a controller (None if it does not say),
    or a ``ValueError`` naming a wrapper that changes them: the controllers read the env's
    own features (scaled positions, the reference), and normalised or stacked ones gave a
    silently wrong control (a PID over ``VecNormalize`` returned -82 for -11)."""
    from gymnasium.wrappers import NormalizeObservation
    from gymnasium.wrappers.vector import NormalizeObservation as VectorNormalizeObservation

    layers = _layers(env)
    for layer in layers:
        normalises = isinstance(layer, (NormalizeObservation, VectorNormalizeObservation)) or (
            type(layer).__name__ == "VecNormalize" and getattr(layer, "norm_obs", False)
        )
        if normalises:
            raise ValueError(
                f"{who}: the env's observations pass {type(layer).__name__}, but the controllers read the env's own "
                "features; expected the env without it (for SB3's VecNormalize, norm_obs=False)"
            )
    # The whole shape: Gymnasium's FrameStackObservation keeps the width and adds a dimension
    # (4 stacked frames were read as 4 envs).
    shapes = [w for w in map(_shape, layers) if w is not None]
    if shapes and shapes[0] != shapes[-1]:
        names = " <- ".join(type(layer).__name__ for layer in layers)
        raise ValueError(
            f"{who}: a wrapper makes the env's observations of shape {shapes[0]} from {shapes[-1]} ({names}; frame "
            "stacking?), but the controllers read one frame of the env's own features; expected the env without it"
        )
    return shapes[-1][-1] if shapes else None


def episode_starts(episode_start: Any, n_batch: int, *, broadcast: bool = False) -> np.ndarray:
    """``predict``'s ``episode_start`` as one bool per observation of a batch of ``n_batch``
    (SB3 passes its ``dones``); ``broadcast``: one flag may stand for the whole batch.

    Booleans, or numbers 0 and 1; anything else is refused by name (``np.asarray(x, bool)``
    read ``"no"``, ``NaN`` and ``0.5`` as True: the controller reset its state every step)."""
    flags = np.asarray(episode_start)
    if flags.dtype != bool:
        numeric = flags.dtype.kind in "iuf"
        if not numeric or not np.isin(flags, (0, 1)).all():
            shown = np.array2string(flags.reshape(-1)[:4], separator=", ") if flags.size else "[]"
            raise ValueError(
                f"episode_start = {shown}{' ...' if flags.size > 4 else ''} ({flags.dtype}): expected booleans "
                "(or 0 / 1), one per observation of the batch"
            )
        flags = flags.astype(bool)
    flags = flags.reshape(-1)
    if broadcast and flags.size == 1:
        return np.repeat(flags, n_batch)
    if flags.size != n_batch:
        raise ValueError(
            f"episode_start has {flags.size} entries: expected {n_batch} (one per observation of the batch)"
        )
    return flags


def require_finite_observation(
    obs: np.ndarray, feature_names: Sequence[str] | Callable[[], Sequence[str]] | None = None
) -> None:
    """ValueError naming the first non-finite value of a policy's observation: its position
    and, given the env's ``feature_names`` (or a callable that returns them, called only on
    that error), the feature, as the env's observation lays them out (and stacks them)."""
    bad = ~np.isfinite(obs)
    if not bad.any():
        return
    where = np.unravel_index(int(np.flatnonzero(bad)[0]), obs.shape)
    value = "NaN" if np.isnan(obs[where]) else f"{obs[where]:+}"
    names = feature_names() if callable(feature_names) else feature_names
    feature = ""
    if names and obs.ndim and obs.shape[-1] % len(names) == 0:
        feature = f" feature {names[where[-1] % len(names)]!r}"
        if obs.shape[-1] > len(names):  # several actuators or stacked frames
            feature += f" of block {where[-1] // len(names)}"
    at = f" at{feature} (index {', '.join(map(str, where))};" if obs.ndim else " ("
    raise ValueError(
        f"observation holds {value}{at} {int(bad.sum())} non-finite value(s) in all): "
        "expected finite numbers (a sensor or a preprocessing step gave no number)"
    )


class ControllerPolicy:
    """One of the report's controllers as a policy (see the module docstring)."""

    def __init__(self, spec: ControllerSpec | str, env: Any, filter_cutoff_hz: float | None = None):
        if not isinstance(spec, (str, ControllerSpec)):
            raise ValueError(f"spec = {spec!r}: expected a controller's label (e.g. 'VSC3 + FF') or a ControllerSpec")
        if filter_cutoff_hz is not None:
            filter_cutoff_hz = require_filter_cutoff_hz(filter_cutoff_hz)  # refused now, not at predict()
        self.spec = spec_by_label(spec) if isinstance(spec, str) else spec
        self.name = self.spec.label
        self.feature_names = tuple(env_attr(env, "feature_names"))
        self.k = len(self.feature_names)
        self.dt = float(env_attr(env, "control_period_s"))
        self.duty_range = DutyRange(*env_attr(env, "duty_range"))
        self.position_scale_m = np.asarray(env_attr(env, "position_scale_m", per_env=True), dtype=float)
        self.resistance_scale_ohm = np.asarray(env_attr(env, "resistance_scale_ohm", per_env=True), dtype=float)
        self._filter_cutoff_hz = filter_cutoff_hz
        self._controller: Controller | None = None
        self._index = {name: i for i, name in enumerate(self.feature_names)}
        self.width = require_raw_observations(env, self.name)
        """Width of one observation of ``env`` (its actuators times their features), when it says."""
        if "position" not in self._index and type(self).position_m is ControllerPolicy.position_m:
            # Refused here, not at the first predict() (a new user's evaluation got that far).
            raise ValueError(self._no_position())

    def _no_position(self) -> str:
        return (
            f"{self.name}: the observation has no position feature ({self.feature_names}); "
            "use SelfSensingPolicy with a resistance calibration"
        )

    def reset(self) -> None:
        """Forget the controllers' state: call it after ``env.reset()`` in a loop of your own
        (or pass ``episode_start`` to :meth:`predict`)."""
        self._controller = None

    def position_m(self, features: np.ndarray, scale: np.ndarray) -> np.ndarray:
        """Measured position [m] from the features (shape (batch, units, k))."""
        if "position" not in self._index:
            raise ValueError(self._no_position())
        return features[..., self._index["position"]] * scale

    def predict(
        self, observation: np.ndarray, state: Any = None, episode_start: Any = None, deterministic: bool = True
    ):
        obs = np.asarray(observation, dtype=float)
        single = obs.ndim == 1
        if obs.ndim not in (1, 2) or obs.shape[-1] % self.k or not obs.shape[-1] or not obs.size:
            raise ValueError(
                f"observation of shape {obs.shape}: expected ({self.k},), (n * {self.k},) or a batch of them "
                f"(batch, n * {self.k}) from {self.spec.label}'s env"
            )
        if self.width is not None and obs.shape[-1] != self.width:
            # Another bank's (the duty cap is 1/n of this env's n) or a stacked frame.
            raise ValueError(
                f"observation of shape {obs.shape}: expected {self.width} features per observation, as the env this "
                f"{self.spec.label} was made for gives ({self.width // self.k} actuator(s) x {self.k})"
            )
        # A controller fed NaN returns NaN duties, which no env accepts.
        require_finite_observation(obs, self.feature_names)
        batch = obs.reshape(1 if single else obs.shape[0], -1, self.k)
        n_batch, units, _ = batch.shape
        n = n_batch * units
        starts = None if episode_start is None else np.repeat(episode_starts(episode_start, n_batch), units)
        if self._controller is None or self._controller.n != n:
            kwargs = {} if self._filter_cutoff_hz is None else {"filter_cutoff_hz": self._filter_cutoff_hz}
            self._controller = Controller(self.spec, n=n, dt=self.dt, **kwargs)
        elif starts is not None:
            if starts.any():
                self._controller.reset(starts)
        scale = self._scale(self.position_scale_m, n_batch, units)
        x = self.position_m(batch, scale).reshape(n)
        r = (batch[..., self._index["reference"]] * scale).reshape(n)
        rate = (batch[..., self._index["reference_rate"]] * scale).reshape(n)
        x = np.broadcast_to(x, (n,)) if np.ndim(x) == 0 else x
        duty = self._controller(x, r, rate)
        # The env's duty range applies as a cap (multiplexed: at most 1/n per actuator, §9.1).
        action = self.duty_range.action_for(np.clip(duty, *self.duty_range))
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
    def fit(
        cls, model: Any = "standard", seconds: float = 40.0, duty_range: tuple[float, float] = (0.05, 0.8)
    ) -> ResistanceCalibration:
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

    def __init__(
        self, spec: ControllerSpec | str, env: Any, calibration: ResistanceCalibration | None = None, model: Any = None
    ):
        super().__init__(spec, env)
        self.name = f"{self.spec.label} (self-sensing)"
        if calibration is None:
            if model is None:
                model = env_attr(env, "settings").model
            calibration = ResistanceCalibration.fit(model, duty_range=tuple(env_attr(env, "duty_range")))
        self.calibration = calibration

    def position_m(self, features: np.ndarray, scale: np.ndarray) -> np.ndarray:
        r_scale = self._scale(self.resistance_scale_ohm, features.shape[0], features.shape[1])
        resistance = r_scale * (1.0 + features[..., self._index["resistance"]] / 10.0)
        return self.calibration.position_m(resistance)

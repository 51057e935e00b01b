"""The tracking task on top of the simulator: actions, observations, reward, termination, info.

One compiled function computes observations, rewards and termination for any set of
actuators of a :class:`~sma_gym.Simulator`, so the single env (n = 1), the multiplexed env
(n actuators in one env) and the native vector env (one actuator per sub-env) share the
same code. Each quantity the envs expose is defined here once:

* the action -> duty map: :class:`DutyRange`;
* the observation features, their definitions and bounds: :data:`FEATURES`,
  :data:`_BOUNDS` (the env docstrings' tables are generated from them by
  :func:`feature_table`);
* the ``info`` keys: :data:`INFO` (:func:`info_list` documents them);
* the scales (usable stroke, cold resistance): the simulator's parameter views
  ``Simulator.usable_stroke_m`` and ``Simulator.cold_resistance_ohm``.

Reward (per actuator, per step)::

    reward = -|x_true - r(t)| / stroke  -  energy_weight * P_el / P_full

with ``P_el`` the mean electrical power of the step and ``P_full = V^2 / R_cold`` the power
at duty 1 into the cold wire. The hot (austenitic) wire's resistance is lower, so at duty 1
the energy term reaches ``R_cold / R_hot`` times ``energy_weight``: up to 1.21 on the presets
(measured at duty 1 from rest; 1.0 on ``bench-0.5mm-ht-datasheet``), not 1. The step on
which a wire passes the overheat limit adds :func:`overheat_penalty`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import partial
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from gymnasium import logger
from gymnasium.error import ResetNeeded

from sma_gym._jit import njit
from sma_gym.core import layout as L
from sma_gym.envs import EPISODE_STEPS
from sma_gym.envs.references import N_PARAMS, N_WAYPOINTS, TRAINING_KINDS, Reference, evaluate

if TYPE_CHECKING:
    from sma_gym.simulator import Simulator

# --------------------------------------------------------------------------------------
# Defaults of the env keyword arguments (the env signatures and docstrings use these)
# --------------------------------------------------------------------------------------
DEFAULT_CONTROL_PERIOD_S = 10e-3
DEFAULT_REFERENCE: tuple[str, ...] = TRAINING_KINDS
DEFAULT_ENERGY_WEIGHT = 0.0
DEFAULT_OVERHEAT_C = 150.0
"""Flexinol's trained memory degrades when the wire is held much hotter."""
DEFAULT_PWM_MODE = "averaged"


# --------------------------------------------------------------------------------------
# Action
# --------------------------------------------------------------------------------------


class DutyRange(NamedTuple):
    """The duty range an action in [-1, 1] is mapped onto, affinely.

    A tuple ``(low, high)`` (so ``lo, hi = env.duty_range`` works), and the one definition
    of the action <-> duty map: ``duty = low + (clip(a, -1, 1) + 1) / 2 * (high - low)``.
    """

    low: float
    high: float

    def duty_for(self, action: Any) -> Any:
        """Duty for an action (a float or an array), clipped to [-1, 1] first."""
        low, high = self
        if type(action) is float:  # one env step: no numpy call on this path
            a = -1.0 if action < -1.0 else (1.0 if action > 1.0 else action)
        else:
            a = np.clip(action, -1.0, 1.0)
        return low + (a + 1.0) * (0.5 * (high - low))

    def action_for(self, duty: Any) -> Any:
        """Inverse of :meth:`duty_for` (a float or an array; not clipped), for controllers
        that compute a duty."""
        low, high = self
        return (duty - low) / (0.5 * (high - low)) - 1.0


# --------------------------------------------------------------------------------------
# Observation
# --------------------------------------------------------------------------------------
OBS_POSITION = 0
"""Observation set with the position sensor (tracking and robustness envs)."""
OBS_SELF_SENSING = 1
"""Observation set without it: resistance, current and voltage readings (self-sensing env)."""

_REFERENCE_FEATURES = ("reference", "reference_rate", "preview_0.2s", "preview_0.5s", "preview_1s", "last_duty")
FEATURES = {
    OBS_POSITION: ("position", "resistance", "resistance_valid", *_REFERENCE_FEATURES, "error"),
    OBS_SELF_SENSING: ("resistance", "resistance_valid", "current", "voltage", *_REFERENCE_FEATURES),
}
"""Feature names of each observation set, in observation order."""

_BOUNDS = {
    "position": (-0.5, 1.5),
    "resistance": (-3.0, 3.0),
    "resistance_valid": (0.0, 1.0),
    "current": (-3.0, 3.0),
    "voltage": (-3.0, 3.0),
    "reference": (-0.5, 1.5),
    "reference_rate": (-10.0, 10.0),
    "preview_0.2s": (-0.5, 1.5),
    "preview_0.5s": (-0.5, 1.5),
    "preview_1s": (-0.5, 1.5),
    "last_duty": (0.0, 1.0),
    "error": (-2.0, 2.0),
}
"""Box bounds of each feature (float32, each scaled to order one and clipped to these)."""

_DEFINITIONS = {
    "position": "measured position / stroke",
    "resistance": "10 (R / R_cold - 1), last valid reading held",
    "resistance_valid": "1 if R could be read in this step (pulse >= 50 us), else 0",
    "current": "10 (I / I_cold - 1), last valid reading held",
    "voltage": "10 (V / V_supply - 1), last valid reading held",
    "reference": "r(t) / stroke",
    "reference_rate": "r'(t) * 1 s / stroke",
    "preview_0.2s": "r(t + 0.2 s) / stroke",
    "preview_0.5s": "r(t + 0.5 s) / stroke",
    "preview_1s": "r(t + 1 s) / stroke (a reversal must be anticipated by the time the wire takes to cool through the hysteresis)",
    "last_duty": "duty commanded in the last step, clipped (what the driver was given)",
    "error": "(r(t) - measured position) / stroke",
}

PREVIEW_1_S = 0.2
PREVIEW_2_S = 0.5
PREVIEW_3_S = 1.0

# The compiled task reads the bounds as compile-time tuples made from _BOUNDS.
_LOWS_POSITION = tuple(_BOUNDS[f][0] for f in FEATURES[OBS_POSITION])
_HIGHS_POSITION = tuple(_BOUNDS[f][1] for f in FEATURES[OBS_POSITION])
_LOWS_SELF_SENSING = tuple(_BOUNDS[f][0] for f in FEATURES[OBS_SELF_SENSING])
_HIGHS_SELF_SENSING = tuple(_BOUNDS[f][1] for f in FEATURES[OBS_SELF_SENSING])


def bounds(observation: int) -> tuple[np.ndarray, np.ndarray]:
    """Low and high bounds (float32) of an observation set's features."""
    names = FEATURES[observation]
    low = np.array([_BOUNDS[n][0] for n in names], dtype=np.float32)
    high = np.array([_BOUNDS[n][1] for n in names], dtype=np.float32)
    return low, high


def feature_table(observation: int) -> str:
    """The features of an observation set as a Markdown table (for the env docstrings)."""
    lines = ["| Num | Feature | Definition | Min | Max |", "|-----|---------|------------|-----|-----|"]
    for k, name in enumerate(FEATURES[observation]):
        low, high = _BOUNDS[name]
        lines.append(f"| {k} | `{name}` | {_DEFINITIONS[name]} | {low:g} | {high:g} |")
    return "\n".join(lines)


# --------------------------------------------------------------------------------------
# Info
# --------------------------------------------------------------------------------------
STATE_INFO = {
    "position_m": "true contraction [m]",
    "position_measured_m": "position reading [m]",
    "temperature_c": "wire temperature [degC]",
    "martensite_fraction": "martensite fraction [-]",
    "stress_pa": "wire stress [Pa]",
    "power_w": "mean electrical power of the step [W]",
    "electrical_energy_j": "electrical energy since reset [J]",
    "spring_force_n": "bias-spring force (what the report's force transducer reads) [N]",
    "duty": "duty commanded in the step, clipped to [0, duty_max] (the resolved PWM latches it at its next period; the end-of-travel cut may hold the power off: power_w is what was delivered)",
    "time_s": "simulated time since reset [s]",
}
"""``info`` entries that are simulator state quantities (names of ``Simulator.read``)."""

INFO = {
    **STATE_INFO,
    "reference_m": "reference position r(t) [m]",
    "reference_kind": "0 step, 1 ramp, 2 sine, 3 random (int)",
    "resistance_valid": "a resistance reading was taken in the step (bool)",
}
"""Every ``info`` key of every env (robustness adds :data:`~sma_gym.envs.conditions.CONDITION_INFO`)."""

_STATE_INFO_KEYS = tuple(STATE_INFO)
_READ_KEYS = (*STATE_INFO, "resistance_measured_ohm")


def info_list(entries: dict[str, str]) -> str:
    """``info`` entries as a Markdown list (for the env docstrings)."""
    return "\n".join(f"- `{key}`: {text}" for key, text in entries.items())


# --------------------------------------------------------------------------------------
# Per-actuator task state
# --------------------------------------------------------------------------------------
class TaskState:
    """Per-actuator task data (references, held sensor readings, last duty) and the task's
    settings: which observation set, the energy weight and the overheat limit."""

    def __init__(self, n: int, observation: int, energy_weight: float, overheat_limit_c: float):
        self.n = n
        self.observation = observation
        self.energy_weight = energy_weight
        self.overheat_limit_c = overheat_limit_c
        self.kind = np.zeros(n, dtype=np.int64)
        self.params = np.zeros((n, N_PARAMS))
        self.wp_t = np.full((n, N_WAYPOINTS), np.inf)
        self.wp_x = np.zeros((n, N_WAYPOINTS))
        self.held = np.zeros((n, 3))  # last valid R, I, V
        self.last_duty = np.zeros(n)
        self.penalty = np.zeros(n)
        """Each actuator's overheat penalty in its last reward (0 unless it overheated;
        :func:`overheat_penalty`): a bank whose reward is the mean over its actuators adds
        it back whole (:func:`bank_rewards`)."""
        self.references: list[Reference | None] = [None] * n

    def set_reference(self, i: int, ref: Reference) -> None:
        """Give actuator i a new reference."""
        self.kind[i] = ref.kind
        self.params[i] = ref.params
        self.wp_t[i] = ref.waypoint_t
        self.wp_x[i] = ref.waypoint_x
        self.references[i] = ref

    def describe_references(self, per_env: int = 1, envs: str = "actuators") -> list[dict[str, Any]]:
        """Each actuator's reference as a dict (kind, name, parameters); ``ResetNeeded``
        naming what has none yet (never reset): the ``envs`` (``"sub-envs"``, ``"banks"``)
        of ``per_env`` actuators each, numbered as their owner numbers them (a bank vector
        env of 2 banks named its 8 actuators)."""
        missing = sorted({i // per_env for i, ref in enumerate(self.references) if ref is None})
        if missing:
            shown = missing if len(missing) <= 10 else [*missing[:10], "..."]
            raise ResetNeeded(f"no reference yet for {envs} {shown}: call reset() first")
        return [ref.describe() for ref in self.references]  # type: ignore[union-attr]

    def reset_actuator(self, i: int, sim: Simulator) -> None:
        """Start actuator i's episode: readings held at the cold wire's values, no duty yet."""
        r_cold = float(sim.cold_resistance_ohm[i])
        v = float(sim.supply_voltage_v[i])
        self.held[i] = (r_cold, v / r_cold, v)
        self.last_duty[i] = 0.0

    def bind(
        self,
        sim: Simulator,
        actuators: np.ndarray,
        obs_out: np.ndarray,
        reward_out: np.ndarray,
        term_out: np.ndarray,
        ref_out: np.ndarray,
    ) -> Callable[[], None]:
        """A call without arguments that fills observations, rewards, termination flags and
        references (entry j for actuator ``actuators[j]``, an int64 array). An env step makes
        it every time (the arrays are updated in place, never replaced); a one-off use is
        ``bind(...)()``."""
        return partial(
            task_outputs,
            sim.state,
            sim.params,
            self.observation,
            self.kind,
            self.params,
            self.wp_t,
            self.wp_x,
            self.held,
            self.last_duty,
            self.energy_weight,
            self.overheat_limit_c,
            self.penalty,
            obs_out,
            reward_out,
            term_out,
            ref_out,
            actuators,
        )

    def info(self, sim: Simulator, reference_m: np.ndarray) -> dict[str, Any]:
        """The :data:`INFO` entries of every actuator, each an array of shape (n,)."""
        info: dict[str, Any] = sim.read(_STATE_INFO_KEYS)
        info["reference_m"] = reference_m.copy()
        info["reference_kind"] = self.kind.copy()
        info["resistance_valid"] = ~np.isnan(sim.resistance_measured_ohm)
        return info

    def info_of(self, sim: Simulator, i: int, reference_m: float) -> dict[str, Any]:
        """The :data:`INFO` entries of actuator i as Python scalars (json.dumps and loggers
        refuse numpy scalars such as ``np.bool_``)."""
        values = sim.read_actuator_values(i, _READ_KEYS)
        info: dict[str, Any] = dict(zip(_STATE_INFO_KEYS, values))  # all but the last, the reading
        info["reference_m"] = float(reference_m)
        info["reference_kind"] = int(self.kind[i])
        info["resistance_valid"] = not math.isnan(values[-1])  # a reading was taken
        return info


PENALTY_STEPS = float(EPISODE_STEPS)
"""Steps of :func:`overheat_penalty`: the registered episode's (:data:`~sma_gym.envs.EPISODE_STEPS`)."""


@njit(cache=True, error_model="numpy", _nrt=False)
def overheat_penalty(power_ratio: float, energy_weight: float) -> float:
    """The reward added on a step that ends the episode by overheating (negative): a whole
    registered episode (:data:`PENALTY_STEPS`) spent a full stroke off the reference at the
    power that overheated the wire, i.e. ``-PENALTY_STEPS * (1 + energy_weight * P_el / P_full)``.

    Why: every step's reward is negative, so without it an episode that ends early pays.
    On a wire without an end-of-travel cut (the real bench's twins) holding duty 1 overheated
    it in 1.2 s for a return of -60 to -74, better than the report's controllers on three
    seeds of four (a new user's trial). With it no episode of the registered length or
    shorter is worse than overheating. ``power_ratio`` is ``P_el / P_full`` of that step.
    Compiled: :func:`task_outputs` calls it, and Python may too."""
    return -PENALTY_STEPS * (1.0 + energy_weight * power_ratio)


# Without numba's reference counting (as core.kernel._advance; it allocates nothing): the
# row views and the reference calls cost a pair of atomic updates each, about 7 % of a
# single env's step.
@njit(cache=True, error_model="numpy", _nrt=False)
def task_outputs(
    state,
    params,
    observation,
    kind,
    ref_p,
    wp_t,
    wp_x,
    held,
    last_duty,
    energy_weight,
    overheat_c,
    penalty_out,
    obs_out,
    reward_out,
    term_out,
    ref_out,
    actuators,
):
    """Fill observation rows, rewards, termination flags and references for ``actuators``."""
    for j in range(actuators.shape[0]):
        i = actuators[j]
        p = params[i]
        s = state[i]
        stroke = p[L.P_STROKE]
        r_cold = p[L.P_R_COLD]
        v_supply = p[L.P_V_SUPPLY]
        i_cold = v_supply / r_cold
        t = s[L.S_TIME]
        r, rate = evaluate(kind[i], ref_p[i], wp_t[i], wp_x[i], t)
        r1 = evaluate(kind[i], ref_p[i], wp_t[i], wp_x[i], t + PREVIEW_1_S)[0]
        r2 = evaluate(kind[i], ref_p[i], wp_t[i], wp_x[i], t + PREVIEW_2_S)[0]
        r3 = evaluate(kind[i], ref_p[i], wp_t[i], wp_x[i], t + PREVIEW_3_S)[0]
        valid = 0.0
        if s[L.S_R_MEAS] == s[L.S_R_MEAS]:  # not NaN: a reading was taken
            valid = 1.0
            held[i, 0] = s[L.S_R_MEAS]
            held[i, 1] = s[L.S_I_MEAS]
            held[i, 2] = s[L.S_V_MEAS]
        x_meas = s[L.S_POS_MEAS] / stroke
        rn = r / stroke
        res = 10.0 * (held[i, 0] / r_cold - 1.0)
        # The reference, its preview and the last duty: the same in both observations.
        task_feats = (rn, rate / stroke, r1 / stroke, r2 / stroke, r3 / stroke, last_duty[i])
        if observation == OBS_POSITION:
            feats = (x_meas, res, valid) + task_feats + (rn - x_meas,)
            lows = _LOWS_POSITION
            highs = _HIGHS_POSITION
        else:
            i_feat = 10.0 * (held[i, 1] / i_cold - 1.0)
            v_feat = 10.0 * (held[i, 2] / v_supply - 1.0)
            feats = (res, valid, i_feat, v_feat) + task_feats
            lows = _LOWS_SELF_SENSING
            highs = _HIGHS_SELF_SENSING
        for k in range(len(feats)):
            value = feats[k]
            if value < lows[k]:
                value = lows[k]
            elif value > highs[k]:
                value = highs[k]
            obs_out[j, k] = value
        p_full = v_supply * v_supply / r_cold
        energy = energy_weight * s[L.S_POWER] / p_full
        reward_out[j] = -abs(s[L.S_X] - r) / stroke - energy
        overheated = s[L.S_T] > overheat_c
        term_out[j] = overheated
        penalty = overheat_penalty(s[L.S_POWER] / p_full, energy_weight) if overheated else 0.0
        penalty_out[i] = penalty
        reward_out[j] += penalty
        ref_out[j] = r


def bank_rewards(rewards: np.ndarray, penalties: np.ndarray) -> np.ndarray:
    """Each bank's reward from its actuators' (last axis): their mean, plus the rest of each
    overheat penalty, so that an actuator that overheats costs the bank the whole penalty
    (the mean carried 1/n of it: 250 steps' worth on a bank of four), while each actuator's
    own reward (``actuator_rewards``, a bank agent's per-actuator reward) carries it once."""
    n = rewards.shape[-1]
    return rewards.mean(axis=-1) + (n - 1) * penalties.mean(axis=-1)


def warn_step_after_termination() -> None:
    """Gymnasium's classic-control warning (CartPole's) for a step after the episode
    terminated: the simulation goes on (the wire keeps its state), but what follows is no
    episode; the native vector envs refuse such a step with autoreset disabled."""
    logger.warn(
        "step() after the episode terminated (the wire passed overheat_limit_c): call reset() first; "
        "further steps go on simulating the overheated wire and belong to no episode"
    )


class UnstartedEnvs:
    """Which envs (of a vector env: sub-envs) were never reset: stepping one would run an
    episode without a reference or a noise generator, so the step is refused, as Gymnasium's
    ``OrderEnforcing`` refuses it behind ``gym.make``, also for a class built directly or
    stepped through ``env.unwrapped``. One ``bool`` test per step once all started."""

    def __init__(self, n: int, vector: bool = True):
        self._never = np.ones(n, dtype=bool)
        self._all_started = False
        self._vector = vector

    def started(self, envs: np.ndarray | slice = slice(None)) -> None:
        if not self._all_started:
            self._never[envs] = False
            self._all_started = not self._never.any()

    def require_none(self, what: str = "step()") -> None:
        if not self._all_started:
            if not self._vector:
                raise ResetNeeded(f"the env was never reset: call reset() before {what}")
            never = np.flatnonzero(self._never).tolist()
            shown = never if len(never) <= 10 else [*never[:10], "..."]
            raise ResetNeeded(f"sub-envs {shown} were never reset: call reset() before {what}")

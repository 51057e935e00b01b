"""The evaluation harness: any policy through the report's experiments, scored its way.

``sma-gym evaluate --out DIR [--policy PATH ...] [--json]`` (:mod:`sma_gym_agents.commands`) or
:func:`evaluate` runs:

* **Table 6.1** (§6): the ten controller configurations under standard conditions on the
  8 mm step and the 0.1 Hz, 3 mm sine: overshoot, steady-state error, largest tracking
  error while heating and while cooling, beside the report's numbers; plots like figs.
  6.2, 6.3, 6.5, 6.6.
* **Chapter 7**: PID, VSC3, VSC4 with and without feedforward under forced convection,
  5 V, 15 V, 0.2 mm and 0.5 mm wire (not retuned).
* **Chapter 8**: efficiency of 1 -> 7 mm steps at 5 / 7.5 / 10 / 15 V and of 1, 2, 3 s
  ramps at 10 V, beside Tables 8.1 / 8.2.
* **Chapter 9**: rise time and oscillation against the number of multiplexed actuators
  (1, 8, 16), the cycling frequency (100-4000 Hz) and the supply (10, 15, 20 V), and the
  I/O counts of Table 9.1, for PID on fixed slots (the report's scheme) and PID under the
  budget allocator on a shared budget (:mod:`sma_gym_agents.bank`); and the bank step
  (issue 16): 16 actuators at 10 V, 15 holding random positions, one stepping 0 -> 8 mm,
  rise time of the stepping one in both schemes.

Every run also records the RMS tracking error and the electrical energy, over several
seeds (sensor noise differs per seed); tables give the mean and the worst case over seeds,
so a trained agent and a baseline are compared on the same numbers.

Conventions. Error e = r - x on the true position (mm). Step: the report's 8 mm step at
0.5 s, 6 s long; overshoot = max(x) - 8 mm after the step; steady-state error = mean e
over the last second, reported as "oscillates" when the position still moves by more
than 0.1 mm peak to peak there about its least-squares line (a settling tail or a drift is
not an oscillation). Sine: 30 s (three periods), heating / cooling errors are
the signed e of largest magnitude while r rises / falls, over the last two periods; RMS
over the same window. Step RMS over the whole run. Baselines run at the report's 1 kHz
with the PWM resolved (``pwm_mode="resolved"``: the report's FPGA latches the duty once per
PWM period and samples the position at the period's end, §3.3-3.4, so a sample reaches the
wire 2 ms later) and their position filter at 11 Hz (docs/model.md §10); a trained agent at the control period and PWM mode it
was trained with. Two kinds of baseline keep the controllers' default 50 Hz filter and the
env's averaged PWM, at 1 kHz: the self-sensing readers (fed by the resistance, whose
loop the report does not time) and the controllers of the multiplexed bank; their
comparisons with the sensor-fed controllers differ in filter and PWM timing too. Sensor noise: 2 um (the report's
controllers filter their input against noise, so there should be some).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from sma_gym._validation import require_int_range, require_positive
from sma_gym.electrical.multiplexer import SCHEMES
from sma_gym.envs.references import report_sine, report_step
from sma_gym.envs.single import SELF_SENSING
from sma_gym.model import ModelConfig, load_model, model_names
from sma_gym.params import preset, preset_names
from sma_gym_agents.bank import bank_policy
from sma_gym_agents.card import ALLOCATIONS, BANK_ENV_ID
from sma_gym_agents.controllers import (
    ALL_SPECS,
    PID,
    REPORT_FILTER_CUTOFF_HZ,
    VSC3,
    VSC4,
    ControllerSpec,
    spec_by_label,
    with_feedforward,
)
from sma_gym_agents.policies import ControllerPolicy, SelfSensingPolicy
from sma_gym_agents.trained import AgentPolicy

STEP_SECONDS = 6.0
STEP_TIME_S = 0.5
STEP_LEVEL_M = 8e-3
SINE_SECONDS = 30.0
SINE_WINDOW_S = (10.0, 30.0)
EVAL_NOISE_M = 2e-6
DEFAULT_SEEDS = (0, 1, 2)


def require_seeds(seeds: Any) -> tuple[int, ...]:
    """``seeds`` as a tuple of integers in [0, 2**32 - 1], at least one: the seeds a run uses,
    as given (until 2026-12-07 a rollout ran ``seeds[0] + i`` whatever followed it, and 1.5
    ran as 1)."""
    if isinstance(seeds, (str, bytes)) or not isinstance(seeds, Iterable):
        raise ValueError(f"seeds = {seeds!r}: expected a sequence of integer seeds, e.g. [0, 1, 2]")
    chosen = tuple(require_int_range("seed", s, 0, 2**32 - 1) for s in seeds)
    if not chosen:
        raise ValueError(f"seeds = {seeds!r}: expected at least one integer seed, e.g. [0]")
    return chosen


BASELINE_PERIOD_S = 1e-3
OSCILLATION_P2P_M = 0.1e-3
BASELINE_ENV_KWARGS = {"control_period_s": BASELINE_PERIOD_S, "pwm_mode": "resolved"}
"""The report's sensor-fed controllers run with its loop timing: a 1 kHz loop, the PWM
resolved (and their position filter at ``REPORT_FILTER_CUTOFF_HZ``, docs/model.md §10); the
self-sensing and bank baselines do not (see the module docstring)."""

TABLE_6_1 = {
    # controller: (overshoot, steady-state error, max error heating, max error cooling) [mm]
    "PID": (0.757, 0.000, 0.061, -0.097),
    "VSC1": (0.745, None, -1.050, -0.898),
    "VSC2": (0.381, 0.046, 0.094, -0.014),
    "VSC3": (0.000, 0.046, 0.103, -0.021),
    "VSC4": (0.057, 0.000, 0.077, -0.219),
    "PID + FF": (0.814, 0.000, 0.061, -0.097),
    "VSC1 + FF": (0.717, None, -1.058, -1.382),
    "VSC2 + FF": (0.371, 0.010, 0.059, -0.054),
    "VSC3 + FF": (0.022, 0.010, 0.063, 0.035),
    "VSC4 + FF": (0.130, 0.000, 0.057, 0.106),
}
CHAPTER_7_CONDITIONS = (
    ("standard", "standard"),
    ("forced convection", "forced-convection"),
    ("5 V", "supply-5v"),
    ("15 V", "supply-15v"),
    ("0.2 mm wire", "wire-0.2mm"),
    ("0.5 mm wire", "wire-0.5mm"),
)
CHAPTER_7_SPECS = (PID, VSC3, VSC4, with_feedforward(PID), with_feedforward(VSC3), with_feedforward(VSC4))
CHAPTER_8_CASES = (
    # label, preset, ramp seconds (0 = step), report efficiency [%]
    ("step 5 V", "supply-5v", 0.0, 0.12),
    ("step 7.5 V", "supply-7.5v", 0.0, 0.42),
    ("step 10 V", "supply-10v", 0.0, 0.51),
    ("step 15 V", "supply-15v", 0.0, 0.60),
    ("ramp 1 s", "supply-10v", 1.0, 0.34),
    ("ramp 2 s", "supply-10v", 2.0, 0.24),
    ("ramp 3 s", "supply-10v", 3.0, 0.18),
)
EFFICIENCY_HOLD_S = 4.0
EFFICIENCY_AFTER_S = 6.0
CHAPTER_9_STEP_M = 3e-3
"""[m] = 3 mm: the step of chapter 9's runs. The report does not state its size (figs.
9.1-9.4 plot positions up to 8-10 mm). A bank of 16 at 10 V gets at most 1/16 = 0.0625 of
the duty, which holds the wire near 5 mm (fig. 6.4, row A26: 0.06 at 5 mm), so the report's
8 mm step of chapter 6 would never be reached and its "approximately nine seconds" rise
(row 9f) needs a step well inside that reach; 3 mm is our choice, and rows 9f, 9h and 9k
depend on it."""
CHAPTER_9_SECONDS = {1: 4.0, 8: 10.0, 16: 25.0}
CHAPTER_9_COUNTS = ((1, 10.0), (8, 10.0), (16, 10.0), (16, 15.0), (16, 20.0), (1, 20.0), (8, 20.0))
CHAPTER_9_FREQUENCIES = (100.0, 500.0, 1000.0, 2000.0, 3000.0, 4000.0)
BANK_BASELINE_SPECS = (PID, with_feedforward(VSC3), VSC4, with_feedforward(VSC4))
"""The report's controllers a bank agent is compared with, per actuator (the best one counts)."""
BANK_PRIORITY_SPEC = with_feedforward(VSC3)
"""The controller of the priority allocator a shared-budget bank agent is also compared with
(on 16 independent references the four controllers under it differ by under 0.01 mm: the
allocation, not the controller, sets the error)."""
BANK_STEP_N = 16
BANK_STEP_VOLTAGE_V = 10.0
BANK_STEP_LEVEL_M = 8e-3
BANK_HOLD_RANGE_M = (1e-3, 6e-3)
"""The holders' positions are drawn uniformly from this range (within the stroke, and each
holdable on a 1/16 slot at 10 V: holding 8 mm takes 5.8 % duty)."""
BANK_STEP_TIME_S = 40.0
"""The step comes after the holders have settled in both schemes (fixed slots take ~30 s)."""
BANK_STEP_MAX_S = 300.0
"""Longest wait for the stepping actuator after its step; not reached by then: rise = inf."""


# --------------------------------------------------------------------------------------
# Policies to evaluate
# --------------------------------------------------------------------------------------
@dataclass
class PolicyEntry:
    """A policy and the env it runs on (baselines: tracking env at 1 kHz)."""

    name: str
    make: Callable[[Any], Any]
    env_id: str = "SMATracking-v0"
    env_kwargs: dict = field(default_factory=lambda: {"control_period_s": BASELINE_PERIOD_S})
    frame_stack: int = 1
    kind: str = "baseline"
    shares_env: bool = False
    """The policy reads nothing of its env but the constants of its own columns (the report's
    controllers, :func:`baseline`), so several run side by side in one vector env
    (:func:`batchable`). A policy of your own runs alone: batched, it saw the other entries'
    columns in ``num_envs`` and the spaces (and failed on shapes)."""


def baseline(spec: ControllerSpec | str, self_sensing: bool = False) -> PolicyEntry:
    """The report's controller ``spec`` (a label or a spec) as an entry; ``self_sensing``:
    fed by the position estimated from resistance, on the self-sensing env."""
    s = spec_by_label(spec) if isinstance(spec, str) else spec
    if self_sensing:
        return PolicyEntry(
            f"{s.label} (self-sensing)",
            lambda env, s=s: SelfSensingPolicy(s, env),
            env_id="SMASelfSensing-v0",
        )
    return PolicyEntry(
        s.label,
        lambda env, s=s: ControllerPolicy(s, env, filter_cutoff_hz=REPORT_FILTER_CUTOFF_HZ),
        env_kwargs=dict(BASELINE_ENV_KWARGS),
        shares_env=True,
    )


def bank_entry(spec: ControllerSpec | str, scheme: str, allocation: str = "proportional") -> PolicyEntry:
    """The report's controller per actuator on a multiplexed bank: on fixed slots (Table 9.1's
    scheme) or on a shared budget under the budget allocator (``allocation="proportional"``)
    or the priority allocator (``"priority"``) (:func:`sma_gym_agents.bank.bank_policy`)."""
    s = spec_by_label(spec) if isinstance(spec, str) else spec
    if allocation not in ALLOCATIONS:
        raise ValueError(f"allocation = {allocation!r}: expected one of {ALLOCATIONS}")
    if scheme not in SCHEMES:
        raise ValueError(f"scheme = {scheme!r}: expected one of {SCHEMES}")
    if scheme != "shared_budget":
        suffix = "fixed slots"
    else:
        suffix = "priority allocator" if allocation == "priority" else "budget allocator"
    return PolicyEntry(
        f"{s.label} ({suffix})",
        lambda env, s=s: bank_policy(s, env, allocation),
        env_id="SMAMultiplexed-v0",
        env_kwargs={"control_period_s": BASELINE_PERIOD_S, "scheme": scheme},
    )


def agent_entry(agent: AgentPolicy) -> PolicyEntry:
    env_id = agent.env_id
    kwargs = {k: v for k, v in agent.env_kwargs.items() if k in ("control_period_s", "pwm_mode", "energy_weight")}
    if env_id == "SMARobust-v0":
        # Same observation as the tracking env; conditions are set through the model.
        env_id = "SMATracking-v0"
    return PolicyEntry(
        agent.name,
        lambda env, a=agent: a,
        env_id=env_id,
        env_kwargs=kwargs,
        frame_stack=agent.frame_stack,
        kind="agent",
    )


# --------------------------------------------------------------------------------------
# Running episodes
# --------------------------------------------------------------------------------------
@dataclass
class Trace:
    """Recorded signals, each (steps, seeds) or (steps, seeds, actuators)."""

    t: np.ndarray
    data: dict[str, np.ndarray]

    def __getitem__(self, key: str) -> np.ndarray:
        return self.data[key]


_RECORD = (
    "position_m",
    "position_measured_m",
    "reference_m",
    "duty",
    "power_w",
    "electrical_energy_j",
    "spring_force_n",
    "temperature_c",
)


def make_venv(entry: PolicyEntry, n_envs: int, seconds: float, env_kwargs: dict):
    """A Gymnasium vector env of ``n_envs`` copies (the native one where there is one).

    Episodes are one step longer than the run, so no autoreset happens while recording.
    """
    import gymnasium as gym

    import sma_gym  # noqa: F401  (registers the ids)

    kwargs = {**entry.env_kwargs, **env_kwargs}
    dt = kwargs.get("control_period_s", 0.01)
    seconds = require_positive("seconds", seconds, "s")
    steps = int(round(seconds / dt))
    if steps < 1:
        raise ValueError(f"seconds = {seconds!r}: expected at least one control period ({dt!r} s)")
    spec = gym.spec(entry.env_id)
    mode = "vector_entry_point" if spec.vector_entry_point is not None else "sync"
    venv = gym.make_vec(
        "sma_gym:" + entry.env_id, num_envs=n_envs, vectorization_mode=mode, max_episode_steps=steps + 1, **kwargs
    )
    return venv, steps, dt


def rollout(entry: PolicyEntry, **options: Any) -> Trace:
    """Run ``entry`` once per seed on ``reference`` for ``seconds``; record the true state.

    ``options`` are :func:`rollouts`'s keywords (``model``, ``reference``, ``seconds``,
    ``seeds``, ``noise_m``, ``env_kwargs``). Column i of the run is seeded ``seeds[i]`` (sensor
    noise differs per seed). Agents trained on stacked observations get them stacked by
    stable-baselines3's own ``StackedObservations``, exactly as ``VecFrameStack`` did in
    training.
    """
    return rollouts([entry], **options)[0]


def rollouts(
    entries: Sequence[PolicyEntry],
    *,
    model: Any = "standard",
    reference: Any,
    seconds: float,
    seeds: Sequence[int] = DEFAULT_SEEDS,
    noise_m: float = EVAL_NOISE_M,
    env_kwargs: dict | None = None,
) -> list[Trace]:
    """:func:`rollout` for several entries side by side in one vector env (one trace each).

    The entries must share env id, env kwargs and frame stack (:func:`batchable`). Entry k
    runs on columns k*S ... k*S + S - 1 (S = len(seeds)), seeded ``seeds[i]`` exactly as
    when it runs alone, and its policy sees only its columns, so each trace equals the one
    :func:`rollout` gives; only the Python overhead per control step is shared.
    """
    seeds = require_seeds(seeds)
    if not entries:
        raise ValueError("rollouts: no entries: expected at least one policy entry")
    first = entries[0]
    if any(
        (e.env_id, e.env_kwargs, e.frame_stack) != (first.env_id, first.env_kwargs, first.frame_stack) for e in entries
    ):
        raise ValueError("rollouts: entries must share env id, env kwargs and frame stack")
    width = len(seeds)
    kwargs = {"model": model, "reference": reference, "position_noise_std_m": noise_m, **(env_kwargs or {})}
    venv, steps, dt = make_venv(first, width * len(entries), seconds, kwargs)
    if len(entries) == 1:
        policies = [first.make(venv)]
    else:
        policies = [e.make(_ColumnView(venv, slice(k * width, (k + 1) * width))) for k, e in enumerate(entries)]
    for policy in policies:
        if hasattr(policy, "reset"):
            policy.reset()
    obs, _ = venv.reset(seed=[s for _ in entries for s in seeds])
    n = width * len(entries)
    stacker = None
    if first.frame_stack > 1:
        from stable_baselines3.common.vec_env.stacked_observations import StackedObservations

        stacker = StackedObservations(n, first.frame_stack, venv.single_observation_space)
        obs = stacker.reset(obs)
    record: dict[str, list] = {k: [] for k in _RECORD}
    starts = np.ones(n, dtype=bool)
    for _ in range(steps):
        actions = [
            p.predict(
                obs[k * width : (k + 1) * width], episode_start=starts[k * width : (k + 1) * width], deterministic=True
            )[0]
            for k, p in enumerate(policies)
        ]
        action = actions[0] if len(actions) == 1 else np.concatenate(actions)
        starts = np.zeros(n, dtype=bool)
        obs, _, terminated, truncated, info = venv.step(action)
        if stacker is not None:
            obs, _ = stacker.update(obs, terminated | truncated, [{} for _ in range(n)])
        for key in _RECORD:
            record[key].append(np.asarray(info[key], dtype=float))
        if np.any(terminated | truncated):
            ended = np.flatnonzero(terminated | truncated)
            venv.close()
            raise EpisodeEnded(
                {entries[i // width].name: float(np.asarray(info["time_s"])[i]) for i in ended[::-1]},
                float(np.max(np.asarray(info["temperature_c"])[ended])),
                str(reference),
            )
    venv.close()
    data = {k: np.asarray(v, dtype=float) for k, v in record.items()}
    t = (np.arange(steps) + 1) * dt
    return [
        Trace(t=t, data={k: v[:, k_ * width : (k_ + 1) * width] for k, v in data.items()}) for k_ in range(len(entries))
    ]


class EpisodeEnded(RuntimeError):
    """An evaluation episode ended before its run did: the policy let the wire overheat
    (the env's ``overheat_limit_c``). ``ended_s`` maps each such policy to the time [s]."""

    def __init__(self, ended_s: dict[str, float], temperature_c: float, reference: str):
        self.ended_s = ended_s
        self.temperature_c = temperature_c
        where = ", ".join(f"{name} at t = {t:.3f} s" for name, t in ended_s.items())
        super().__init__(
            f"reference {reference}: an evaluation episode ended early, {where} "
            f"(overheated: {temperature_c:.1f} degC, the env's overheat limit)"
        )


ENDED_EARLY = "ended_early_s"
"""The metric recorded instead of a policy's others when its episode overheated: the time it ended [s]."""


def rollouts_that_finish(
    entries: Sequence[PolicyEntry], results: Results, key: tuple[str, str, str], **options: Any
) -> list[tuple[PolicyEntry, Trace]]:
    """:func:`rollouts` of ``entries``; a policy whose episode overheats is recorded under
    ``key`` (experiment, condition, reference) as :data:`ENDED_EARLY` and the others run
    again without it, so one policy that overheats the wire does not cost the rest."""
    while entries:
        try:
            return list(zip(entries, rollouts(entries, **options)))
        except EpisodeEnded as ended:
            experiment, condition, reference = key
            for name, t in ended.ended_s.items():
                results.records += _records(experiment, name, condition, reference, {ENDED_EARLY: np.array([t])})
            entries = [e for e in entries if e.name not in ended.ended_s]
    return []


def batchable(entries: Sequence[PolicyEntry]) -> list[list[PolicyEntry]]:
    """``entries`` in groups that :func:`rollouts` can run together, order kept.

    Only the report's controllers on the tracking env: their policies read nothing of the
    env but its constants, so they can share one; any other entry runs alone.
    """
    groups: list[list[PolicyEntry]] = []
    for e in entries:
        shareable = e.shares_env and e.env_id == "SMATracking-v0" and e.frame_stack == 1
        last = groups[-1] if groups else None
        if (
            shareable
            and last
            and last[0].shares_env
            and (last[0].env_id, last[0].env_kwargs, last[0].frame_stack) == (e.env_id, e.env_kwargs, 1)
        ):
            last.append(e)
        else:
            groups.append([e])
    return groups


class _ColumnView:
    """What a policy reads from a vector env (its constants), restricted to some columns."""

    def __init__(self, venv: Any, columns: slice):
        self._venv = getattr(venv, "unwrapped", venv)
        self._columns = columns

    def __getattr__(self, name: str) -> Any:
        if name in ("get_attr", "unwrapped") or name.startswith("_"):
            raise AttributeError(name)
        value = getattr(self._venv, name)
        if isinstance(value, np.ndarray) and value.ndim >= 1 and value.shape[0] == self._venv.num_envs:
            return value[self._columns]
        return value


# --------------------------------------------------------------------------------------
# Metrics (per seed; lengths in metres)
# --------------------------------------------------------------------------------------
def step_metrics(
    trace: Trace, step_time_s: float = STEP_TIME_S, level_m: float = STEP_LEVEL_M
) -> dict[str, np.ndarray]:
    x, r, t = trace["position_m"], trace["reference_m"], trace.t
    after = t >= step_time_s
    tail = t >= t[-1] - 1.0
    p2p = oscillation_p2p(t, x, 1.0)
    sse = np.mean((r - x)[tail], axis=0)
    rise = np.array([_first(t, x[:, j] >= 0.9 * level_m) - step_time_s for j in range(x.shape[1])])
    return {
        "overshoot_m": np.maximum(0.0, x[after].max(axis=0) - level_m),
        "steady_state_error_m": np.where(p2p > OSCILLATION_P2P_M, np.nan, sse),
        "oscillation_p2p_m": p2p,
        "rise_time_s": rise,
        "rms_error_m": np.sqrt(np.mean((r - x) ** 2, axis=0)),
        "energy_j": trace["electrical_energy_j"][-1],
    }


def sine_metrics(trace: Trace, window: tuple[float, float] = SINE_WINDOW_S) -> dict[str, np.ndarray]:
    x, r, t = trace["position_m"], trace["reference_m"], trace.t
    w = (t >= window[0]) & (t <= window[1])
    e = (r - x)[w]
    rate = np.gradient(r, axis=0)[w]
    heat = np.array([_signed_extreme(e[rate[:, j] > 0, j]) for j in range(e.shape[1])])
    cool = np.array([_signed_extreme(e[rate[:, j] < 0, j]) for j in range(e.shape[1])])
    energy = trace["electrical_energy_j"]
    return {
        "max_error_heating_m": heat,
        "max_error_cooling_m": cool,
        "rms_error_m": np.sqrt(np.mean(e**2, axis=0)),
        "energy_j": energy[-1] - energy[w][0],
    }


def efficiency_percent(trace: Trace, start_s: float = EFFICIENCY_HOLD_S, end_level_m: float = 6.9e-3) -> np.ndarray:
    """integral(F dx) / integral(P dt) from ``start_s`` until x first reaches ``end_level_m``."""
    t, x, f, p = trace.t, trace["position_m"], trace["spring_force_n"], trace["power_w"]
    dt = t[1] - t[0]
    k0 = int(np.searchsorted(t, start_s))
    out = []
    for j in range(x.shape[1]):
        crossing = np.flatnonzero(x[k0:, j] >= end_level_m)
        if not crossing.size:
            out.append(math.nan)  # never reached 7 mm: no stroke to rate
            continue
        end = k0 + crossing[0]
        dx = np.diff(x[k0 - 1 : end + 1, j])
        work = np.sum(0.5 * (f[k0 - 1 : end, j] + f[k0 : end + 1, j]) * dx)
        energy = np.sum(p[k0 : end + 1, j]) * dt
        out.append(100.0 * work / energy if energy > 0.0 else math.nan)
    return np.array(out)


def rise_and_oscillation(trace: Trace, level_m: float = CHAPTER_9_STEP_M) -> tuple[np.ndarray, np.ndarray]:
    """Rise time to 90 % and the oscillation (:func:`oscillation_p2p`) over the last 2 s (actuator 0)."""
    x = trace["position_m"]
    x0 = x[:, :, 0] if x.ndim == 3 else x
    t = trace.t
    rise = np.array([_first(t, x0[:, j] >= 0.9 * level_m) for j in range(x0.shape[1])])
    return rise, oscillation_p2p(t, x0, 2.0)


def oscillation_p2p(t: np.ndarray, x: np.ndarray, seconds: float) -> np.ndarray:
    """Peak to peak of ``x`` (samples x columns) about its least-squares line over the last
    ``seconds`` [m]: the size of an oscillation, not of a drift or a settling's tail. (The
    raw peak to peak of one actuator's 4 s step, still settling monotonically 0.1 mm above
    its level at 2 s, read 0.128 mm: "oscillates" by the 0.1 mm bar.)"""
    tail = t >= t[-1] - seconds
    tt = t[tail] - t[tail].mean()
    xx = x[tail] - x[tail].mean(axis=0)
    slope = (tt @ xx) / (tt @ tt)
    return np.ptp(xx - np.multiply.outer(tt, slope), axis=0)


def _first(t: np.ndarray, mask: np.ndarray) -> float:
    idx = np.flatnonzero(mask)
    return float(t[idx[0]]) if idx.size else math.inf


def _signed_extreme(e: np.ndarray) -> float:
    return float(e[np.argmax(np.abs(e))]) if e.size else math.nan


# --------------------------------------------------------------------------------------
# Results
# --------------------------------------------------------------------------------------
LOWER_IS_BETTER = {
    "overshoot_m",
    "rms_error_m",
    "energy_j",
    "rise_time_s",
    "half_rise_time_s",
    "oscillation_p2p_m",
    "holders_settled_error_m",
    "holders_max_error_m",
}
ABS_LOWER_IS_BETTER = {"steady_state_error_m", "max_error_heating_m", "max_error_cooling_m"}


@dataclass
class Record:
    """One metric of one policy on one condition and reference (over seeds)."""

    experiment: str
    policy: str
    condition: str
    reference: str
    metric: str
    value: float
    worst: float
    seeds: int

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        for key in ("value", "worst"):
            if isinstance(d[key], float) and not math.isfinite(d[key]):
                d[key] = None if math.isnan(d[key]) else ("inf" if d[key] > 0 else "-inf")
        return d


def _records(
    experiment: str, policy: str, condition: str, reference: str, metrics: dict[str, np.ndarray]
) -> list[Record]:
    out = []
    for name, values in metrics.items():
        v = np.asarray(values, dtype=float)
        if np.all(np.isnan(v)):
            mean = worst = math.nan
        else:
            mean = float(np.nanmean(v))
            if name in ABS_LOWER_IS_BETTER:
                worst = float(v[np.nanargmax(np.abs(v))]) if np.any(np.isfinite(v)) else math.nan
            elif name in ("efficiency_percent", "highest_position_m"):
                worst = float(np.nanmin(v))
            else:
                worst = float(np.nanmax(v))
            if np.any(np.isnan(v)):
                mean = worst = math.nan  # e.g. one seed oscillates: no steady state
        out.append(Record(experiment, policy, condition, reference, name, mean, worst, len(v)))
    return out


@dataclass
class Results:
    records: list[Record] = field(default_factory=list)
    traces: dict[tuple, Trace] = field(default_factory=dict)
    scales: dict[str, float] = field(default_factory=dict)
    """Each Table 6.1 condition's :func:`stroke_scale` (its references' levels over the report's)."""
    notes: list[str] = field(default_factory=list)
    """What a reader should know that no table shows (e.g. an agent a chapter did not score)."""
    _models: dict[str, str] = field(default_factory=dict, repr=False)

    def value(
        self, experiment: str, policy: str, condition: str, reference: str, metric: str, worst: bool = False
    ) -> float:
        for r in self.records:
            if (r.experiment, r.policy, r.condition, r.reference, r.metric) == (
                experiment,
                policy,
                condition,
                reference,
                metric,
            ):
                return r.worst if worst else r.value
        raise KeyError((experiment, policy, condition, reference, metric))

    def distinct(self, experiment: str, field: str = "policy") -> list[str]:
        """The values of a record field (``policy``, ``condition``) in ``experiment``, in run order."""
        seen: list[str] = []
        for r in self.records:
            if r.experiment == experiment and getattr(r, field) not in seen:
                seen.append(getattr(r, field))
        return seen

    def to_json(self) -> str:
        return json.dumps([r.as_dict() for r in self.records], indent=1)


# --------------------------------------------------------------------------------------
# Experiments
# --------------------------------------------------------------------------------------
def run_table_6_1(
    entries: Sequence[PolicyEntry],
    results: Results,
    seeds: Sequence[int] = DEFAULT_SEEDS,
    condition: str | None = None,
    model: Any = "standard",
    sine_seconds: float = SINE_SECONDS,
) -> None:
    """Table 6.1's step and sine for ``entries`` on ``model``, recorded under ``condition``.

    ``condition`` defaults to ``"standard"`` for the report's standard model (given by that
    name), else to ``"model <name>"``: the report's numbers are set beside ``"standard"``
    only, so another actuator's results are never compared with the report's.
    """
    _require_sine_seconds(sine_seconds)
    if condition is None:
        condition = table_6_1_condition(model)
    key = _model_key(model)
    if results._models.setdefault(condition, key) != key:
        # Two actuators that share a name would be read as one table.
        raise ValueError(
            f"condition = {condition!r}: these results already hold Table 6.1 of another model under it; "
            "give condition= a label of its own for this one"
        )
    results.scales[condition] = stroke_scale(model)
    for group in batchable(entries):
        _step_and_sine("6.1", group, model, condition, results, seeds, sine_seconds)


def distinct_condition(results: Results, condition: str, model: Any) -> str:
    """``condition``, or where ``results`` already hold another model under it (two actuators
    named alike), the label with a short digest of this model's configuration added."""
    key = _model_key(model)
    if results._models.get(condition, key) == key:
        return condition
    return f"{condition} [{hashlib.sha256(key.encode()).hexdigest()[:8]}]"


def table_6_1_condition(model: Any) -> str:
    """The condition Table 6.1 on ``model`` is recorded under: ``"standard"`` for the report's
    standard model (given by that name or as None), else ``"model <name>"``."""
    return "standard" if is_standard(model) else f"model {_model_label(model)}"


def self_sensing_condition(model: Any) -> str:
    """The condition the self-sensing comparison on ``model`` is recorded under:
    ``"self-sensing"`` on the report's (:data:`SELF_SENSING_MODEL`), else it names the model."""
    return "self-sensing" if model == SELF_SENSING_MODEL else f"self-sensing, {table_6_1_condition(model)}"


def is_standard(model: Any) -> bool:
    """The report's standard model: by that name, as None, or as a configuration equal to it."""
    if model is None:
        return True
    if isinstance(model, str) and model in model_names():
        return model == "standard"
    return load_model(model) == ModelConfig(preset("standard"))


def _model_label(model: Any) -> str:
    """A model as a label: the name or path given, else the configuration's name, marked
    ``(changed)`` where it carries a preset's name but not its values (``with_changes``
    keeps the name unless given one)."""
    if isinstance(model, (str, os.PathLike)):
        return str(model)
    config = load_model(model)
    actuator = config.actuator
    if actuator.name in preset_names() and actuator != preset(actuator.name):
        return f"{actuator.name} (changed){config.name.removeprefix(actuator.name)}"
    return config.name


def run_chapter_7(
    entries: Sequence[PolicyEntry],
    results: Results,
    seeds: Sequence[int] = DEFAULT_SEEDS,
    conditions: Sequence[tuple[str, str]] = CHAPTER_7_CONDITIONS,
    sine_seconds: float = SINE_SECONDS,
) -> None:
    """Chapter 7's conditions: Table 6.1's step and sine for ``entries`` on each preset."""
    _require_sine_seconds(sine_seconds)
    for label, preset_name in conditions:
        for group in batchable(entries):
            _step_and_sine("7", group, preset_name, label, results, seeds, sine_seconds)


def _require_sine_seconds(sine_seconds: Any) -> None:
    """The sine is scored from ``SINE_WINDOW_S[0]`` on: a run that ended there failed with an
    ``IndexError`` after it had been simulated (a quick run may score a part of a period)."""
    start = SINE_WINDOW_S[0]
    if isinstance(sine_seconds, bool) or not isinstance(sine_seconds, (int, float)) or not sine_seconds > start + 1.0:
        raise ValueError(
            f"sine_seconds = {sine_seconds!r}: expected more than {start + 1.0:g} s (the sine is scored from "
            f"{start:g} s on; the report's protocol runs {SINE_SECONDS:g} s)"
        )


def _step_and_sine(
    experiment: str,
    entries: Sequence[PolicyEntry],
    model: Any,
    condition: str,
    results: Results,
    seeds: Sequence[int],
    sine_seconds: float = SINE_SECONDS,
) -> None:
    """The report's 8 mm step and 0.1 Hz sine for policies on one model: metrics and traces.

    ``sine_seconds`` shorter than the default (quick runs) ends the sine's scoring window there.
    """
    window = (SINE_WINDOW_S[0], min(SINE_WINDOW_S[1], sine_seconds))
    scale = stroke_scale(model)
    for reference, seconds, metrics in (
        ("step", STEP_SECONDS, lambda tr: step_metrics(tr, level_m=scale * STEP_LEVEL_M)),
        ("sine", sine_seconds, lambda tr: sine_metrics(tr, window)),
    ):
        runs = rollouts_that_finish(
            entries,
            results,
            (experiment, condition, reference),
            model=model,
            reference=report_reference(reference, scale),
            seconds=seconds,
            seeds=seeds,
        )
        for entry, trace in runs:
            results.records += _records(experiment, entry.name, condition, reference, metrics(trace))
            results.traces[(experiment, entry.name, condition, reference)] = trace


STANDARD_STROKE_M = preset("standard").usable_stroke_m
"""The report's wire's usable stroke [m] (9.5 mm), which the report's step and sine are set in."""


def stroke_scale(model: Any) -> float:
    """``model``'s usable stroke over the report's wire's (9.5 mm): 1 for every preset of the
    report's experiments; the report's step and sine run at this fraction of their levels."""
    return load_model(model).actuator.usable_stroke_m / STANDARD_STROKE_M


def report_reference(name: str, scale: float = 1.0) -> str | dict[str, Any]:
    """The report's ``"step"`` (8 mm) or ``"sine"`` (1-7 mm) as the harness runs it on an
    actuator whose stroke is ``scale`` times the report's: the same fractions of its stroke
    (on a 7.55 mm wire the 8 mm step could not be reached, on the 17 mm real bench it would
    be half its stroke). With ``scale`` 1 it is the report's own, by name."""
    if scale == 1.0:
        return f"report-{name}"
    spec = (report_step() if name == "step" else report_sine()).describe()
    spec.pop("name")
    return {k: v * scale if k.endswith("_m") else v for k, v in spec.items()}


def efficiency_reference(ramp_s: float) -> dict:
    """Hold 1 mm, then at 4 s a step (ramp_s = 0) or a ramp of ramp_s seconds to 7 mm (§8)."""
    if ramp_s <= 0.0:
        return {"kind": "step", "t1_s": 0.0, "level1_m": 1e-3, "t2_s": EFFICIENCY_HOLD_S, "level2_m": 7e-3}
    return {
        "kind": "ramp",
        "t1_s": 0.0,
        "level1_m": 1e-3,
        "d1_s": 0.5,
        "t2_s": EFFICIENCY_HOLD_S,
        "level2_m": 7e-3,
        "d2_s": ramp_s,
    }


def run_chapter_8(
    entries: Sequence[PolicyEntry],
    results: Results,
    seeds: Sequence[int] = DEFAULT_SEEDS,
    cases: Sequence[tuple] = CHAPTER_8_CASES,
    noise_m: float = EVAL_NOISE_M,
) -> None:
    for label, preset_name, ramp_s, _ in cases:
        for entry in entries:
            runs = rollouts_that_finish(
                [entry],
                results,
                ("8", label, "1 -> 7 mm"),
                model=preset_name,
                reference=efficiency_reference(ramp_s),
                seconds=EFFICIENCY_HOLD_S + EFFICIENCY_AFTER_S,
                seeds=seeds,
                noise_m=noise_m,
            )
            if not runs:
                continue
            trace = runs[0][1]
            results.records += _records(
                "8", entry.name, label, "1 -> 7 mm", {"efficiency_percent": efficiency_percent(trace)}
            )
            results.traces[("8", entry.name, label, "1 -> 7 mm")] = trace


def chapter_9_conditions() -> list[tuple[int, float, float]]:
    conds = [(n, 2000.0, v) for n, v in CHAPTER_9_COUNTS]
    conds += [(n, f, 10.0) for n in (1, 8, 16) for f in CHAPTER_9_FREQUENCIES if f != 2000.0]
    return conds


def chapter_9_label(n: int, f: float, v: float) -> str:
    return f"{n} actuators, {f:g} Hz, {v:g} V"


def run_chapter_9(
    entries: Sequence[PolicyEntry],
    results: Results,
    conditions: Sequence[tuple[int, float, float]] | None = None,
    seeds: Sequence[int] = (0,),
    noise_m: float = EVAL_NOISE_M,
) -> None:
    """Multiplexed step of :data:`CHAPTER_9_STEP_M` (3 mm; the report's size is unstated)."""
    for n, f, v in conditions or chapter_9_conditions():
        for entry in entries:
            mux = PolicyEntry(
                entry.name,
                entry.make,
                env_id="SMAMultiplexed-v0",
                # The multiplexed env is always PWM-resolved: it takes no pwm_mode.
                env_kwargs={
                    **{k: v for k, v in entry.env_kwargs.items() if k != "pwm_mode"},
                    "n_actuators": n,
                    "cycling_frequency_hz": f,
                },
                frame_stack=entry.frame_stack,
                kind=entry.kind,
            )
            trace = rollout(
                mux,
                model=f"supply-{v:g}v",
                reference={"kind": "step", "t1_s": 0.0, "level1_m": CHAPTER_9_STEP_M},
                seconds=CHAPTER_9_SECONDS[n],
                seeds=seeds,
                noise_m=noise_m,
            )
            rise, p2p = rise_and_oscillation(trace)
            label = chapter_9_label(n, f, v)
            overshoot = (
                np.maximum(0.0, trace["position_m"][..., 0].max(axis=0) - CHAPTER_9_STEP_M)
                if trace["position_m"].ndim == 3
                else np.maximum(0.0, trace["position_m"].max(axis=0) - CHAPTER_9_STEP_M)
            )
            results.records += _records(
                "9",
                entry.name,
                label,
                "3 mm step",
                {"rise_time_s": rise, "oscillation_p2p_m": p2p, "overshoot_m": overshoot},
            )
            results.traces[("9", entry.name, label, "3 mm step")] = trace


def bank_step_references(
    n: int = BANK_STEP_N, seed: int = 0, step_time_s: float = BANK_STEP_TIME_S
) -> list[dict[str, Any]]:
    """Actuator 0 steps 0 -> 8 mm at ``step_time_s``; the others go at once to random
    positions in :data:`BANK_HOLD_RANGE_M` (drawn from ``seed``) and hold them."""
    levels = np.random.default_rng(seed).uniform(*BANK_HOLD_RANGE_M, n - 1)
    step = {"kind": "step", "t1_s": step_time_s, "level1_m": BANK_STEP_LEVEL_M}
    return [step] + [{"kind": "step", "t1_s": 0.0, "level1_m": float(x)} for x in levels]


def bank_step(
    entry: PolicyEntry,
    n: int = BANK_STEP_N,
    voltage_v: float = BANK_STEP_VOLTAGE_V,
    seed: int = 0,
    noise_m: float = EVAL_NOISE_M,
    max_after_s: float = BANK_STEP_MAX_S,
    step_time_s: float = BANK_STEP_TIME_S,
) -> dict[str, float]:
    """One bank step (:func:`bank_step_references`) of a bank entry (:func:`bank_entry`).

    Returns ``rise_time_s`` (step to 90 % of 8 mm on the true position, ``inf`` if not within
    ``max_after_s``), ``half_rise_time_s`` (to 50 %, a finite comparison where a fixed slot
    cannot deliver 90 %), ``highest_position_m`` (of the stepping one, up to the rise),
    ``holders_settled_error_m`` (the holders' largest |error| just before the step: were
    they holding?) and ``holders_max_error_m`` (their largest |error| from the step until
    the rise: what the stepping one cost them). The run stops at the rise.
    """
    import gymnasium as gym

    import sma_gym  # noqa: F401  (registers the ids)

    kwargs = {**entry.env_kwargs, "n_actuators": n, "model": f"supply-{voltage_v:g}v", "position_noise_std_m": noise_m}
    env = gym.make("sma_gym:" + entry.env_id, max_episode_steps=None, **kwargs).unwrapped
    policy = entry.make(env)
    obs, _ = env.reset(seed=seed, options={"references": bank_step_references(n, seed, step_time_s)})
    dt = env.control_period_s
    step_k = int(round(step_time_s / dt))
    settled = math.nan
    worst = highest = 0.0
    half = rise = math.inf
    for k in range(step_k + int(round(max_after_s / dt))):
        action, _ = policy.predict(obs, episode_start=np.array([k == 0]), deterministic=True)
        obs, _, terminated, _, info = env.step(action)
        if terminated:
            raise RuntimeError(f"{entry.name}: the bank step ended early (overheated?) at t = {info['time_s']} s")
        x, r = env.sim.position_m, info["reference_m"]
        if k + 1 == step_k:
            settled = float(np.max(np.abs(r[1:] - x[1:])))
        if k + 1 > step_k:
            worst = max(worst, float(np.max(np.abs(r[1:] - x[1:]))))
            highest = max(highest, float(x[0]))
            if math.isinf(half) and x[0] >= 0.5 * BANK_STEP_LEVEL_M:
                half = (k + 1 - step_k) * dt
            if x[0] >= 0.9 * BANK_STEP_LEVEL_M:
                rise = (k + 1 - step_k) * dt
                break
    env.close()
    return {
        "rise_time_s": rise,
        "half_rise_time_s": half,
        "highest_position_m": highest,
        "holders_settled_error_m": settled,
        "holders_max_error_m": worst,
    }


def run_bank_step(entries: Sequence[PolicyEntry], results: Results, seeds: Sequence[int] = (0,)) -> None:
    """Chapter 9's bank step (issue 16) for bank entries, over ``seeds`` (the holders' levels
    and the sensor noise differ per seed); records under experiment ``"9 bank"``."""
    label = f"{BANK_STEP_N} actuators, 2000 Hz, {BANK_STEP_VOLTAGE_V:g} V"
    for entry in entries:
        runs = [bank_step(entry, seed=int(seed)) for seed in seeds]
        metrics = {key: np.array([run[key] for run in runs]) for key in runs[0]}
        # Its own experiment id: chapter 9's table reads oscillation and overshoot for every "9" row.
        results.records += _records("9 bank", entry.name, label, "bank step 0 -> 8 mm, others hold", metrics)


BANK_TRACKING_SECONDS = 10.0
"""One training episode (1000 steps of 10 ms)."""
BANK_TRACKING_KINDS = ("step", "sine", "random", "hold")
"""Actuator j of a tracking bank gets kind j mod 4; ``hold``: a step at 0 s to a random level."""
BANK_TRACKING_SEED = 20_000
"""First seed of the bank-tracking references (training and validation draw below it)."""


def bank_tracking_references(n: int, seed: int, stroke_m: float) -> list[dict[str, Any]]:
    """Independent references for a bank of n: kinds :data:`BANK_TRACKING_KINDS` in turn,
    parameters drawn from ``BANK_TRACKING_SEED + seed`` within the stroke."""
    from sma_gym.envs import references as refs

    rng = np.random.default_rng(BANK_TRACKING_SEED + seed)
    out = []
    for j in range(n):
        kind = BANK_TRACKING_KINDS[j % len(BANK_TRACKING_KINDS)]
        if kind == "hold":
            out.append({"kind": "step", "t1_s": 0.0, "level1_m": float(rng.uniform(0.1, 0.9) * stroke_m)})
            continue
        spec = refs.draw(kind, rng, stroke_m).describe()
        spec.pop("name", None)
        out.append(spec)
    return out


def bank_tracking(
    entry: PolicyEntry, n: int, scheme: str, seed: int = 0, noise_m: float = EVAL_NOISE_M, model: Any = "standard"
) -> dict[str, float]:
    """RMS tracking error [m] of a bank of n actuators ``model`` on independent references
    (:func:`bank_tracking_references`), over all its actuators and :data:`BANK_TRACKING_SECONDS`,
    on the true positions; the bank's total electrical energy [J]. Raises :class:`EpisodeEnded`
    when the bank overheats."""
    import gymnasium as gym

    import sma_gym  # noqa: F401  (registers the ids)

    kwargs = {**entry.env_kwargs, "n_actuators": n, "scheme": scheme, "position_noise_std_m": noise_m, "model": model}
    env = gym.make("sma_gym:" + entry.env_id, max_episode_steps=None, **kwargs).unwrapped
    policy = entry.make(env)
    if hasattr(policy, "reset"):
        policy.reset()
    references = bank_tracking_references(n, seed, float(env.position_scale_m))
    obs, _ = env.reset(seed=seed, options={"references": references})
    squared = 0.0
    steps = int(round(BANK_TRACKING_SECONDS / env.control_period_s))
    for k in range(steps):
        action, _ = policy.predict(obs, episode_start=np.array([k == 0]), deterministic=True)
        obs, _, terminated, _, info = env.step(action)
        if terminated:
            env.close()
            raise EpisodeEnded(
                {entry.name: float(info["time_s"])}, float(np.max(env.sim.temperature_c)), "bank tracking"
            )
        squared += float(np.mean((info["reference_m"] - env.sim.position_m) ** 2))
    energy = float(np.sum(env.sim.electrical_energy_j))
    env.close()
    return {"rms_error_m": math.sqrt(squared / steps), "energy_j": energy}


def bank_baselines(scheme: str, quick: bool = False) -> list[PolicyEntry]:
    """The bank baselines an agent of ``scheme`` is compared with: the report's controllers
    per actuator (:data:`BANK_BASELINE_SPECS`; two of them when ``quick``) and, on a shared
    budget, the priority allocator (:data:`BANK_PRIORITY_SPEC`)."""
    specs = BANK_BASELINE_SPECS[:2] if quick else BANK_BASELINE_SPECS
    entries = [bank_entry(s, scheme) for s in specs]
    if scheme == "shared_budget":
        entries.append(bank_entry(BANK_PRIORITY_SPEC, scheme, "priority"))
    return entries


def bank_tracking_label(n: int, scheme: str, model: Any = "standard") -> str:
    """The condition bank tracking is recorded under; names the model unless it is the standard one."""
    label = f"{n} actuators, {scheme.replace('_', ' ')}"
    return label if is_standard(model) else f"{label}, model {_model_label(model)}"


def run_bank_tracking(
    entries: Sequence[PolicyEntry],
    results: Results,
    n: int,
    scheme: str,
    seeds: Sequence[int] = DEFAULT_SEEDS,
    model: Any = "standard",
) -> None:
    """Bank tracking on independent references (issue 16) for bank baselines and agents on
    ``model``, over ``seeds``; records under experiment ``"9 bank tracking"``, reference
    ``"independent"`` (an entry whose bank overheats: :data:`ENDED_EARLY`)."""
    label = bank_tracking_label(n, scheme, model)
    for entry in entries:
        try:
            runs = [bank_tracking(entry, n, scheme, seed=int(seed), model=model) for seed in seeds]
        except EpisodeEnded as ended:
            results.records += _records(
                "9 bank tracking",
                entry.name,
                label,
                "independent",
                {ENDED_EARLY: np.array(list(ended.ended_s.values()))},
            )
            continue
        metrics = {key: np.array([run[key] for run in runs]) for key in runs[0]}
        results.records += _records("9 bank tracking", entry.name, label, "independent", metrics)


def bank_agent_entry(agent: AgentPolicy) -> PolicyEntry:
    """A bank agent (trained on ``SMAMultiplexed-v0``) as an entry: one model acting for every
    actuator (:class:`sma_gym_agents.bank.BankAgent`, with its residual base if it trained on
    one), at the control period it trained with."""
    from sma_gym_agents.bank import BankAgent

    kwargs = {k: v for k, v in agent.env_kwargs.items() if k in ("control_period_s", "energy_weight", "scheme")}

    def make(env: Any, a: AgentPolicy = agent) -> BankAgent:
        return BankAgent.from_policy(a, env)

    return PolicyEntry(
        agent.name,
        make,
        env_id="SMAMultiplexed-v0",
        env_kwargs=kwargs,
        kind="agent",
    )


def default_entries(self_sensing: bool = False) -> list[PolicyEntry]:
    entries = [baseline(s) for s in ALL_SPECS]
    if self_sensing:
        entries += [baseline(PID, True), baseline(with_feedforward(VSC3), True)]
    return entries


EXPERIMENTS = ("6.1", "7", "8", "9", "self-sensing")


AGENT_EXPERIMENTS: dict[str, tuple[str, ...]] = {
    "SMATracking-v0": ("6.1", "7", "8"),
    "SMASelfSensing-v0": ("self-sensing",),
    BANK_ENV_ID: ("9",),
    "SMARobust-v0": (),
}
"""Which experiments of :func:`evaluate` score an agent trained on each env (a robustness
agent is scored by its training run's comparison, over the chapter-7 conditions)."""


MODEL_EXPERIMENTS = ("6.1", "self-sensing")
"""The experiments :func:`evaluate` can run on a model of the user's (``model=``): chapters
7-9 are the report's conditions (a fan, other supplies and wires, multiplexing) of its own
wire, so they run on the report's wire only."""


def require_model_experiments(model: Any, experiments: Sequence[str], name: str = "model") -> bool:
    """Whether ``model`` is another actuator than the report's standard wire; refuses (naming
    the argument ``name``) a model that cannot be loaded, and another model with experiments
    outside :data:`MODEL_EXPERIMENTS`, before anything runs."""
    if model is None:
        return False
    shown = f"{name} {model!r}" if name.startswith("-") else f"{name} = {model!r}"
    try:
        load_model(model)
    except (OSError, ValueError) as err:
        raise ValueError(f"{shown}: {err}") from err
    if is_standard(model):
        return False
    chapters = [e for e in experiments if e not in MODEL_EXPERIMENTS]
    if chapters:
        raise ValueError(
            f"{shown} with experiments {', '.join(chapters)}: chapters 7-9 are the report's conditions "
            f"of its own wire; expected only {' and '.join(MODEL_EXPERIMENTS)} on another model"
        )
    return True


def evaluate(
    agents: Sequence[AgentPolicy] = (),
    experiments: Iterable[str] = EXPERIMENTS,
    seeds: Sequence[int] = DEFAULT_SEEDS,
    baselines: Sequence[PolicyEntry] | None = None,
    model: Any = None,
) -> Results:
    """Run the experiments for the baselines and the given agents, each over ``seeds``.

    ``model`` (a preset or twin name, a model file, a configuration; None: the report's) is
    the actuator the baselines run Table 6.1 and the self-sensing comparison on, e.g. the
    twin ``sma-gym diagnose`` identified; an agent is scored on the model it trained on,
    beside the baselines there. Only :data:`MODEL_EXPERIMENTS` take another model than the
    report's.
    """
    seeds = require_seeds(seeds)
    experiments = tuple(experiments)
    for e in experiments:
        if e not in EXPERIMENTS:
            raise ValueError(f"experiment = {e!r}: expected one of {', '.join(EXPERIMENTS)}")
    own_model = require_model_experiments(model, experiments)
    # Where the baselines run Table 6.1 and the self-sensing comparison.
    table_default = model if own_model else "standard"
    sensing_default = model if own_model else SELF_SENSING_MODEL  # the report's has a fan; the user's as given
    results = Results()

    def scored_in(experiment: str, env_id: str) -> bool:
        return experiment in AGENT_EXPERIMENTS.get(env_id, ())

    tracking = [a for a in agents if scored_in("6.1", a.env_id)]
    sensing = [a for a in agents if scored_in("self-sensing", a.env_id)]
    bank_agents = [a for a in agents if scored_in("9", a.env_id)]
    # The report's conditions are its actuator's: an agent trained on another model is
    # scored on that model (Table 6.1 beside the baselines there), not on the report's.
    tracking_agents = [agent_entry(a) for a in tracking if is_standard(trained_model(a))]
    base = list(baselines) if baselines is not None else default_entries()
    sensing_labels: list[str] = []
    if "self-sensing" in experiments:
        # Checked before any experiment runs (a bad choice failed only after the others).
        sensing_labels = [PID.label, with_feedforward(VSC3).label] if baselines is None else _report_labels(base)
    if "6.1" in experiments:
        for table_model, group in _by_model(tracking, default=table_default):
            condition = distinct_condition(results, table_6_1_condition(table_model), table_model)
            run_table_6_1(
                base + [agent_entry(a) for a in group], results, seeds, condition=condition, model=table_model
            )
    if model is not None:
        # Asked for one actuator, an agent trained on another is scored on its own: said, as
        # a second table beside the first read as the agent's result there (a new user's trial).
        for scored, experiment, asked in ((tracking, "6.1", table_default), (sensing, "self-sensing", sensing_default)):
            if experiment not in experiments:
                continue  # the agent is not run at all (the chapters say so where they skip it)
            for a in scored:
                if _model_key(trained_model(a)) != _model_key(asked):
                    results.notes.append(
                        f"{a.name} trained on {_model_label(trained_model(a))}, not on {_model_label(asked)}: it is "
                        "scored on the model it trained on, beside the baselines there, not on the one asked for"
                    )
    for a in tracking:
        if not is_standard(trained_model(a)) and {"7", "8"} & set(experiments):
            results.notes.append(
                f"{a.name} trained on another model than the report's standard wire ({table_6_1_condition(trained_model(a))}): "
                "chapters 7 and 8 run the report's wire under its conditions, so they do not score it; its Table 6.1 is "
                "on its own model"
            )
    if "7" in experiments:
        chosen = [e for e in base if e.name in {s.label for s in CHAPTER_7_SPECS}] if baselines is None else base
        run_chapter_7(chosen + tracking_agents, results, seeds, CHAPTER_7_CONDITIONS[1:])
    if "8" in experiments:
        chosen = [e for e in base if e.name in ("PID", "VSC3 + FF")] if baselines is None else base
        run_chapter_8(chosen + tracking_agents, results, seeds)
    if "9" in experiments:
        chosen = [e for e in base if e.name == "PID"] if baselines is None else base
        banks = [
            bank_entry(PID, "fixed_slots"),
            bank_entry(PID, "shared_budget"),
            bank_entry(PID, "shared_budget", "priority"),
        ]
        run_chapter_9(chosen + ([banks[1]] if baselines is None else []), results, seeds=seeds)
        run_bank_step(banks, results, seeds)
        # Each bank agent beside the bank baselines of its own scheme, at the n and on the
        # model it trained with; agents that share all three share one run of the baselines
        # (each baseline was run, and recorded, once per agent).
        bank_groups: dict[tuple[str, int, str], tuple[Any, list[AgentPolicy]]] = {}
        for agent in bank_agents:
            scheme = agent.env_kwargs.get("scheme", "fixed_slots")
            n = int(agent.env_kwargs.get("n_actuators", 4))
            bank_model = trained_model(agent)
            bank_groups.setdefault((scheme, n, _model_key(bank_model)), (bank_model, []))[1].append(agent)
        for (scheme, n, _), (bank_model, group) in bank_groups.items():
            pool = bank_baselines(scheme) + [bank_agent_entry(a) for a in group]
            run_bank_tracking(pool, results, n, scheme, seeds, model=bank_model)
    if "self-sensing" in experiments:
        # The report's self-sensing setup (§4.2): a fan; compared with the same controllers
        # reading the position sensor under the same conditions.
        with_sensor = [e for e in base if e.name in sensing_labels]
        for sensing_model, group in _by_model(sensing, default=sensing_default):
            readers = [baseline(label, True) for label in sensing_labels]
            condition = distinct_condition(results, self_sensing_condition(sensing_model), sensing_model)
            entries = readers + [agent_entry(a) for a in group] + with_sensor
            run_table_6_1(entries, results, seeds, condition=condition, model=sensing_model)
    return results


def _report_labels(entries: Sequence[PolicyEntry]) -> list[str]:
    """The names of ``entries`` that are the report's controllers (the self-sensing
    experiment runs each of them fed by resistance as well as by the sensor); until
    2026-12-07 it ran PID and VSC3 + FF whatever ``baselines`` asked for."""
    labels = {s.label for s in ALL_SPECS}
    chosen = [e.name for e in entries if e.name in labels]
    if not chosen:
        raise ValueError(
            f"baselines = {[e.name for e in entries]!r}: the self-sensing experiment runs the report's controllers "
            f"fed by resistance; expected at least one of {sorted(labels)}"
        )
    return chosen


SELF_SENSING_MODEL = SELF_SENSING.default_model
"""The model of the report's self-sensing experiments (§4.2, with a fan): the self-sensing env's default."""


def trained_model(agent: AgentPolicy) -> Any:
    """The model an agent trained on, as its card gives it (a name, a path or a configuration);
    ``"standard"`` (:data:`SELF_SENSING_MODEL` for the self-sensing env) when the card gives none."""
    model = agent.env_kwargs.get("model")
    if model is None:
        return SELF_SENSING_MODEL if agent.env_id == "SMASelfSensing-v0" else "standard"
    return model


def _by_model(agents: Sequence[AgentPolicy], default: Any = "standard") -> list[tuple[Any, list[AgentPolicy]]]:
    """``agents`` grouped by the model they trained on, ``default``'s group first (always there,
    for the baselines), in order; equal configurations given as dicts share a group."""
    groups: dict[str, tuple[Any, list[AgentPolicy]]] = {_model_key(default): (default, [])}
    for a in agents:
        model = trained_model(a)
        groups.setdefault(_model_key(model), (model, []))[1].append(a)
    return list(groups.values())


def _model_key(model: Any) -> str:
    """One key per actuator however it is given: a name, a file of it (a twin and its copy
    were two actuators, so the baselines ran, and were tabled, twice) or a configuration."""
    if is_standard(model):
        return "standard"  # however given: one group, one Table 6.1 beside the report's
    return json.dumps(load_model(model).to_dict(), sort_keys=True)

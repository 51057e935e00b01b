"""Reference trajectories for position tracking.

A reference is a kind code plus a row of parameters, evaluated by a compiled function at
any time (so a vector env evaluates thousands at once). Kinds:

``step``
    0 until ``t1``, then ``level1``; from ``t2`` on, ``level2`` (a step up and one back).
``ramp``
    0 until ``t1``, ramps linearly to ``level1`` over ``d1``; from ``t2`` ramps to ``level2``
    over ``d2``.
``sine``
    ``offset - amplitude * cos(2 pi f t + phase)`` (phase 0 starts at the minimum).
``random``
    A smooth random profile: cosine interpolation between random levels at random times.

The report's experiments (§6) are fixed members: ``report-step`` (0 -> 8 mm at 0.5 s) and
``report-sine`` (0.1 Hz, 3 mm amplitude around 4 mm: 1 -> 7 mm, as in §4 and §8).
Training draws (``draw``) randomise every parameter within the actuator's stroke; the
report's members are never drawn exactly, so evaluating on them is evaluating on
references the agent did not train on.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from sma_gym._jit import njit

STEP = 0
RAMP = 1
SINE = 2
RANDOM = 3
KIND_CODES = {"step": STEP, "ramp": RAMP, "sine": SINE, "random": RANDOM}
TRAINING_KINDS = ("step", "ramp", "sine", "random")
NAMED = ("step", "ramp", "sine", "random", "report-step", "report-sine")

N_PARAMS = 6
N_WAYPOINTS = 24

FIELDS: dict[str, tuple[str, ...]] = {
    "step": ("t1_s", "level1_m", "t2_s", "level2_m"),
    "ramp": ("t1_s", "level1_m", "d1_s", "t2_s", "level2_m", "d2_s"),
    "sine": ("offset_m", "amplitude_m", "frequency_hz", "phase_rad"),
    "random": ("times_s", "levels_m"),
}
"""The fields of a reference given as a dict, ``{"kind": kind, field: value, ...}``, and of
:meth:`Reference.describe`, per kind (times and durations in s, positions in m from rest,
the sine's phase in rad; ``random``'s two are lists of 2 to N_WAYPOINTS waypoints). A field
left out takes the report's value (step, sine) or a fixed default (ramp); ``{"kind": kind}``
alone draws that kind as training does."""

REPORT_STEP_M = 8e-3
REPORT_STEP_TIME_S = 0.5
REPORT_SINE_FREQUENCY_HZ = 0.1
REPORT_SINE_AMPLITUDE_M = 3e-3
REPORT_SINE_OFFSET_M = 4e-3


class Reference:
    """One reference: kind, parameters and (for ``random``) waypoints. Lengths in metres."""

    __slots__ = ("kind", "params", "waypoint_t", "waypoint_x", "name")

    def __init__(
        self,
        kind: int,
        params: np.ndarray,
        waypoint_t: np.ndarray | None = None,
        waypoint_x: np.ndarray | None = None,
        name: str = "",
    ):
        self.kind = int(kind)
        self.params = np.zeros(N_PARAMS)
        self.params[: len(params)] = params
        self.waypoint_t = np.full(N_WAYPOINTS, np.inf) if waypoint_t is None else waypoint_t
        self.waypoint_x = np.zeros(N_WAYPOINTS) if waypoint_x is None else waypoint_x
        self.name = name

    def __call__(self, t: float | np.ndarray) -> np.ndarray:
        """Reference position [m] at time(s) t (numpy, for plots and tests)."""
        times = np.atleast_1d(np.asarray(t, dtype=float))
        out = np.empty_like(times)
        for k, tk in enumerate(times):
            out[k] = evaluate(self.kind, self.params, self.waypoint_t, self.waypoint_x, tk)[0]
        return out

    def describe(self) -> dict[str, Any]:
        inverse = {v: k for k, v in KIND_CODES.items()}
        d: dict[str, Any] = {"kind": inverse[self.kind], "name": self.name or inverse[self.kind]}
        if self.kind != RANDOM:
            d.update({label: float(v) for label, v in zip(FIELDS[d["kind"]], self.params)})
        if self.kind == RANDOM:
            d["times_s"] = [float(v) for v in self.waypoint_t]
            d["levels_m"] = [float(v) for v in self.waypoint_x]
        return d


# Without reference counting: called per actuator and step from envs.task (see there).
@njit(cache=True, error_model="numpy", _nrt=False)
def evaluate(kind, p, wp_t, wp_x, t):
    """(r, dr/dt) of one reference at time t."""
    if kind == STEP:
        if t < p[0]:
            return 0.0, 0.0
        if t < p[2]:
            return p[1], 0.0
        return p[3], 0.0
    if kind == RAMP:
        r = 0.0
        rate = 0.0
        if t >= p[0]:
            if t < p[0] + p[2]:
                rate = p[1] / p[2]
                r = rate * (t - p[0])
            else:
                r = p[1]
        if t >= p[3]:
            if t < p[3] + p[5]:
                rate = (p[4] - p[1]) / p[5]
                r = p[1] + rate * (t - p[3])
            else:
                r = p[4]
                rate = 0.0
        return r, rate
    if kind == SINE:
        w = 2.0 * math.pi * p[2]
        return p[0] - p[1] * math.cos(w * t + p[3]), p[1] * w * math.sin(w * t + p[3])
    # RANDOM: cosine interpolation between waypoints (smooth, bounded rate).
    n = wp_t.shape[0]
    if t <= wp_t[0]:
        return wp_x[0], 0.0
    for k in range(n - 1):
        t0 = wp_t[k]
        t1 = wp_t[k + 1]
        if t < t1:
            u = (t - t0) / (t1 - t0)
            c = 0.5 * (1.0 - math.cos(math.pi * u))
            dc = 0.5 * math.pi * math.sin(math.pi * u) / (t1 - t0)
            return wp_x[k] + (wp_x[k + 1] - wp_x[k]) * c, (wp_x[k + 1] - wp_x[k]) * dc
    return wp_x[n - 1], 0.0


def report_step() -> Reference:
    return Reference(STEP, np.array([REPORT_STEP_TIME_S, REPORT_STEP_M, np.inf, REPORT_STEP_M]), name="report-step")


def report_sine() -> Reference:
    return Reference(
        SINE,
        np.array([REPORT_SINE_OFFSET_M, REPORT_SINE_AMPLITUDE_M, REPORT_SINE_FREQUENCY_HZ, 0.0]),
        name="report-sine",
    )


def draw(kind: str, rng: np.random.Generator, stroke_m: float) -> Reference:
    """A random reference of ``kind`` for an actuator with usable stroke ``stroke_m``.

    Levels stay within [5 %, 90 %] of the stroke; timings leave the wire time to respond.
    """
    lo, hi = 0.05 * stroke_m, 0.9 * stroke_m
    if kind == "step":
        t1 = rng.uniform(0.1, 1.5)
        level1 = rng.uniform(0.15 * stroke_m, hi)
        t2 = t1 + rng.uniform(2.5, 6.0)
        level2 = rng.uniform(lo, level1)
        return Reference(STEP, np.array([t1, level1, t2, level2]), name="step")
    if kind == "ramp":
        t1 = rng.uniform(0.1, 1.5)
        level1 = rng.uniform(0.15 * stroke_m, hi)
        d1 = rng.uniform(0.5, 3.0)
        t2 = t1 + d1 + rng.uniform(1.0, 3.0)
        level2 = rng.uniform(lo, level1)
        d2 = rng.uniform(1.0, 4.0)
        return Reference(RAMP, np.array([t1, level1, d1, t2, level2, d2]), name="ramp")
    if kind == "sine":
        amplitude = rng.uniform(0.1, 0.4) * stroke_m
        offset = rng.uniform(lo + amplitude, hi - amplitude)
        frequency = rng.uniform(0.03, 0.3)
        phase = rng.uniform(-math.pi, math.pi)
        return Reference(SINE, np.array([offset, amplitude, frequency, phase]), name="sine")
    if kind == "random":
        gaps = rng.uniform(0.6, 3.0, size=N_WAYPOINTS - 1)
        times = np.concatenate([[rng.uniform(0.0, 1.0)], gaps]).cumsum()
        levels = rng.uniform(lo, hi, size=N_WAYPOINTS)
        levels[0] = 0.0
        return Reference(RANDOM, np.zeros(N_PARAMS), times, levels, name="random")
    raise ValueError(f"reference kind = {kind!r}: expected one of {', '.join(map(repr, TRAINING_KINDS))}")


def resolve(spec: Any, rng: np.random.Generator, stroke_m: float, default: str | tuple[str, ...]) -> Reference:
    """A reference from a reset option: a name, a Reference, a dict, or None (use default).

    A dict may be ``{"kind": "step", "level1_m": ..., ...}`` (:data:`FIELDS`) or
    ``{"kind": "sine"}`` to draw only that kind.
    """
    if spec is None:
        choices = (default,) if isinstance(default, str) else tuple(default)
        spec = choices[int(rng.integers(len(choices)))] if len(choices) > 1 else choices[0]
    if isinstance(spec, Reference):
        # Checked as its dict would be: one built by hand skips no check. Kept as given.
        fields = spec.describe()
        del fields["name"]
        _from_mapping(fields, rng, stroke_m)
        return spec
    if isinstance(spec, str):
        if spec in ("report-step", "report-sine"):
            # The report's fixed levels (8 mm; 1 -> 7 mm): beyond a short wire's stroke, an
            # episode would drive it to overheat.
            ref = report_step() if spec == "report-step" else report_sine()
            top = REPORT_STEP_M if spec == "report-step" else REPORT_SINE_OFFSET_M + REPORT_SINE_AMPLITUDE_M
            _check_level(spec, "its top level", top, stroke_m)
            return ref
        if spec in TRAINING_KINDS:
            return draw(spec, rng, stroke_m)
        raise ValueError(f"reference = {spec!r}: expected one of {', '.join(map(repr, NAMED))}")
    if isinstance(spec, Mapping):
        return _from_mapping(spec, rng, stroke_m)
    raise ValueError(f"reference = {spec!r}: expected a name ({', '.join(NAMED)}), a dict or a Reference")


MAX_REFERENCE_FREQUENCY_HZ = 100.0
"""Fastest sine accepted: far above what a wire (thermal time constants of ~1 s) can follow."""

MIN_RAMP_DURATION_S = 1e-6
"""Shortest ramp accepted [s]: far below a control period; a subnormal duration made the
ramp's rate (level / duration) overflow to inf and the reference NaN."""


def _field(kind: str, key: str, value: Any) -> float:
    """``value`` of reference field ``key`` as a float, or a ValueError naming the field."""
    if isinstance(value, (str, bytes, bool, np.bool_)):
        # float("0.004") and float(True) would work: a number arriving as text or a flag is a mistake.
        what = "a boolean" if isinstance(value, (bool, np.bool_)) else "a string"
        raise ValueError(f"reference {kind!r} {key} = {value!r}: expected a number, not {what}")
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ValueError(f"reference {kind!r} {key} = {value!r}: expected a number") from None


def _check_level(kind: str, key: str, value: float, stroke_m: float) -> None:
    if not (math.isfinite(value) and 0.0 <= value <= stroke_m):
        raise ValueError(
            f"reference {kind!r} {key} = {value!r}: expected a position in [0, {stroke_m:g}] m "
            "(the actuator's stroke: the wire can neither extend past rest nor contract past its end of travel)"
        )


def _from_mapping(spec: Mapping[str, Any], rng: np.random.Generator, stroke_m: float) -> Reference:
    """A reference from a dict; every field is checked (finite, within the stroke, ...)."""
    kind = spec.get("kind")
    if kind not in KIND_CODES:
        raise ValueError(f"reference['kind'] = {kind!r}: expected one of {', '.join(map(repr, KIND_CODES))}")
    given = {k: v for k, v in spec.items() if k != "kind"}
    if not given:
        return draw(kind, rng, stroke_m)
    if kind == "random":
        unknown = set(given) - set(FIELDS["random"])
        if unknown:
            raise ValueError(
                f"reference 'random': unknown field(s) {sorted(unknown)}; expected {list(FIELDS['random'])}"
            )
        lists = {}
        for key in ("times_s", "levels_m"):
            values = given.get(key, [])
            if not isinstance(values, (list, tuple, np.ndarray)) or np.ndim(values) != 1:
                raise ValueError(f"reference 'random' {key} = {values!r}: expected a list of numbers")
            lists[key] = np.array([_field("random", f"{key}[{k}]", v) for k, v in enumerate(values)], dtype=float)
        wp_t, wp_x = lists["times_s"], lists["levels_m"]
        if (
            wp_t.ndim != 1
            or wp_t.shape != wp_x.shape
            or not (2 <= len(wp_t) <= N_WAYPOINTS)
            or np.any(np.diff(wp_t) <= 0)
        ):
            raise ValueError(
                f"reference 'random' needs 'times_s' (strictly increasing) and 'levels_m' of equal length 2..{N_WAYPOINTS}"
            )
        for k, t in enumerate(wp_t):
            if not (math.isfinite(t) and t >= 0.0):
                raise ValueError(f"reference 'random' times_s[{k}] = {float(t)!r}: expected a finite time >= 0 s")
        for k, x in enumerate(wp_x):
            _check_level("random", f"levels_m[{k}]", float(x), stroke_m)
        times = np.concatenate([wp_t, wp_t[-1] + np.arange(1, N_WAYPOINTS - len(wp_t) + 1)])
        levels = np.concatenate([wp_x, np.full(N_WAYPOINTS - len(wp_x), wp_x[-1])])
        return Reference(RANDOM, np.zeros(N_PARAMS), times, levels, name="random")
    names = FIELDS[kind]
    unknown = set(given) - set(names)
    if unknown:
        raise ValueError(f"reference {kind!r}: unknown field(s) {sorted(unknown)}; expected {list(names)}")
    defaults = {
        "step": {"t1_s": REPORT_STEP_TIME_S, "level1_m": REPORT_STEP_M, "t2_s": math.inf, "level2_m": None},
        "ramp": {"t1_s": 0.5, "level1_m": 7e-3, "d1_s": 1.0, "t2_s": math.inf, "level2_m": 1e-3, "d2_s": 1.0},
        "sine": {
            "offset_m": REPORT_SINE_OFFSET_M,
            "amplitude_m": REPORT_SINE_AMPLITUDE_M,
            "frequency_hz": REPORT_SINE_FREQUENCY_HZ,
            "phase_rad": 0.0,
        },
    }[kind]
    values = {**defaults, **{k: _field(kind, k, v) for k, v in given.items()}}
    if kind == "step" and values["level2_m"] is None:
        values["level2_m"] = values["level1_m"]
    for key, value in values.items():
        if math.isnan(value):
            raise ValueError(f"reference {kind!r} {key} = nan: expected a number")
        if key in ("level1_m", "level2_m"):
            _check_level(kind, key, value, stroke_m)
        elif key == "t1_s" and not (math.isfinite(value) and value >= 0.0):
            raise ValueError(f"reference {kind!r} {key} = {value!r}: expected a finite time >= 0 s")
        elif key == "t2_s" and not value >= values["t1_s"]:
            raise ValueError(
                f"reference {kind!r} {key} = {value!r}: expected a time >= t1_s = {values['t1_s']!r} s, or inf (never)"
            )
        elif key in ("d1_s", "d2_s") and not (MIN_RAMP_DURATION_S <= value and math.isfinite(value)):
            raise ValueError(
                f"reference {kind!r} {key} = {value!r}: expected a finite duration >= {MIN_RAMP_DURATION_S:g} s "
                "(a shorter ramp is a step)"
            )
        elif key == "frequency_hz" and not 0.0 < value <= MAX_REFERENCE_FREQUENCY_HZ:
            raise ValueError(
                f"reference {kind!r} {key} = {value!r}: expected a value in (0, {MAX_REFERENCE_FREQUENCY_HZ:g}] Hz"
            )
        elif key == "phase_rad" and not math.isfinite(value):
            raise ValueError(f"reference {kind!r} {key} = {value!r}: expected a finite phase (rad)")
        elif key == "amplitude_m" and not (math.isfinite(value) and value >= 0.0):
            raise ValueError(f"reference {kind!r} {key} = {value!r}: expected a finite amplitude >= 0 m")
    if kind == "ramp" and values["t2_s"] < values["t1_s"] + values["d1_s"]:
        # The second ramp starts from level1_m: starting it before the first one ends
        # would make the reference jump.
        raise ValueError(
            f"reference 'ramp' t2_s = {values['t2_s']!r}: expected a time >= t1_s + d1_s = "
            f"{values['t1_s'] + values['d1_s']!r} s (the end of the first ramp), or inf (never)"
        )
    if kind == "sine":
        # The sine spans offset +- amplitude: both ends must lie within the stroke.
        _check_level(kind, "offset_m - amplitude_m", values["offset_m"] - values["amplitude_m"], stroke_m)
        _check_level(kind, "offset_m + amplitude_m", values["offset_m"] + values["amplitude_m"], stroke_m)
    return Reference(KIND_CODES[kind], np.array([values[n] for n in names]), name=kind)

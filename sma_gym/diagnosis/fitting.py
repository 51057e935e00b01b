"""Fitting candidate models to measured traces through the batched simulator core.

A *candidate* is the nominal model plus a few parameters to fit: the nominal parameters
that are legitimately uncertain for any real actuator (convection level, a shift of the
transformation temperatures, the recoverable strain, the position sensor's zero and the
resistivity level) and, optionally, the parameters of one named effect. Without electrical
signals the resistivity level is the level of the heating power V^2 / R: it is as uncertain
as when R is measured (more: nothing pins it), and leaving it out lets any effect that
changes the power (a supply sag above all) stand in for it. Fitting the nominal parameters alongside every effect is what keeps an
effect from winning merely by absorbing a miscalibration.

Residuals are the measured minus the simulated outputs (position, and resistance, current
and voltage where measured), each divided by a robust estimate of its measurement noise,
so outputs are weighted by how well they were measured. Fits are bounded least squares
(scipy's trust-region reflective); the Jacobian comes from forward differences that run as
extra columns of one batched simulation, so one iteration costs one call into the core.
That call runs on several threads (the core releases the GIL): the columns and the traces
are split into ``threads`` parts each, all simulated at once; every actuator is independent,
so the result is the same bit for bit with any thread count.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from sma_gym._jit import available_cores
from sma_gym.data.measured import SIDECAR_KEYS, MeasuredTrace
from sma_gym.effects import EFFECTS
from sma_gym.model import ModelConfig
from sma_gym.simulator import Simulator

OUTPUT_COLUMNS = {
    # output name: (trace attribute, simulator record, noise floor)
    "position": ("position", "position_measured_m", 1e-6),
    "resistance": ("resistance", "resistance_measured_ohm", 5e-4),
    "current": ("current", "current_measured_a", 1e-4),
    "voltage": ("wire_voltage", "voltage_measured_v", 1e-3),
}
OUTPUT_UNITS = {"position": "m", "resistance": "ohm", "current": "A", "voltage": "V"}

MAX_THREADS = 8
"""Most threads a batched simulation uses. A call simulates about 7 columns for each trace,
so more threads would each get too small a part to gain."""


def default_threads() -> int:
    """Threads for the batched simulations of a fit: the cores this process may run on, at
    most ``MAX_THREADS``. The core is pure computation without a spinning thread pool, so
    on a shared machine extra threads only time-share; they never thrash."""
    return max(1, min(available_cores(), MAX_THREADS))


def require_threads(name: str, value: object) -> int:
    """``value`` as a thread count (1..MAX_THREADS), or ValueError naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 1 <= value <= MAX_THREADS:
        raise ValueError(f"{name} = {value!r}: expected an integer from 1 to {MAX_THREADS}")
    return int(value)


SWEEP_SIZE_EXTRA = 7
"""Grid values of each swept parameter after the first (``Problem._grid_start``)."""

POLISH_MAX_NFEV = 20
"""Evaluations of the dogbox run that continues a TRF run stopped by its evaluation budget
(``Problem.fit``). The transformation temperatures and the heat loss trade along a narrow
curved ravine (a higher convection scale with a lower temperature shift starts the
transformation at the same time), along which TRF's steps crawl. Measured (seed 67 pair 7
of ``bench_diagnosis.py --pairs 20``, a convection change in its power form refitted beside
a minor-loop width): TRF stopped after 80 evaluations at 2.15x the noise on the fitted data
(2.91x held out), 160 more reached 1.24x; dogbox from the same start converged in 7 to
1.005x (1.003x held out)."""


def _grid_values(p: FitParameter, size: int, scale: bool = False) -> np.ndarray:
    """``size`` + 1 values spanning a parameter's range: evenly when it spans zero; for a
    ``scale`` (a positive factor about 1) geometrically from bound to bound; else
    geometrically in the distance from its lower bound (an effect's size or time constant,
    whose small values matter most)."""
    if p.lower < 0.0 < p.upper:
        return np.linspace(p.lower, p.upper, size + 1)
    if scale and p.lower > 0.0:
        return np.geomspace(p.lower, p.upper, size + 1)
    return np.r_[p.lower, p.lower + (p.upper - p.lower) * np.geomspace(1.0 / 256.0, 1.0, size)]


# Effect parameters that would duplicate a fitted nominal parameter are held at off.
DEGENERATE_WITH_NOMINAL = {("convection_change", "scale")}


@dataclass(frozen=True)
class FitParameter:
    """A parameter of a candidate: name, bounds, start, and how it enters the model."""

    name: str
    unit: str
    lower: float
    upper: float
    start: float
    kind: str  # "nominal", "offset" (added to the position output) or "effect"
    effect: str | None = None
    form: str = "default"  # the effect's form (candidates are fitted in the default one)


NOMINAL = (
    FitParameter("convection_scale", "-", 0.5, 2.0, 1.0, "nominal"),
    FitParameter("temperature_shift_k", "K", -10.0, 10.0, 0.0, "nominal"),
    FitParameter("strain_scale", "-", 0.7, 1.3, 1.0, "nominal"),
    FitParameter("position_offset_m", "m", -2e-3, 2e-3, 0.0, "offset"),
)
RESISTIVITY = FitParameter("resistivity_scale", "-", 0.8, 1.25, 1.0, "nominal")


def effect_parameters(name: str, form: str = "default") -> tuple[FitParameter, ...]:
    """The fitted parameters of effect ``name`` in ``form`` (those duplicating a nominal one held off)."""
    effect = EFFECTS[name]
    if form not in effect.forms:
        raise ValueError(f"effect {name!r} form = {form!r}: expected one of {effect.forms}")
    return tuple(
        FitParameter(f"{name}.{p.name}", p.unit, p.lower, p.upper, p.off, "effect", name, form)
        for p in effect.parameters
        if (name, p.name) not in DEGENERATE_WITH_NOMINAL
    )


def starts_for(parameters: Sequence[FitParameter], warm: dict[str, float] | None = None) -> list[np.ndarray]:
    """Starting points: the nominal parameters where ``warm`` has them (the nominal refit's
    solution), with the effect off, and with the effect at a moderate size (half its
    typical value), because some effects are flat at their off value (a spread is
    symmetric in +-T)."""
    warm = warm or {}
    base = np.array([warm.get(p.name, p.start) for p in parameters])
    out = [base]
    alt = base.copy()
    changed = False
    for k, p in enumerate(parameters):
        if p.kind == "effect":
            typical = EFFECTS[p.effect].parameter(p.name.split(".", 1)[1]).typical
            alt[k] = float(np.clip(0.5 * typical, p.lower, p.upper))
            changed = True
    if changed:
        out.append(alt)
    return out


def apply(nominal: ModelConfig, parameters: Sequence[FitParameter], values: np.ndarray) -> tuple[ModelConfig, float]:
    """The model for a parameter vector, and the position offset it carries."""
    a = nominal.actuator
    w, c = a.wire, a.convection
    offset = 0.0
    effects: dict[str, dict[str, float]] = {}
    forms: dict[str, str] = {}
    changes: dict[str, float] = {}
    scale_conv = scale_strain = scale_rho = 1.0
    shift = 0.0
    for p, v in zip(parameters, values):
        v = float(v)
        if p.name == "convection_scale":
            scale_conv = v
        elif p.name == "temperature_shift_k":
            shift = v
        elif p.name == "strain_scale":
            scale_strain = v
        elif p.name == "resistivity_scale":
            scale_rho = v
        elif p.kind == "offset":
            offset = v
        elif p.kind == "effect":
            effects.setdefault(p.effect, {})[p.name.split(".", 1)[1]] = v
            forms[p.effect] = p.form
    changes = {
        "convection.h0_w_m2_k": c.h0_w_m2_k * scale_conv,
        "convection.h2_w_m2_k3": c.h2_w_m2_k3 * scale_conv,
        "wire.austenite_start_c": w.austenite_start_c + shift,
        "wire.austenite_finish_c": w.austenite_finish_c + shift,
        "wire.martensite_start_c": w.martensite_start_c + shift,
        "wire.martensite_finish_c": w.martensite_finish_c + shift,
        "wire.max_transformation_strain": w.max_transformation_strain * scale_strain,
        "wire.resistivity_martensite_ohm_m": w.resistivity_martensite_ohm_m * scale_rho,
        "wire.resistivity_austenite_ohm_m": w.resistivity_austenite_ohm_m * scale_rho,
    }
    model = nominal.with_actuator(**changes)
    for name, vals in effects.items():
        setting = nominal.effects.get(name)
        merged = dict(setting.values) if setting else {}
        merged.update(vals)
        # A default-form parameter keeps the form the nominal model already gives the effect.
        form = setting.form if setting is not None and forms[name] == "default" else forms[name]
        model = model.with_effect(name, merged, form=form)
    return model, offset


@dataclass
class TraceData:
    """A measured trace prepared for simulation: duty per control step, sample indices."""

    trace: MeasuredTrace
    duty: np.ndarray
    sample_steps: np.ndarray  # control step index whose end is each sample (or -1 before)
    outputs: dict[str, np.ndarray]  # measured values per output
    noise: dict[str, float]
    mask: np.ndarray  # samples used (e.g. the fitted part of a split file)
    rest: np.ndarray | None  # samples before the duty first rises (sets the sensor zero)

    @property
    def n_samples(self) -> int:
        return int(self.mask.sum())


MIN_REST_SAMPLES = 10
"""A file whose duty stays 0 for at least this many samples at the start reads its sensor
zero there (measured minus simulated while at rest); the README of the real bench says the
zero differs between runs, so a zero fitted on one file cannot serve another."""


NOISE_DIFFERENCE_ORDER = 3
"""Order k of the differences the white noise is read from. A signal's own motion leaks
into low orders: at 100 Hz the first differences of a sine, chirp or step response count
it as noise (6.3-9.4 um read for a true 5.0 um, `sma-gym synth` at seed 3), the third
remove each local quadratic and read 4.97-5.30 um (4.97 um at 1 kHz, where the first
read 5.24). White noise of standard deviation s gives third differences of standard
deviation s * sqrt(C(2k, k)) = s * sqrt(20)."""


def quantisation_step(values: np.ndarray) -> float:
    """The step of the grid the finite ``values`` lie on (a reading rounded to 0.1 ohm: 0.1),
    or 0 if they lie on none coarser than their own spacing."""
    u = np.unique(values[np.isfinite(values)])
    if u.size < 2:
        return 0.0
    gaps = np.diff(u)
    q = float(gaps.min())
    ratio = gaps / q
    # Every gap a whole number of steps (rounding leaves 1e-16-relative float error).
    return q if float(np.max(np.abs(ratio - np.rint(ratio)))) < 1e-3 else 0.0


def noise_level(values: np.ndarray, floor: float, order: int = NOISE_DIFFERENCE_ORDER) -> float:
    """Robust white-noise estimate: MAD of the ``order``-th differences / sqrt(C(2 order, order)),
    at least ``floor`` and the rounding error of a quantised reading (step / sqrt(12)): the
    differences of a reading rounded to 0.1 ohm are mostly 0, so its noise was read as the
    floor (0.5 mohm), and that output outweighed every other in the fit (a right 'none'
    became 'unexplained')."""
    v = values[np.isfinite(values)]
    if v.size < 10:
        return floor
    d = np.diff(v, order)
    mad = 1.4826 * np.median(np.abs(d - np.median(d)))
    return max(floor, mad / math.sqrt(math.comb(2 * order, order)), quantisation_step(v) / math.sqrt(12.0))


def prepare(trace: MeasuredTrace, control_period_s: float, mask: np.ndarray | None = None) -> TraceData:
    ends, duty = trace.duty_at_control_steps(control_period_s)
    rel = trace.t - trace.t[0]
    steps = np.rint(rel / control_period_s).astype(int) - 1  # sample at the end of step k
    outputs: dict[str, np.ndarray] = {}
    noise: dict[str, float] = {}
    for name, (attr, _, floor) in OUTPUT_COLUMNS.items():
        values = getattr(trace, attr)
        if values is not None and np.isfinite(values).sum() > 10:
            outputs[name] = values
            noise[name] = noise_level(values, floor)
    m = np.ones(len(trace.t), dtype=bool) if mask is None else mask
    first_on = np.flatnonzero(trace.duty > 0)
    rest = None
    if first_on.size and first_on[0] >= MIN_REST_SAMPLES and np.isfinite(trace.position[: first_on[0]]).all():
        rest = np.zeros(len(trace.t), dtype=bool)
        rest[: first_on[0]] = True
    return TraceData(trace, np.ascontiguousarray(duty), np.clip(steps, -1, len(duty) - 1), outputs, noise, m, rest)


def model_for_trace(model: ModelConfig, trace: MeasuredTrace) -> ModelConfig:
    """Apply the trace's sidecar conditions (supply, diameter, PWM, ambient) to a model."""
    return with_conditions(model, {key: trace.conditions[key] for key in SIDECAR_KEYS if key in trace.conditions})


def shared_conditions(traces: Sequence[MeasuredTrace]) -> tuple[dict[str, float], dict[str, list[float | None]]]:
    """The sidecar conditions of ``traces``: those every trace gives with one value (the
    conditions the actuator ran under in all of them), and those the traces give with
    different values or only some give ({key: each trace's value, None where not given})."""
    shared: dict[str, float] = {}
    differing: dict[str, list[float | None]] = {}
    for key in SIDECAR_KEYS:
        values = [t.conditions.get(key) for t in traces]
        if all(v is None for v in values):
            continue
        if None not in values and len(set(values)) == 1:
            shared[key] = float(values[0])  # type: ignore[arg-type]
        else:
            differing[key] = values
    return shared, differing


def with_conditions(model: ModelConfig, conditions: Mapping[str, float]) -> ModelConfig:
    """``model`` with sidecar ``conditions`` ({key of ``SIDECAR_KEYS``: value}) set."""
    changes = {SIDECAR_KEYS[key]: value for key, value in conditions.items()}
    return model.with_actuator(**changes) if changes else model


def assumed_conditions(model: ModelConfig, trace: MeasuredTrace) -> dict[str, float]:
    """The conditions the trace's sidecar does not give, as ``model`` sets them (what a
    diagnosis of the trace assumes)."""
    return {key: condition_value(model, key) for key in SIDECAR_KEYS if key not in trace.conditions}


def condition_value(model: ModelConfig, key: str) -> float:
    """The value ``model`` gives the sidecar condition ``key`` (of ``SIDECAR_KEYS``)."""
    group, name = SIDECAR_KEYS[key].split(".")
    return float(getattr(getattr(model.actuator, group), name))


def simulate(
    models: Sequence[ModelConfig],
    offsets: Sequence[float],
    data: TraceData,
    control_period_s: float,
    used_only: bool = False,
) -> dict[str, np.ndarray]:
    """Simulated outputs at the trace's samples, one column per model: {output: (samples, n)}.

    ``used_only`` stops the simulation after the last sample that the data's mask (or its
    rest) uses; the later samples are then NaN. The model is causal, so the used samples
    are the same bit for bit, and a fit on the first 70 % of a split file simulates 70 % of
    it (the held-out part, at the file's end, still simulates the whole file).
    """
    duty = data.duty
    if used_only:
        used = data.mask if data.rest is None else data.mask | data.rest
        duty = duty[: max(1, int(data.sample_steps[used].max(initial=0)) + 1)]
    sim = Simulator([model_for_trace(m, data.trace) for m in models], control_period_s=control_period_s)
    record = tuple(OUTPUT_COLUMNS[name][1] for name in data.outputs)
    rec = sim.run(np.repeat(duty[:, None], len(models), axis=1), record=record)
    out = {}
    idx = data.sample_steps
    after = idx >= len(duty)  # (only with used_only) past the end of the simulation
    for name in data.outputs:
        series = rec[OUTPUT_COLUMNS[name][1]]
        first = np.where(after[:, None], np.nan, series[np.clip(idx, 0, len(duty) - 1)])
        if name == "position":
            # Before the first control step ends the actuator is at rest.
            first = np.where((idx < 0)[:, None], 0.0, first)
            if data.rest is not None:
                # Each column's mean summed alone (contiguous), so that a column's result
                # does not depend on how many others share the batch (threads split it).
                gap = data.outputs["position"][data.rest, None] - first[data.rest]
                zero = np.ascontiguousarray(gap.T).mean(axis=1)
                first = first + zero[None, :]
            else:
                first = first + np.asarray(offsets)[None, :]
        out[name] = first
    return out


def simulate_traces(
    models: Sequence[ModelConfig],
    offsets: Sequence[float],
    traces: Sequence[TraceData],
    control_period_s: float,
    threads: int = 1,
    used_only: bool = False,
) -> list[dict[str, np.ndarray]]:
    """:func:`simulate` for each trace, the models and the traces split over ``threads``."""
    if threads <= 1 or len(models) * len(traces) < 2:
        return [simulate(models, offsets, d, control_period_s, used_only) for d in traces]
    parts = [c for c in np.array_split(np.arange(len(models)), min(threads, len(models))) if c.size]
    tasks = [(d, c) for d in traces for c in parts]
    with ThreadPoolExecutor(max_workers=min(threads, len(tasks))) as pool:
        done = list(
            pool.map(
                lambda task: simulate(
                    [models[k] for k in task[1]], [offsets[k] for k in task[1]], task[0], control_period_s, used_only
                ),
                tasks,
            )
        )
    out = []
    for j, d in enumerate(traces):
        pieces = done[j * len(parts) : (j + 1) * len(parts)]
        out.append({name: np.concatenate([p[name] for p in pieces], axis=1) for name in d.outputs})
    return out


def residuals(sim: dict[str, np.ndarray], data: TraceData) -> np.ndarray:
    """Noise-normalised residuals (measured - simulated), stacked over outputs: (m, n)."""
    parts = []
    for name, measured in data.outputs.items():
        keep = data.mask & np.isfinite(measured)
        r = (measured[keep, None] - sim[name][keep]) / data.noise[name]
        # A reading the model cannot produce (NaN: no pulse long enough) counts as a large
        # miss rather than disappearing from the fit.
        parts.append(np.where(np.isfinite(r), r, 10.0))
    return np.concatenate(parts, axis=0)


def rms_by_output(sim: dict[str, np.ndarray], data: TraceData, mask: np.ndarray | None = None) -> dict[str, float]:
    """Root-mean-square error per output in SI units over ``mask`` (default: the data's)."""
    m = data.mask if mask is None else mask
    out = {}
    for name, measured in data.outputs.items():
        keep = m & np.isfinite(measured) & np.isfinite(sim[name][:, 0])
        if keep.any():
            out[name] = float(np.sqrt(np.mean((measured[keep] - sim[name][keep, 0]) ** 2)))
    return out


@dataclass
class Fit:
    """Result of fitting one candidate."""

    name: str
    parameters: tuple[FitParameter, ...]
    values: np.ndarray
    stderr: np.ndarray
    cost: float  # sum of squared normalised residuals over the fitted samples
    n: int
    model: ModelConfig
    offset: float
    success: bool = True
    message: str = ""
    correlation_time_samples: float = 1.0

    @property
    def k(self) -> int:
        return len(self.parameters)

    def values_by_name(self) -> dict[str, float]:
        return {p.name: float(v) for p, v in zip(self.parameters, self.values)}

    def as_dict(self) -> dict[str, dict[str, float]]:
        return {
            p.name: {"value": float(v), "uncertainty": float(s), "unit": p.unit}
            for p, v, s in zip(self.parameters, self.values, self.stderr)
        }


class Problem:
    """Fit data (one or more traces) and the nominal model; evaluates candidates in batches."""

    def __init__(
        self,
        nominal: ModelConfig,
        traces: Sequence[TraceData],
        control_period_s: float,
        threads: int | None = None,
    ):
        self.nominal = nominal
        self.traces = list(traces)
        self.dt = control_period_s
        self.electrical = any(name != "position" for t in traces for name in t.outputs)
        self.threads = default_threads() if threads is None else require_threads("threads", threads)

    def nominal_parameters(self) -> tuple[FitParameter, ...]:
        params = tuple(p for p in NOMINAL if p.kind != "offset")
        if any(t.rest is None for t in self.traces):
            params += tuple(p for p in NOMINAL if p.kind == "offset")
        # The resistivity level always: on position-only data it is the heating power's
        # level, as uncertain as ever; without it a supply sag (measured: 0.03 ohm) was
        # named on clean data for a 2 % resistivity error the refit could not absorb.
        return params + (RESISTIVITY,)

    def _grid_start(
        self, params: Sequence[FitParameter], base: np.ndarray, ks: Sequence[int], size: int = 12
    ) -> np.ndarray:
        """The best point of a grid over the ranges of parameters ``ks`` (their product; the
        others at ``base``), in one batched simulation. The first gets ``size`` + 1 values,
        each further one ``SWEEP_SIZE_EXTRA`` values spaced as a scale (each axis
        multiplies the cost)."""
        axes = [
            _grid_values(params[k], size) if n == 0 else _grid_values(params[k], SWEEP_SIZE_EXTRA - 1, True)
            for n, k in enumerate(ks)
        ]
        points = []
        for values in itertools.product(*axes):
            point = base.copy()
            point[list(ks)] = values
            points.append(point)
        costs = np.sum(self.residual_matrix(params, points) ** 2, axis=0)
        return points[int(np.argmin(costs))]

    def residual_matrix(self, parameters: Sequence[FitParameter], points: Sequence[np.ndarray]) -> np.ndarray:
        """Residual vectors of several parameter points at once: (m, len(points))."""
        models, offsets = zip(*(apply(self.nominal, parameters, p) for p in points))
        sims = simulate_traces(models, offsets, self.traces, self.dt, self.threads, used_only=True)
        blocks = [residuals(sim, d) for sim, d in zip(sims, self.traces)]
        return np.concatenate(blocks, axis=0)

    def fit(
        self,
        name: str,
        parameters: Sequence[FitParameter],
        max_nfev: int = 40,
        warm: dict[str, float] | None = None,
        sweep: Sequence[str] = (),
        sweep_effect: str | None = None,
        also_from: Sequence[dict[str, float]] = (),
    ) -> Fit:
        """Bounded least squares from the starts of :func:`starts_for`, and from the best
        point of a sweep (one batched simulation each): over the range of one effect's
        parameter (``sweep_effect``'s when it has one fitted parameter, else the only
        effect parameter there is), then from there over the grid of the ``sweep``
        parameters' ranges; and from each of ``also_from`` (values by name, the others at
        their starts). A TRF run that ends at ``max_nfev`` is continued by a short
        dogbox run (``POLISH_MAX_NFEV``), kept if it ends lower."""
        from scipy.optimize import least_squares

        params = tuple(parameters)
        lower = np.array([p.lower for p in params])
        upper = np.array([p.upper for p in params])
        span = upper - lower
        best = None
        effect_idx = [k for k, p in enumerate(params) if p.kind == "effect" and sweep_effect in (None, p.effect)]
        starts = starts_for(params, warm)
        # A local fit can stall in the rugged landscape of a large mismatch, so first sweep
        # the effect's range in one batched simulation and start from the best. The effects
        # found earlier stay at their warm values: without ``sweep_effect`` a candidate on top
        # of them was never swept (measured: a Stribeck friction refitted in its own form on
        # top of a supply sag stopped at 8.5x the noise held out, with the sweep at 4.1x).
        grids = [self._grid_start(params, starts[0], effect_idx)] if len(effect_idx) == 1 else []
        if sweep:
            names = [p.name for p in params]
            base = grids[0] if grids else starts[0]
            grids.append(self._grid_start(params, base, [names.index(n) for n in sweep]))
        if grids:
            # Every sweep's point is a start: the grid over the ``sweep`` parameters holds
            # the effect's best size but not the nominal values it was found at, so its best
            # can be worse than where it began (measured: a friction swept to 4.5x the noise
            # on the fitted data, then the shift and convection grid's best at 14.2x, and the
            # best fit from its starts ended at 5.9x).
            starts = [starts[0], *grids]
        starts += [np.array([w.get(p.name, p.start) for p in params]) for w in also_from]
        tried: list[np.ndarray] = []
        for start in starts:
            if any(np.allclose(start, t) for t in tried):
                continue
            tried.append(start)
            cache: dict[bytes, np.ndarray] = {}

            def residual(u: np.ndarray, cache=cache) -> np.ndarray:
                key = u.tobytes()
                if key not in cache:
                    if len(cache) > 4:
                        cache.clear()
                    cache[key] = self.residual_matrix(params, [u])[:, 0]
                return cache[key]

            def jacobian(u: np.ndarray) -> np.ndarray:
                # Forward differences from the residual at ``u`` (TRF asks for it first),
                # the columns in one batched simulation. Only where TRF needs them: a
                # rejected trial step needs none, and a batch costs in proportion to its
                # size, so computing the columns with every residual wasted them on every
                # rejected step (measured, the four-run real-bench diagnosis: 22 % of its
                # simulated columns). A
                # column's result does not depend on its batch, so the fits are unchanged
                # bit for bit.
                h = 1e-3 * span
                # Step inwards at an upper bound so every column stays feasible.
                h = np.where(u + h > upper, -h, h)
                res = self.residual_matrix(params, [u + np.eye(len(u))[k] * h[k] for k in range(len(u))])
                return (res - residual(u)[:, None]) / h[None, :]

            def solve(x0: np.ndarray, method: str, budget: int, residual=residual, jacobian=jacobian):
                return least_squares(
                    residual,
                    x0,
                    jac=jacobian,
                    bounds=(lower, upper),
                    x_scale=span,
                    max_nfev=budget,
                    method=method,
                )

            sol = solve(np.clip(start, lower, upper), "trf", max_nfev)
            if sol.status == 0:
                # Stopped by the budget while still descending: dogbox's rectangular trust
                # region follows the ravine TRF crawls along (``POLISH_MAX_NFEV``). It
                # starts at TRF's end and is kept only if it ends lower, so a fit that
                # converged is unchanged and no fit gets worse.
                polish = solve(sol.x, "dogbox", POLISH_MAX_NFEV)
                if polish.cost < sol.cost:
                    sol = polish
            if best is None or sol.cost < best.cost:
                best = sol
        res, jac = best.fun, best.jac
        n = res.size
        cost = float(np.sum(res**2))
        tau = correlation_time(res)
        stderr = _stderr(jac, cost, n, len(params), tau)
        model, offset = apply(self.nominal, params, best.x)
        return Fit(name, params, best.x, stderr, cost, n, model, offset, bool(best.success), best.message, tau)


def correlation_time(res: np.ndarray) -> float:
    """Integrated autocorrelation time of the residuals, in samples (>= 1).

    Model-error residuals are smooth, not white: each sample does not carry independent
    information, and an information criterion on the raw count would reward anything.
    """
    r = res - res.mean()
    if r.size < 8 or not np.any(r):
        return 1.0
    f = np.fft.rfft(r, 2 * r.size)
    acf = np.fft.irfft(f * np.conj(f))[: r.size]
    acf /= acf[0]
    below = np.flatnonzero(acf < math.exp(-1.0))
    lag = below[0] if below.size else r.size
    return float(max(1.0, lag))


def _stderr(jac: np.ndarray, cost: float, n: int, k: int, tau: float) -> np.ndarray:
    dof = max(1, n - k)
    s2 = cost / dof
    try:
        cov = np.linalg.pinv(jac.T @ jac) * s2 * tau  # inflate for correlated residuals
        return np.sqrt(np.clip(np.diag(cov), 0.0, None))
    except np.linalg.LinAlgError:
        return np.full(k, math.nan)

"""How the calibrated numbers in :mod:`sma_gym.params` were obtained (re-runnable).

``python -m sma_gym.calibration`` solves, for the standard actuator,

* h0 so that the open-loop duty holding 5 mm at 10 V on the heating branch is 0.06 (T4);
* rho_A so that the resistance near 7 mm while heating in the §4.2 experiment is 3.25 ohm (T3);

(h2 / h0 is fixed by the shape argument in :class:`~sma_gym.params.Convection`; rho_M by the
cold resistance 3.75 ohm in closed form). The two interact weakly (h sets the temperature at
7 mm, rho_A the power at a given duty), so it alternates secant steps until both hit their
targets, then prints the values to write into ``params.py``.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

from sma_gym import fidelity
from sma_gym.extras import MissingExtraError, require
from sma_gym.model import ModelConfig
from sma_gym.params import FORCED_CONVECTION_FACTOR, preset, standard

if TYPE_CHECKING:
    from sma_gym.diagnosis.workflow import Diagnosis


def _model(h0: float, rho_a: float, forced: bool = False) -> ModelConfig:
    p = standard()
    factor = FORCED_CONVECTION_FACTOR if forced else 1.0
    ratio = p.convection.h2_w_m2_k3 / p.convection.h0_w_m2_k
    conv = replace(p.convection, h0_w_m2_k=h0 * factor, h2_w_m2_k3=h0 * ratio * factor)
    return ModelConfig(replace(p, convection=conv, wire=replace(p.wire, resistivity_austenite_ohm_m=rho_a)))


def holding_duty_5mm(h0: float, rho_a: float) -> float:
    import numpy as np

    curve = fidelity.holding_curve(_model(h0, rho_a), duties=np.linspace(0.05, 0.07, 41))
    return fidelity.holding_duty_at(curve, 5e-3)


def resistance_7mm(h0: float, rho_a: float) -> float:
    import math

    import numpy as np

    from sma_gym.simulator import Simulator

    sim = Simulator(_model(h0, rho_a, forced=True))
    xs, rs, vs = [], [], []
    last = 0.0
    for k in range(40000):
        t = k * 1e-3
        ref = 4e-3 - 3e-3 * math.cos(2.0 * math.pi * 0.05 * t)
        sim.step(min(0.8, max(0.025, 1000.0 * (ref - sim.position_measured_m[0]))))
        if t >= 20.0:
            xs.append(sim.position_measured_m[0])
            rs.append(sim.resistance_measured_ohm[0])
            vs.append((sim.position_m[0] - last) / 1e-3)
        last = sim.position_m[0]
    x, r, v = np.array(xs), np.array(rs), np.array(vs)
    heat = (x > 1e-3) & (x < 6.5e-3) & (v > 1e-4) & np.isfinite(r)
    return float(np.polyval(np.polyfit(x[heat], r[heat], 1), 7e-3))


def calibrate(h0: float, rho_a: float, rounds: int = 4) -> tuple[float, float]:
    for _ in range(rounds):
        d = holding_duty_5mm(h0, rho_a)
        d2 = holding_duty_5mm(h0 * 1.02, rho_a)
        h0 = h0 + (0.06 - d) * (0.02 * h0) / (d2 - d)
        r = resistance_7mm(h0, rho_a)
        r2 = resistance_7mm(h0, rho_a * 1.01)
        rho_a = rho_a + (3.25 - r) * (0.01 * rho_a) / (r2 - r)
        print(f"h0 = {h0:.3f} W/(m^2 K)  rho_A = {rho_a:.5e} ohm m   (duty {d:.5f}, R7 {r:.4f})")
    print(f"final: duty(5 mm) = {holding_duty_5mm(h0, rho_a):.5f}, R(7 mm) = {resistance_7mm(h0, rho_a):.4f}")
    return h0, rho_a


# --------------------------------------------------------------------------------------
# The real bench (shared/data/real): identify what its README leaves unknown
# --------------------------------------------------------------------------------------
#: What the bench's README leaves unknown, with physically plausible bounds: natural
#: convection within +-50 % of the thin-wire correlation (h0 is given at 0.3 mm and scaled to
#: 0.5 mm by d^-0.556), a preload that keeps a sleigh on a 0.07 N/mm spring in contact, the
#: recoverable strain of a lightly loaded wire. The expansion coefficients stay at NiTi's
#: values (6.6e-6 /K martensite, 11e-6 /K austenite): freed, the fit drives them to zero to
#: hide the early start of the transformation, which is a missing effect for the diagnosis to
#: find, not a calibration.
BENCH_FIT_PARAMETERS = (
    ("convection.h0_w_m2_k", 40.0, 150.0),
    ("wire.max_transformation_strain", 0.005, 0.05),
    ("mechanism.spring_preload_n", 0.2, 5.0),
)


def bench_models(values):
    """Bench preset with the fitted fields set (h2 keeps the standard h2/h0 ratio)."""
    from sma_gym.params import bench_05mm_ht

    base = bench_05mm_ht()
    ratio = base.convection.h2_w_m2_k3 / base.convection.h0_w_m2_k
    changes = {name: float(v) for (name, _, _), v in zip(BENCH_FIT_PARAMETERS, values)}
    changes["convection.h2_w_m2_k3"] = changes["convection.h0_w_m2_k"] * ratio
    return ModelConfig(base.with_changes(**changes))


def bench_residuals(trace, columns, offsets):
    """Measured minus simulated position at the trace's samples, one column per model."""
    import numpy as np

    from sma_gym.simulator import Simulator

    ends, duty = trace.duty_at_control_steps(1e-3)
    sim = Simulator(columns)
    rec = sim.run(np.repeat(duty[:, None], len(columns), axis=1), record=("position_measured_m",))
    sim_t = np.r_[trace.t[0], ends]
    sim_x = np.vstack([np.zeros((1, len(columns))), rec["position_measured_m"]])
    out = np.empty((len(trace.t), len(columns)))
    for j in range(len(columns)):
        out[:, j] = trace.position - (np.interp(trace.t, sim_t, sim_x[:, j]) + offsets[j])
    return out


def calibrate_bench(fit_file: str = "step01.csv", check_file: str = "ramp01.csv"):
    """Fit the bench's unknown parameters on ``fit_file``.

    The sensor's zero (which differs between runs, README) is read off the rest segment
    before the duty first rises. Bounded least squares (scipy) on the position; the
    Jacobian by finite differences, run as extra columns of one batched simulation. Prints
    the fit and the RMS error on both files (``check_file`` is never used in the fit).
    """
    import numpy as np

    require("scipy", purpose="python -m sma_gym.calibration", extra="diagnose")
    from scipy.optimize import least_squares

    from sma_gym.data import find_real_data_dir, load_trace
    from sma_gym.data.measured import REAL_DATA_ENV
    from sma_gym.params import bench_05mm_ht

    folder = find_real_data_dir()
    if folder is None:
        raise ValueError(f"shared/data/real not found: run from the project next to ../shared, or set {REAL_DATA_ENV}")
    fit = load_trace(folder / fit_file)
    check = load_trace(folder / check_file)
    base = bench_05mm_ht()
    lower = np.array([b[1] for b in BENCH_FIT_PARAMETERS])
    upper = np.array([b[2] for b in BENCH_FIT_PARAMETERS])
    start = np.array(
        [
            base.convection.h0_w_m2_k,
            base.wire.max_transformation_strain,
            base.mechanism.spring_preload_n,
        ]
    )
    scale = upper - lower

    def zero_of(trace):
        rest = trace.t < trace.t[np.argmax(trace.duty > 0)]
        return float(np.mean(trace.position[rest]))

    zero_fit = zero_of(fit)

    def residual_and_jacobian(u):
        steps = np.diag(1e-3 * scale)
        points = [u] + [u + steps[k] for k in range(len(u))]
        cols = [bench_models(p) for p in points]
        res = bench_residuals(fit, cols, [zero_fit] * len(points))
        jac = (res[:, 1:] - res[:, :1]) / np.diag(steps)[None, :]
        return res[:, 0], jac

    cache = {}

    def fun(u):
        key = tuple(u)
        if key not in cache:
            cache.clear()
            cache[key] = residual_and_jacobian(u)
        return cache[key][0]

    def jac(u):
        fun(u)
        return cache[tuple(u)][1]

    sol = least_squares(fun, start, jac=jac, bounds=(lower, upper), x_scale=scale, max_nfev=60)
    values = sol.x
    for (name, lo, hi), v in zip(BENCH_FIT_PARAMETERS, values):
        at_bound = " (at its bound)" if min(v - lo, hi - v) < 1e-3 * (hi - lo) else ""
        print(f"{name} = {v:.6g}{at_bound}")
    model = bench_models(values)
    for trace in (fit, check):
        zero = zero_of(trace)
        before = bench_residuals(trace, [ModelConfig(base)], [zero])[:, 0]
        after = bench_residuals(trace, [model], [zero])[:, 0]
        print(
            f"{trace.name}: RMS position error {np.sqrt(np.mean(before**2)) * 1e3:.3f} mm (preset guess) -> "
            f"{np.sqrt(np.mean(after**2)) * 1e3:.3f} mm (fitted)"
        )
    return values


def _verdict_words(result: Diagnosis) -> str:
    """How the twin's notes introduce its effects: found, or only carried when the verdict is
    ``partial`` (they close less than half of the held-out gap, docs/diagnosis.md)."""
    if result.verdict != "partial":
        return "effects found"
    from sma_gym.diagnosis.workflow import explained_text

    return f"verdict partial, effects carried but not named as found (they close {explained_text(result.explained)})"


def identify_twin(folder: str | None = None, max_rounds: int = 3, write: bool = True) -> ModelConfig:
    """Identify the ``bench-0.5mm-ht`` twin on the four shared real runs and write it.

    ``sma-gym diagnose`` on all four runs (the model chosen on the first 70 % of each, the
    last 30 % held out, then refitted on the whole runs, as the workflow does without
    held-out files) from the datasheet actuator ``bench-0.5mm-ht-datasheet``, up to
    ``max_rounds`` rounds; the corrected model, with the effects found and the gap it
    reached in its notes, becomes ``sma_gym/models/bench-0.5mm-ht.json``.
    """
    from pathlib import Path

    from sma_gym.data import REAL_BENCH_RUNS, find_real_data_dir, load_trace
    from sma_gym.data.measured import REAL_DATA_ENV
    from sma_gym.diagnosis import diagnose
    from sma_gym.diagnosis.workflow import HOLDOUT_FRACTION
    from sma_gym.models import twin_path

    where = Path(folder) if folder else find_real_data_dir()
    if where is None or not where.is_dir():
        raise ValueError(f"the shared real runs (../shared/data/real, or ${REAL_DATA_ENV}) are not on this machine")
    if write:  # before the minutes of the diagnosis: a read-only install failed only after them
        from sma_gym._io import check_output_file

        check_output_file(twin_path("bench-0.5mm-ht"), "the twin's file", overwrite=True)
    traces = [load_trace(where / name) for name in REAL_BENCH_RUNS]
    nominal = ModelConfig(preset("bench-0.5mm-ht-datasheet"))
    result = diagnose(traces, [], nominal, max_rounds=max_rounds, progress=lambda m: print("twin:", m, flush=True))
    # Without held-out files the workflow refits the chosen model on the whole runs (step 9).
    whole = result.whole_file_refit or {"rms_by_file": {}, "parameters_at_bounds": []}
    gap = ", ".join(f"{name} {rms['refitted']['position'] * 1e3:.3f} mm" for name, rms in whole["rms_by_file"].items())
    chosen = ", ".join(
        f"{name} {rms['selected']['position'] * 1e3:.3f} mm" for name, rms in whole["rms_by_file"].items()
    )
    found = ", ".join(result.effects_found) or "none"
    if result.carried:
        # Say so, or the notes ("effects found: none") would contradict the file's effects.
        last = result.rounds[-1]["effect"]
        rivals = last if isinstance(last, str) else " or ".join(last)
        found += f"; also carries {result.carried}, the best held out of the last round's ambiguous {rivals}"
    at_bounds = "; ".join(whole["parameters_at_bounds"]) or "none"
    held = round(HOLDOUT_FRACTION * 100)
    twin = ModelConfig(
        replace(
            result.corrected_model.actuator,
            name="bench-0.5mm-ht",
            description=(
                "Twin of the real bench of shared/data/real (0.5 mm HT Flexinol, 0.96 m, 24 V, 35 g sleigh, "
                "0.07 N/mm spring), identified on its four shared runs by python -m sma_gym.calibration twin."
            ),
        ),
        result.corrected_model.effects,
        notes=(
            f"Identified by python -m sma_gym.calibration twin from bench-0.5mm-ht-datasheet on {', '.join(REAL_BENCH_RUNS)} "
            f"(chosen on the first {100 - held} % of each run, the last {held} % held out, then refitted on the whole runs), "
            f"{len(result.rounds)} round(s); {_verdict_words(result)}: {found}. "
            f"Position RMS over each whole run: {gap} (as chosen, before the refit: {chosen}). "
            f"Fitted parameters at a bound (findings, docs/diagnosis.md): {at_bounds}."
        ),
    )
    if write:
        path = twin.save(twin_path("bench-0.5mm-ht"))
        print(f"twin: wrote {path}")
    print("twin:", twin.notes)
    return twin


def main(argv: list[str] | None = None) -> None:
    """``python -m sma_gym.calibration [standard|bench|twin]``: re-derive calibrated numbers."""
    import argparse

    parser = argparse.ArgumentParser(
        prog="python -m sma_gym.calibration",
        description="Re-derive the calibrated numbers of sma_gym.params and the bench twin (prints them; "
        "'twin' also writes sma_gym/models/bench-0.5mm-ht.json).",
    )
    parser.add_argument(
        "target",
        nargs="?",
        default="standard",
        choices=("standard", "bench", "twin"),
        help="standard: h0 and rho_A of the report's actuator (default); bench: the datasheet bench "
        "preset's fitted parameters; twin: the bench-0.5mm-ht twin from the four shared real runs",
    )
    target = parser.parse_args(argv).target
    try:
        if target in ("bench", "twin"):
            # Before any work: the fits need scipy (the diagnose extra), and a lean install
            # must say so rather than fail minutes into a diagnosis.
            require("scipy", purpose=f"python -m sma_gym.calibration {target}", extra="diagnose")
        if target == "bench":
            calibrate_bench()
        elif target == "twin":
            identify_twin()
        else:
            p = standard()
            calibrate(p.convection.h0_w_m2_k, p.wire.resistivity_austenite_ohm_m)
    except (MissingExtraError, ValueError) as err:
        # Missing or malformed real runs, a read-only install: one message, not a traceback.
        parser.exit(2, f"{parser.prog}: error: {err}\n")


if __name__ == "__main__":
    main()

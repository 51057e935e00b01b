"""Synthetic measured traces with a hidden effect (``sma-gym synth``).

A trace is recorded the way a lab would: a P controller (Kp = 1000 per metre, the report's
gain) drives the actuator to follow an excitation reference, commanding once per sample
(``--sample-period``; the actuator is simulated in 1 ms steps), and the commanded duty, the
position reading and the electrical readings are written in the measured-data format. The
duty is kept at or above the minimum that makes resistance readable, so that R, I and V can
be recorded (the report's self-sensing practice, §4.1).

The hidden truth goes into a separate labels file (``<name>.labels.json``), which
``diagnose`` never reads. To avoid the "inverse crime" (diagnosing data with the very model
that produced it), the data can be generated with

* an effect in an alternative form (``--form``; e.g. a uniform rather than Gaussian spread,
  a second-order rather than first-order sensor lag),
* nominal parameters perturbed by a few percent (``--perturb``),
* realistic sensor noise and quantisation,

and diagnosed on a held-out file with a different excitation.
"""

from __future__ import annotations

import math
import os
import shlex
import shutil
import sys
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from sma_gym._io import check_output_file, locked_folder, signals_deferred, write_json
from sma_gym._validation import require_int_range, require_range
from sma_gym.data.measured import (
    DIAGNOSIS_MIN_ROWS,
    SIDECAR_KEYS,
    MeasuredTrace,
    sidecar_write_path,
    write_trace,
)
from sma_gym.diagnosis.fitting import condition_value
from sma_gym.effects import EFFECTS
from sma_gym.model import ModelConfig, load_model, model_names
from sma_gym.simulator import Simulator

EXCITATIONS = ("steps", "ramps", "sine", "chirp", "random")
MIN_STEPS_DURATION_S = 7.0
"""A 'steps' file this long always holds a step of at least :data:`MIN_DRIVEN_S` (the first
comes 3-6 s in)."""
MIN_DRIVEN_S = 1.0
"""Shortest time a synthetic file's reference asks for motion (the wire takes about a second
to reach its transformation at 10 V)."""
CONTROL_PERIOD_S = 1e-3
KP_PER_M = 1000.0
REST_STEPS = 1000  # 1 s at rest before the excitation starts
MIN_DURATION_S = 2.0
"""The first second is at rest; a trace needs at least another second of excitation."""
MAX_SAMPLE_PERIOD_S = 0.1
"""Slower than 10 Hz misses the actuator's thermal transients (time constants of ~1 s)."""
MIN_SAMPLES = 100
"""Fewest samples written (well above the loader's minimum, so the diagnosis has data to fit)."""
MAX_NOISE_FRACTION = 0.05
"""Largest sensor noise or resolution, as a fraction of the stroke or cold resistance: more
would bury the signal a diagnosis looks for (and 1 m of position noise is a unit slip)."""


def excitation(kind: str, duration_s: float, stroke_m: float, rng: np.random.Generator) -> np.ndarray:
    """Reference position [m] at each 1 ms step for the excitation ``kind``."""
    n = int(round(duration_s / CONTROL_PERIOD_S))
    t = np.arange(n) * CONTROL_PERIOD_S
    lo, hi = 0.1 * stroke_m, 0.85 * stroke_m
    if kind == "steps":
        times, levels = [1.0], [0.0]
        while times[-1] < duration_s:
            times.append(times[-1] + rng.uniform(2.0, 5.0))
            levels.append(rng.uniform(lo, hi))
        idx = np.searchsorted(times, t, side="right") - 1
        ref = np.asarray(levels)[np.clip(idx, 0, len(levels) - 1)]
        ref[t < 1.0] = 0.0
        return ref
    if kind == "ramps":
        corners_t, corners_x = [0.0, 1.0], [0.0, 0.0]
        while corners_t[-1] < duration_s:
            corners_t.append(corners_t[-1] + rng.uniform(1.5, 5.0))
            corners_x.append(rng.uniform(lo, hi))
        return np.interp(t, corners_t, corners_x)
    if kind == "sine":
        f = rng.uniform(0.08, 0.15)
        mid, amp = 0.5 * (lo + hi), 0.5 * (hi - lo)
        ref = mid - amp * np.cos(2.0 * math.pi * f * (t - 1.0))
        ref[t < 1.0] = 0.0
        return ref
    if kind == "chirp":
        f0, f1 = 0.03, 0.4
        tt = np.clip(t - 1.0, 0.0, None)
        phase = 2.0 * math.pi * (f0 * tt + 0.5 * (f1 - f0) * tt**2 / duration_s)
        mid, amp = 0.5 * (lo + hi), 0.5 * (hi - lo)
        ref = mid - amp * np.cos(phase)
        ref[t < 1.0] = 0.0
        return ref
    if kind == "random":
        knots_t = np.arange(0.0, duration_s + 2.0, rng.uniform(0.8, 1.5))
        knots_x = rng.uniform(lo, hi, size=knots_t.size)
        knots_x[:2] = 0.0
        # Cosine interpolation: smooth, bounded rate.
        idx = np.clip(np.searchsorted(knots_t, t, side="right") - 1, 0, knots_t.size - 2)
        u = (t - knots_t[idx]) / (knots_t[idx + 1] - knots_t[idx])
        c = 0.5 * (1.0 - np.cos(math.pi * u))
        return knots_x[idx] + (knots_x[idx + 1] - knots_x[idx]) * c
    raise ValueError(f"excitation = {kind!r}: expected one of {', '.join(EXCITATIONS)}")


def perturb(model: ModelConfig, size: float, rng: np.random.Generator) -> tuple[ModelConfig, dict[str, float]]:
    """Nominal parameters off by a few percent (what a real actuator's datasheet hides)."""
    if size == 0.0:
        return model, {}
    a = model.actuator
    w, c, m = a.wire, a.convection, a.mechanism
    f = {
        "convection_scale": float(1.0 + size * rng.uniform(-1, 1)),
        "temperature_shift_k": float(30.0 * size * rng.uniform(-1, 1)),
        "strain_scale": float(1.0 + 0.6 * size * rng.uniform(-1, 1)),
        "preload_scale": float(1.0 + 2.0 * size * rng.uniform(-1, 1)),
        "resistivity_scale": float(1.0 + 0.4 * size * rng.uniform(-1, 1)),
        "mass_scale": float(1.0 + 2.0 * size * rng.uniform(-1, 1)),
    }
    shift = f["temperature_shift_k"]
    perturbed = model.with_actuator(
        **{
            "convection.h0_w_m2_k": c.h0_w_m2_k * f["convection_scale"],
            "convection.h2_w_m2_k3": c.h2_w_m2_k3 * f["convection_scale"],
            "wire.austenite_start_c": w.austenite_start_c + shift,
            "wire.austenite_finish_c": w.austenite_finish_c + shift,
            "wire.martensite_start_c": w.martensite_start_c + shift,
            "wire.martensite_finish_c": w.martensite_finish_c + shift,
            "wire.max_transformation_strain": w.max_transformation_strain * f["strain_scale"],
            "wire.resistivity_martensite_ohm_m": w.resistivity_martensite_ohm_m * f["resistivity_scale"],
            "wire.resistivity_austenite_ohm_m": w.resistivity_austenite_ohm_m * f["resistivity_scale"],
            "mechanism.spring_preload_n": m.spring_preload_n * f["preload_scale"],
            "mechanism.moving_mass_kg": m.moving_mass_kg * f["mass_scale"],
        }
    )
    return perturbed, f


@dataclass
class SynthSpec:
    """Everything that defines a synthetic trace."""

    model: ModelConfig
    effect: str | None = None
    effect_values: Mapping[str, float] | None = None
    form: str = "default"
    excitation: str = "steps"
    duration_s: float = 60.0
    position_noise_m: float = 5e-6
    position_resolution_m: float = 1e-6
    resistance_noise_ohm: float = 2e-3
    electrical: bool = True
    perturb: float = 0.0
    sample_period_s: float = 1e-3
    seed: int = 0
    actuator_seed: int | None = None
    """Seed of the nominal perturbation alone (which actuator), so that runs of one actuator
    can differ in ``seed`` (excitation and noise); ``None``: drawn from ``seed`` with the
    rest, so every seed is another actuator. The perturbation is the first draw of either
    stream, so ``actuator_seed=k`` is the actuator of ``seed=k``."""

    def truth(self) -> ModelConfig:
        """The model that generates the data (before the nominal perturbation)."""
        model = self.model
        if self.effect is not None:
            effect = EFFECTS[self.effect]
            values = dict(self.effect_values or {p.name: p.typical for p in effect.parameters})
            model = model.with_effect(self.effect, values, self.form)
        return model.with_actuator(
            **{
                "sensors.position_noise_std_m": self.position_noise_m,
                "sensors.position_resolution_m": self.position_resolution_m,
                "sensors.resistance_noise_std_ohm": self.resistance_noise_ohm,
                "sensors.current_noise_std_a": 0.5 * self.resistance_noise_ohm,
                "sensors.voltage_noise_std_v": 2.0 * self.resistance_noise_ohm,
            }
        )


def generate(spec: SynthSpec, min_driven_s: float = 0.0) -> tuple[MeasuredTrace, dict[str, Any]]:
    """A measured trace and its labels; ``ValueError`` if the excitation asks for motion for
    less than ``min_driven_s`` (``sma-gym synth``: :data:`MIN_DRIVEN_S`)."""
    rng = np.random.default_rng(spec.seed)
    actuator_rng = rng if spec.actuator_seed is None else np.random.default_rng(spec.actuator_seed)
    truth, perturbation = perturb(spec.truth(), spec.perturb, actuator_rng)
    stroke = truth.actuator.usable_stroke_m
    ref = excitation(spec.excitation, spec.duration_s, stroke, rng)
    driven_s = np.count_nonzero(ref > 0.0) * CONTROL_PERIOD_S
    if driven_s < min_driven_s:
        # 'steps' rests 2-5 s after its first second: a short file was all rest, and a
        # diagnosis of it found "no missing effect" in sensor noise.
        raise ValueError(
            f"--excitation {spec.excitation} over --duration {spec.duration_s:g} s: the wire is driven for "
            f"{driven_s:g} s only (its first step comes at the end); expected a longer --duration (at least "
            f"{MIN_STEPS_DURATION_S:g} s for steps) or another excitation"
        )
    sim = Simulator(truth, control_period_s=CONTROL_PERIOD_S, rng=rng)
    p = truth.actuator
    duty_min = 0.0
    if spec.electrical:
        # Long enough pulses for a V/I reading, with margin (§4.1): 1.2 x Driver.min_readable_duty,
        # multiplied in this order so that every recorded benchmark's data stay bit for bit.
        duty_min = 1.2 * p.driver.settling_time_s * p.driver.pwm_frequency_hz
    n = ref.size
    every = max(1, int(round(spec.sample_period_s / CONTROL_PERIOD_S)))
    rec = {k: np.empty(n) for k in ("duty", "position", "resistance", "current", "voltage")}
    duty = 0.0
    for k in range(n):
        # The controller runs at the sample rate: a lab that logs every 10 ms commands every
        # 10 ms, so the file's duty column is exactly the input the actuator got (a 1 ms loop
        # logged every 10th step would hide nine duties in ten from the diagnosis).
        if k % every == 0:
            # The first second at rest: a recording starts with the sensor zero.
            duty = 0.0 if k < REST_STEPS else min(1.0, max(duty_min, KP_PER_M * (ref[k] - sim.position_measured_m[0])))
        sim.step(duty)
        rec["duty"][k] = duty
        rec["position"][k] = sim.position_measured_m[0]
        rec["resistance"][k] = sim.resistance_measured_ohm[0]
        rec["current"][k] = sim.current_measured_a[0]
        rec["voltage"][k] = sim.voltage_measured_v[0]
    # Sample k is taken at the end of control step k; the duty is what was commanded then
    # (the measured-data format holds the duty from each sample to the next).
    t = (np.arange(n) + 1) * CONTROL_PERIOD_S
    t = np.r_[0.0, t][::every]
    duty = np.r_[rec["duty"], rec["duty"][-1]][::every]
    take = lambda a, first: np.r_[first, a][::every]  # noqa: E731
    trace = MeasuredTrace(
        path="synthetic",
        t=t,
        duty=duty,
        position=take(rec["position"], 0.0),
        resistance=take(rec["resistance"], math.nan) if spec.electrical else None,
        current=take(rec["current"], math.nan) if spec.electrical else None,
        wire_voltage=take(rec["voltage"], math.nan) if spec.electrical else None,
        # Every condition a sidecar can give (the generator knows them all; without the
        # diameter and the ambient every diagnosis of its files noted them as assumed).
        conditions={key: condition_value(truth, key) for key in SIDECAR_KEYS},
    )
    labels = {
        "effect": spec.effect,
        "effect_values": dict(
            spec.effect_values
            or ({} if spec.effect is None else {q.name: q.typical for q in EFFECTS[spec.effect].parameters})
        ),
        "form": spec.form,
        "perturbation": perturbation,
        "excitation": spec.excitation,
        "duration_s": spec.duration_s,
        # The P controller commanded once per sample (see the loop above).
        "sample_period_s": every * CONTROL_PERIOD_S,
        "position_noise_m": spec.position_noise_m,
        "resistance_noise_ohm": spec.resistance_noise_ohm,
        "seed": spec.seed,
        "actuator_seed": spec.seed if spec.actuator_seed is None else spec.actuator_seed,
        "model": spec.model.actuator.name,
        # The model's own effects are in the data too (a model file given as --model may
        # carry some): "effect" is only the one hidden on top of them.
        "model_effects": {s.name: s.to_dict() for s in spec.model.effects.active()},
        "electrical": spec.electrical,
    }
    return trace, labels


def output_paths(path: Path) -> tuple[Path, Path, Path]:
    """The CSV, its sidecar and the labels file that :func:`write` writes for ``path``."""
    return path, sidecar_write_path(path), path.with_name(path.stem + ".labels.json")


def check_outputs(path: Path, overwrite: bool) -> None:
    """Refuse (``ValueError``) unless all three outputs can be written; creates nothing."""
    if path.suffix.lower() != ".csv":
        # The sidecar and labels are named after the CSV: "x.json" would get "x.json.json".
        raise ValueError(f"--out {str(path)!r}: expected a .csv file name (the measured-data format is CSV)")
    for target in output_paths(path):
        check_output_file(target, "--out", overwrite=overwrite)


def write(
    spec: SynthSpec,
    path: Path,
    overwrite: bool = False,
    model_name: str | None = None,
    min_driven_s: float = 0.0,
    model_source: str | None = None,
) -> tuple[Path, Path]:
    """Write ``path`` (CSV), its sidecar ``path.json`` and the labels ``<stem>.labels.json``.

    ``model_name``, a preset or twin name, goes into the sidecar as ``"model"``, as a lab
    names its actuator's nominal model: ``sma-gym diagnose`` then starts from it without
    ``--model``. ``model_source`` (the name or file the model came from) goes into the
    labels as ``"model_source"``: a file's model name resolves to nothing. Refuses, before
    any work, to replace any of them unless ``overwrite``. The three are written into a
    hidden staging folder beside them and then moved into place, the CSV last, under a lock
    on the labels' name: an interrupt leaves the earlier three (or none) and two runs on one
    ``path`` never mix (the labels are the benchmarks' truth).
    """
    check_outputs(path, overwrite)
    trace, labels = generate(spec, min_driven_s)
    if model_source is not None:
        labels["model_source"] = model_source
    if model_name is not None:
        trace = replace(trace, conditions={**trace.conditions, "model": model_name})
    targets = output_paths(path)
    # Locked by the labels' name, which two CSV names can share (w.csv and w.CSV: w.labels.json).
    with locked_folder(path.parent, f"--out {str(path)!r} in", lock_name=f".{targets[2].name}.lock"):
        check_outputs(path, overwrite)  # again, now that no other run can write them
        for leftover in path.parent.glob(f".{targets[2].name}.staging-*"):
            shutil.rmtree(leftover, ignore_errors=True)  # a killed run's (we hold the lock)
        staging = path.parent / f".{targets[2].name}.staging-{os.getpid()}"
        staging.mkdir()
        try:
            staged = output_paths(staging / path.name)
            write_json(staged[2], labels)
            write_trace(staged[0], trace, overwrite=True)
            with signals_deferred():
                if not staged[1].exists():
                    targets[1].unlink(missing_ok=True)  # an earlier sidecar would be read back with the new data
                for source, target in zip((staged[1], staged[2], staged[0]), (targets[1], targets[2], targets[0])):
                    if source.exists():
                        os.replace(source, target)
        finally:
            shutil.rmtree(staging, ignore_errors=True)
    return targets[0], targets[2]


def parse_effect(text: str | None) -> tuple[str | None, dict[str, float] | None]:
    """``name`` or ``name:param=value,param=value`` (values in the parameter's unit)."""
    if not text or text == "none":
        return None, None
    name, _, rest = text.partition(":")
    if name == "none":
        raise ValueError(f"--effect {text!r}: 'none' hides no effect and takes no parameters; expected 'none' alone")
    if name not in EFFECTS:
        raise ValueError(f"--effect {name!r}: expected none or one of {', '.join(EFFECTS)}")
    values: dict[str, float] = {}
    for item in filter(None, rest.split(",")):
        key, _, value = item.partition("=")
        EFFECTS[name].parameter(key)
        if key in values:
            raise ValueError(f"--effect {text!r}: {key} is given twice; expected each parameter once")
        try:
            values[key] = float(value)
        except ValueError:
            raise ValueError(f"--effect {text!r}: {value!r} is not a number for {key}") from None
    return name, values or None


def check_spec(spec: SynthSpec) -> None:
    """Every number of ``spec`` within its range (``ValueError`` naming the option), before any work.

    A trace ``diagnose`` would reject, or one that costs gigabytes, is never generated.
    """
    from sma_gym.diagnosis.workflow import MAX_DURATION_S

    require_range("--duration", spec.duration_s, MIN_DURATION_S, MAX_DURATION_S, "s", lower_open=True)
    period = require_range("--sample-period", spec.sample_period_s, CONTROL_PERIOD_S, MAX_SAMPLE_PERIOD_S, "s")
    steps = period / CONTROL_PERIOD_S
    if abs(steps - round(steps)) > 1e-6 * steps:
        raise ValueError(
            f"--sample-period = {spec.sample_period_s!r}: expected a whole multiple of the {CONTROL_PERIOD_S:g} s "
            "control period the trace is simulated at (e.g. 0.001, 0.002, 0.01)"
        )
    samples = int(spec.duration_s / period)
    if samples < max(MIN_SAMPLES, DIAGNOSIS_MIN_ROWS):
        raise ValueError(
            f"--sample-period = {spec.sample_period_s!r} with --duration = {spec.duration_s!r}: {samples} samples, "
            f"expected at least {max(MIN_SAMPLES, DIAGNOSIS_MIN_ROWS)} (shorter period or longer duration)"
        )
    p = spec.model.actuator
    stroke = p.usable_stroke_m
    require_range("--position-noise", spec.position_noise_m, 0.0, MAX_NOISE_FRACTION * stroke, "m, 5 % of the stroke")
    require_range(
        "--position-resolution", spec.position_resolution_m, 0.0, MAX_NOISE_FRACTION * stroke, "m, 5 % of the stroke"
    )
    require_range(
        "--resistance-noise",
        spec.resistance_noise_ohm,
        0.0,
        MAX_NOISE_FRACTION * p.wire.cold_resistance_ohm,
        "ohm, 5 % of the cold resistance",
    )
    require_range("--perturb", spec.perturb, 0.0, 0.5, "relative; beyond 50 % the nominal model means nothing")
    require_int_range("--seed", spec.seed, 0, 2**63 - 1)
    if spec.actuator_seed is not None:
        require_int_range("--actuator-seed", spec.actuator_seed, 0, 2**63 - 1)


def main(args) -> int:
    if not args.out.strip():  # Path('') is '.', which the message then named
        raise ValueError(f"--out {args.out!r}: empty, expected a .csv file name")
    name, values = parse_effect(args.effect)
    if name is not None and args.form not in EFFECTS[name].forms:
        raise ValueError(f"--form {args.form!r}: effect {name!r} has forms {EFFECTS[name].forms}")
    if name is None and args.form != "default":
        raise ValueError(f"--form {args.form!r}: a form belongs to an effect; expected --effect NAME with it")
    model = load_model(args.model)
    spec = SynthSpec(
        model=model,
        effect=name,
        effect_values=values,
        form=args.form,
        excitation=args.excitation,
        duration_s=args.duration,
        position_noise_m=args.position_noise,
        resistance_noise_ohm=args.resistance_noise,
        position_resolution_m=args.position_resolution,
        electrical=not args.no_electrical,
        perturb=args.perturb,
        sample_period_s=args.sample_period,
        seed=args.seed,
        actuator_seed=args.actuator_seed,
    )
    check_spec(spec)
    # A file's model is the nominal model a lab would name; a model JSON file has no name
    # diagnose could look up, so only presets and twins are named.
    named = args.model if args.model in model_names() else None
    csv_path, labels_path = write(
        spec,
        Path(args.out),
        overwrite=args.overwrite,
        model_name=named,
        min_driven_s=MIN_DRIVEN_S,
        model_source=str(args.model),
    )
    print(f"wrote {csv_path} (+ sidecar) and labels {labels_path}")
    hidden = spec.truth().effects.get("convection_change") if name == "convection_change" else None
    if hidden is not None and hidden.form == "default" and hidden.values["h1_w_m2_k2"] == 0.0:
        # Its labels name the effect, and diagnose answered "none" with the scale right in
        # its refit (a new user's trial): the two cannot be told apart by construction.
        print(
            f"sma-gym synth: note: convection_change with scale = {hidden.values['scale']:g} alone is a pure scale "
            "of the convection, which every diagnosis refits as the nominal model's own convection_scale: it is "
            "found in that refit (verdict 'none'), never as this effect; give h1_w_m2_k2 or --form power for a "
            "changed convection law",
            file=sys.stderr,
        )
    if named is None:
        print(
            f"sma-gym synth: note: the sidecar names no model ({args.model!r} is a file, not a preset or twin name): "
            # Quoted as a shell needs them (a path with a space broke the command copied).
            f"sma-gym diagnose {shlex.quote(str(csv_path))} --model {shlex.quote(str(args.model))}, or it starts "
            "from the standard wire",
            file=sys.stderr,
        )
    return 0

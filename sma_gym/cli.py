"""The ``sma-gym`` command: ``sma-gym <subcommand> --help`` for each.

Every subcommand checks all its arguments (an ``--out`` that cannot be written included)
before it does any work, and exits 2 with a message naming the argument; an output folder
is locked while a command writes to it (:func:`sma_gym._io.locked_folder`).

``bench``, ``diagnose`` and ``synth`` are defined here. Other packages add subcommands
through the ``sma_gym.commands`` entry-point group (as pytest finds its plugins), each
entry a :class:`Command`; this package's ``agents`` declares ``fidelity`` and ``evaluate``
that way in ``pyproject.toml``, because they run the report's controllers, which
``sma_gym`` does not import (the dependency goes one way: ``agents`` uses ``sma_gym``).
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import re
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any

from sma_gym._io import expand_home, interrupt_behind, sigterm_as_interrupt, stopped
from sma_gym.extras import MissingExtraError, extra_error, install_hint, missing, require

DEFAULT_DIAGNOSIS_MODEL = "standard"
"""The nominal model ``sma-gym diagnose`` starts from when ``--model`` is not given."""

COMMANDS_GROUP = "sma_gym.commands"
"""Entry-point group of the subcommands other packages add (each names a :class:`Command`)."""


@dataclass(frozen=True)
class Command:
    """One subcommand of ``sma-gym``.

    ``add_arguments`` declares its options on its parser; ``run`` does the work and returns
    the exit code, raising ``ValueError`` for a bad argument (printed, exit code 2).
    ``needs`` are the top-level modules it imports beyond the lean install, and ``extra``
    the extra that installs them (:mod:`sma_gym.extras`): a missing one is reported before
    ``run`` starts.
    """

    name: str
    help: str
    add_arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace], int]
    description: str | None = None
    needs: tuple[str, ...] = ()
    extra: str | None = None
    available: bool = True


def _bench(args: argparse.Namespace) -> int:
    from sma_gym import bench

    return bench.main(as_json=args.json, repeats=args.repeats)


def _diagnose(args: argparse.Namespace) -> int:
    from sma_gym._io import check_output_folder, locked_folder
    from sma_gym.data import MeasuredDataError, load_traces
    from sma_gym.data.measured import DIAGNOSIS_MIN_ROWS
    from sma_gym.diagnosis.report import write_outputs
    from sma_gym.diagnosis.workflow import data_notes, diagnose, require_diagnosable, require_max_rounds
    from sma_gym.effects import EFFECTS
    from sma_gym.model import load_model

    if not args.files:
        took = f": --heldout took every name after it ({' '.join(args.heldout)})" if len(args.heldout or ()) > 1 else ""
        raise ValueError(
            f"no files to fit{took}; expected the measured files first, e.g. sma-gym diagnose fit1.csv fit2.csv "
            "--heldout held.csv --out DIR"
        )
    require_max_rounds("--max-rounds", args.max_rounds)
    if args.threads is not None:
        from sma_gym.diagnosis.fitting import require_threads

        require_threads("--threads", args.threads)
    if args.cross_validate and (args.heldout or len(args.files) < 2):
        raise ValueError("--cross-validate: expected at least 2 files and no --heldout (each file is held out in turn)")
    out = check_output_folder(args.out)
    _require_distinct_inputs(args.files, args.heldout or [])
    try:
        fit = load_traces(args.files, DIAGNOSIS_MIN_ROWS)
        held = load_traces(args.heldout or [], DIAGNOSIS_MIN_ROWS)
    except MeasuredDataError as err:
        print(f"sma-gym diagnose: invalid measured data:\n{err}", file=sys.stderr)
        return 2
    require_diagnosable(fit, held)
    for note in data_notes(fit, held):
        print(f"sma-gym diagnose: note: {note}", file=sys.stderr)
    named = _sidecar_model([*fit, *held], given=args.model)
    if args.model is not None and named is not None and args.model != named:
        print(f"sma-gym diagnose: note: --model {args.model!r} is used; the sidecars name {named!r}", file=sys.stderr)
    nominal = load_model(args.model or named or DEFAULT_DIAGNOSIS_MODEL)
    if args.model is None and named is None:
        # Said before the work, not only after an unexplained verdict: on another actuator
        # the default names wrong effects with confidence as well (a new user's trial).
        print(
            f"sma-gym diagnose: note: no --model, and no sidecar names one: the nominal model is the default "
            f"{DEFAULT_DIAGNOSIS_MODEL!r} (the report's 0.3 mm wire at 10 V); if your actuator differs, give --model "
            "(a preset such as bench-0.5mm-ht-datasheet, or a model JSON file)",
            file=sys.stderr,
        )
    _note_assumed_conditions([*fit, *held], nominal)
    _note_replaced_conditions([*fit, *held], nominal)
    outputs = CROSS_VALIDATION_OUTPUTS if args.cross_validate else None
    _require_out_free(args, out, fit, held, outputs)
    effects = None if args.effects is None else [e.strip() for e in args.effects.split(",")]
    for name in effects or []:
        if name not in EFFECTS:
            raise ValueError(f"--effects {name!r}: expected a comma-separated subset of {', '.join(EFFECTS)}")
    if effects is not None and len(set(effects)) != len(effects):
        twice = sorted({e for e in effects if effects.count(e) > 1})
        raise ValueError(f"--effects {args.effects!r}: {', '.join(twice)} given twice; expected each effect once")

    def progress(message: str) -> None:
        print(f"sma-gym diagnose: {message}", file=sys.stderr, flush=True)

    if args.cross_validate:
        return _cross_validate(args, fit, nominal, effects, out, progress)
    with locked_folder(out):
        result = diagnose(
            fit, held, nominal, effects, progress=progress, max_rounds=args.max_rounds, threads=args.threads
        )
        paths = write_outputs(result, out, fit, held, nominal)
    _print_diagnosis(result, paths, args.json)
    if args.model is None and named is None and result.verdict in ("unexplained", "partial"):
        # The commonest cause on real data: the wrong actuator, not a missing effect.
        print(
            f"sma-gym diagnose: note: the nominal model was the default {DEFAULT_DIAGNOSIS_MODEL!r} (the report's "
            "0.3 mm wire at 10 V); if your actuator differs, give --model (a preset such as "
            "bench-0.5mm-ht-datasheet, or a model JSON file)",
            file=sys.stderr,
        )
    return 0


CROSS_VALIDATION_OUTPUTS = ("cross_validation.json", "cross_validation.md")
"""What ``sma-gym diagnose --cross-validate`` writes into ``--out``."""


def _note_assumed_conditions(traces: Sequence[Any], nominal: Any) -> None:
    """Say which conditions the files' sidecars leave to the model (a 24 V bench diagnosed
    at the model's 10 V, with no word of it, was found by a new user): one line per set of
    files that assume the same values."""
    from sma_gym.diagnosis.fitting import assumed_conditions

    groups: dict[tuple[tuple[str, float], ...], list[str]] = {}
    for trace in traces:
        assumed = tuple(assumed_conditions(nominal, trace).items())
        if assumed:
            groups.setdefault(assumed, []).append(Path(trace.path).name)
    for assumed, names in groups.items():
        values = ", ".join(f"{key} = {value:g}" for key, value in assumed)
        print(
            f"sma-gym diagnose: note: {', '.join(names)}: taken from the model {nominal.name!r}, as no sidecar "
            f"(<file>.json, docs/diagnosis.md#measured-data) gives them: {values}",
            file=sys.stderr,
        )


def _note_replaced_conditions(traces: Sequence[Any], nominal: Any) -> None:
    """Say where the files' sidecars give other conditions than the model has (its supply,
    say): the fits run under the files' (a user with a model of 8 V and files at 12 V was
    told only in the finished report; a new user's trial). One line per set of files."""
    from sma_gym.diagnosis.fitting import SIDECAR_KEYS, condition_value

    groups: dict[tuple[tuple[str, float, float], ...], list[str]] = {}
    for trace in traces:
        replaced = tuple(
            (key, float(trace.conditions[key]), condition_value(nominal, key))
            for key in SIDECAR_KEYS
            if key in trace.conditions and not math.isclose(float(trace.conditions[key]), condition_value(nominal, key))
        )
        if replaced:
            groups.setdefault(replaced, []).append(Path(trace.path).name)
    for replaced, names in groups.items():
        values = ", ".join(f"{key} = {mine:g} (the model: {theirs:g})" for key, mine, theirs in replaced)
        print(
            f"sma-gym diagnose: note: {', '.join(names)}: the sidecar's conditions are used instead of the "
            f"model's ({nominal.name!r}): {values}",
            file=sys.stderr,
        )


def _sidecar_model(traces: Sequence[Any], given: str | None = None) -> str | None:
    """The nominal model the files' sidecars name (``"model"``): a preset or twin name
    (:func:`sma_gym.model.model_names`). Files that name different models, or a name that
    is not a model, are refused unless ``--model`` (``given``) is, which is used instead."""
    from sma_gym.model import model_names

    named = {str(t.path): t.conditions["model"] for t in traces if "model" in t.conditions}
    if not named:
        return None
    for path, name in named.items():
        if name not in model_names():
            if given is not None:
                return name  # --model decides; the caller notes the sidecar's name beside it
            raise ValueError(
                f"{path}: sidecar 'model' = {name!r}: expected a model name ({', '.join(model_names())}); give "
                "a model file with --model (a free-text description of the actuator goes into 'notes')"
            )
    if len(set(named.values())) > 1:
        if given is not None:
            return next(iter(named.values()))  # --model decides (the caller notes what the sidecars name)
        shown = "; ".join(f"{path}: {name!r}" for path, name in named.items())
        raise ValueError(f"the sidecars name different models ({shown}): expected one, or give --model")
    return next(iter(named.values()))


def _require_distinct_inputs(files: Sequence[str], heldout: Sequence[str]) -> None:
    """A file given twice (or as fitted and held-out data) would count its evidence twice,
    and held-out data that was also fitted is not held out: the same path, another path to
    the same file (a link) or a copy with the same bytes."""
    from sma_gym._io import sha256_file
    from sma_gym.data.measured import MAX_CSV_BYTES

    how = {"path": "already given", "inode": "the same file", "sha256": "the same data"}
    seen: dict[tuple[str, object], str] = {}
    for what, names in (("fit file", files), ("--heldout", heldout)):
        for name in names:
            path = Path(name)
            keys: list[tuple[str, object]] = [("path", path.resolve())]
            if path.is_file():
                st = path.stat()
                keys.append(("inode", (st.st_dev, st.st_ino)))
                if st.st_size <= MAX_CSV_BYTES:  # a bigger one is refused by the loader, not read whole here
                    with contextlib.suppress(OSError):  # unreadable: loading it names the problem
                        keys.append(("sha256", sha256_file(path)))
            for key in keys:
                if key in seen:
                    raise ValueError(
                        f"{what} {name!r}: {how[key[0]]} as {seen[key]}; each measured file may appear once "
                        "(held-out data must not be fitted)"
                    )
            for key in keys:
                seen[key] = f"{what} {name!r}"


def _require_out_free(args: argparse.Namespace, out: Path, fit: Any, held: Any, outputs: Sequence[str] | None) -> None:
    """Refuse an ``--out`` whose outputs would replace an input, or an earlier report without
    ``--overwrite`` (the user's files are never changed unasked)."""
    from sma_gym.data.measured import sidecar_candidates, sidecar_path
    from sma_gym.diagnosis.report import output_paths, previous_outputs

    if outputs is None:
        written = output_paths(out, fit, held)
        earlier = previous_outputs(out)
    else:
        written = [out / name for name in outputs]
        earlier = _previous_cross_validation(out)
    inputs = [Path(f) for f in (*args.files, *(args.heldout or []))]
    inputs += [side for side in (sidecar_path(p) for p in inputs) if side is not None]
    if args.model is not None and Path(args.model).is_file():
        inputs.append(Path(args.model))
    clash = {p.resolve() for p in written} & {p.resolve() for p in inputs}
    if clash:
        raise ValueError(
            f"--out {str(out)!r}: this run would write over its own input {', '.join(sorted(map(str, clash)))}; "
            "copy the input elsewhere or choose another --out"
        )
    # A file this run writes where a data file's sidecar is looked for would be read as that
    # file's conditions from then on (X/diagnosis.csv diagnosed into X: diagnosis.json).
    will_write = {p.resolve() for p in written}
    for data in (Path(f) for f in (*args.files, *(args.heldout or []))):
        for side in sidecar_candidates(data):
            if side.exists():
                break  # the sidecar it has (the first found is read)
            if side.resolve() in will_write:
                raise ValueError(
                    f"--out {str(out)!r}: this run would write {str(side)!r}, which would then be read as the "
                    f"sidecar of its input {str(data)!r}; choose another --out or rename the input"
                )
    # Never over a file of the user's that only shares a name with an output.
    earlier_set = {p.resolve() for p in earlier}
    theirs = sorted(str(p) for p in written if p.is_file() and p.resolve() not in earlier_set)
    if theirs:
        raise ValueError(
            f"--out {str(out)!r}: holds {', '.join(theirs)}, not written by an earlier diagnosis, where this run "
            "would write; choose another --out or move them"
        )
    if earlier and not args.overwrite:
        shown = ", ".join(p.name for p in earlier[:4]) + (", ..." if len(earlier) > 4 else "")
        raise ValueError(
            f"--out {str(out)!r}: holds an earlier diagnosis ({shown}); choose a new folder or pass --overwrite "
            "to replace it"
        )


def _previous_cross_validation(out: Path) -> list[Path]:
    """The files an earlier ``--cross-validate`` wrote into ``out``: only if its
    ``cross_validation.json`` is one (a user's file of that name was replaced by
    ``--overwrite``)."""
    import json

    try:
        data = json.loads((out / CROSS_VALIDATION_OUTPUTS[0]).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return []
    if not isinstance(data, dict) or not isinstance(data.get("folds"), list):
        return []
    return [out / name for name in CROSS_VALIDATION_OUTPUTS if (out / name).is_file()]


def _cross_validate(
    args: argparse.Namespace,
    fit: Any,
    nominal: Any,
    effects: list[str] | None,
    out: Path,
    progress: Callable[[str], None],
) -> int:
    """``sma-gym diagnose --cross-validate``: leave one run out, table and JSON into ``out``."""
    import json

    from sma_gym._io import locked_folder, staged_outputs, write_json, write_text
    from sma_gym.diagnosis.report import cross_validation_table
    from sma_gym.diagnosis.workflow import cross_validate
    from sma_gym.provenance import provenance

    with locked_folder(out):
        cv = cross_validate(fit, nominal, effects, progress=progress, max_rounds=args.max_rounds, threads=args.threads)
        table = cross_validation_table(cv)
        # Staged: an interrupt between the two files left a new JSON beside an old table.
        with staged_outputs(out, "diagnose-cross-validate") as staging:
            write_json(staging / CROSS_VALIDATION_OUTPUTS[0], {**cv, "provenance": provenance()})
            write_text(staging / CROSS_VALIDATION_OUTPUTS[1], "# Leave one run out\n\n" + table)
    if args.json:  # the object the file holds, provenance included, on one line
        print(json.dumps(json.loads((out / CROSS_VALIDATION_OUTPUTS[0]).read_text(encoding="utf-8"))))
    else:
        print(table, end="")
    return 0


def _print_diagnosis(result: Any, paths: dict[str, Path], as_json: bool) -> None:
    """The verdict and the gaps before -> after (or the whole result as JSON)."""
    import json

    if as_json:
        # diagnosis.json's object on one line: the result with its provenance and the files
        # written (the result alone left out which code produced it and where it went).
        print(json.dumps(json.loads(paths["json"].read_text(encoding="utf-8"))))
        return
    joiner = " + " if result.verdict in ("effects", "partial") else " or "
    effect = result.effect if isinstance(result.effect, str) or result.effect is None else joiner.join(result.effect)
    print(f"verdict: {result.verdict}" + (f" ({effect})" if effect else ""))
    if result.verdict == "partial":
        from sma_gym.diagnosis.workflow import explained_text

        print(
            f"  partly explained: the corrected model carries {effect}, which closes "
            f"{explained_text(result.explained)}; not named as found (see the report)"
        )
    from sma_gym.diagnosis.report import format_value

    whole = result.whole_file_refit
    for data in ("fit", "heldout"):
        for output, before in result.gap_before[data].items():
            # Refitted on the whole files, the held-out part was fitted: show the model as chosen there.
            after = (whole["gap_selected"] if whole else result.gap_after)[data].get(output, float("nan"))
            line = f"  {data:8s} {output:10s} RMS {format_value(before, output)} -> {format_value(after, output)}"
            if whole:
                refitted = result.gap_after[data].get(output, float("nan"))
                line += f" (as chosen; refitted on the whole files: {format_value(refitted, output)})"
            print(line)
    if whole:
        from sma_gym.diagnosis.workflow import HOLDOUT_FRACTION

        print(
            f"  note: the model was chosen on the first {100 - round(HOLDOUT_FRACTION * 100)} % of each file (the rest "
            "held out) and then refitted on the whole files, which the corrected model carries; the held-out "
            "figure in brackets was fitted"
        )
    if result.kept_as_given:
        print(
            "  note: the nominal refit predicted the held-out data worse than the model as given, so the "
            "corrected model is the model as given (do the fitted data move the actuator through its range?)"
        )
    print(f"report: {paths['report']}\ncorrected model: {paths['model']}")


def _synth(args: argparse.Namespace) -> int:
    from sma_gym.diagnosis import synth

    return synth.main(args)


def _bench_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--json", action="store_true", help='print {"averaged": {"1": rate, "4096": rate}, "resolved": {...}}'
    )
    p.add_argument("--repeats", type=int, default=3, help="best of this many timings (default 3)")


def _diagnose_arguments(p: argparse.ArgumentParser) -> None:
    # "*", checked in _diagnose: with "+" a --heldout given first took every name, and
    # argparse said only that files were required (a new user's trial).
    p.add_argument("files", nargs="*", help="measured traces to fit (CSV, see docs/diagnosis.md: measured data)")
    p.add_argument(
        "--heldout",
        nargs="+",
        help="measured traces never used for fitting (after the files: it takes every name that follows)",
    )
    p.add_argument("--out", required=True, help="folder for the report, plots, JSON and corrected_model.json")
    p.add_argument(
        "--model",
        default=None,
        help="nominal model: a preset or twin name or a model JSON file (default: the model the files' sidecars "
        f"name, else {DEFAULT_DIAGNOSIS_MODEL})",
    )
    p.add_argument("--effects", help="comma-separated subset of effects to consider (default: all)")
    p.add_argument(
        "--max-rounds",
        type=int,
        default=3,
        help=(
            "at most this many rounds, each adding one effect (two when a pair is named) on top of everything "
            "found so far, re-fitted (default 3; 1 = one round)"
        ),
    )
    p.add_argument(
        "--threads",
        type=int,
        default=None,
        help="threads for the batched simulations (default: the cores this process may use, at most 8); "
        "the result does not depend on it",
    )
    p.add_argument(
        "--cross-validate",
        action="store_true",
        help="leave one run out: diagnose on all files but one and predict that one, for every file; "
        "writes cross_validation.md/.json",
    )
    p.add_argument(
        "--json",
        action="store_true",
        help="print diagnosis.json's (or cross_validation.json's) object on one line instead of the summary",
    )
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="replace an earlier diagnosis in --out (its report, plots and corrected model)",
    )


def _synth_arguments(p: argparse.ArgumentParser) -> None:
    from sma_gym.diagnosis.synth import EXCITATIONS

    p.add_argument("--out", required=True, help="CSV file to write (with <out>.json sidecar and <stem>.labels.json)")
    p.add_argument("--effect", default="none", help="none, or NAME or NAME:param=value,... (default none)")
    p.add_argument("--form", default="default", help="form of the effect (default, or an alternative such as uniform)")
    p.add_argument(
        "--excitation",
        default="steps",
        choices=EXCITATIONS,
        help="the reference the recording controller follows (default steps)",
    )
    p.add_argument("--duration", type=float, default=60.0, help="seconds (default 60)")
    p.add_argument(
        "--model",
        default="standard",
        help="nominal model: preset name or model JSON file (a name goes into the sidecar: diagnose starts from it)",
    )
    p.add_argument(
        "--perturb", type=float, default=0.05, help="relative perturbation of the nominal parameters (default 0.05)"
    )
    p.add_argument("--position-noise", type=float, default=5e-6, help="m (default 5e-6)")
    p.add_argument("--position-resolution", type=float, default=1e-6, help="m (default 1e-6)")
    p.add_argument("--resistance-noise", type=float, default=2e-3, help="ohm (default 2e-3)")
    p.add_argument(
        "--sample-period",
        type=float,
        default=1e-3,
        help="s between rows, and between the recording controller's commands (default 1e-3: 1 kHz)",
    )
    p.add_argument("--no-electrical", action="store_true", help="record position only (no R, I, V)")
    p.add_argument(
        "--seed",
        type=int,
        default=0,
        help="seed of the run: excitation, noise and, unless --actuator-seed, the perturbation (default 0)",
    )
    p.add_argument(
        "--actuator-seed",
        type=int,
        default=None,
        help="seed of the nominal perturbation alone: the same value gives the same actuator under any --seed "
        "(default: drawn from --seed; --actuator-seed K is the actuator of --seed K)",
    )
    p.add_argument("--overwrite", action="store_true", help="replace an existing file")


def _warmup(args: argparse.Namespace) -> int:
    from sma_gym.warmup import warm_up

    done = warm_up()
    where = f"cached in {done.cache_dir}" if done.cached else "not cached (no writable cache directory)"
    # "compiled or loaded": with a cache from an earlier process nothing is compiled.
    print(f"compiled or loaded {len(done.paths)} paths in {done.seconds:.1f} s, {where}")
    return 0


BUILTIN_COMMANDS = (
    Command("bench", "simulator speed in actuator-steps/s (1 kHz control step)", _bench_arguments, _bench),
    Command(
        "warmup",
        "compile (and cache, where possible) every compiled path now instead of at the first step",
        lambda p: None,
        _warmup,
    ),
    Command(
        "diagnose",
        "find the effect the model is missing from measured traces, add it, show the gap shrink",
        _diagnose_arguments,
        _diagnose,
        description="sma-gym diagnose FIT.csv [FIT2.csv ...] [--heldout HELD.csv ...] --out DIR",
        needs=("scipy", "matplotlib"),
        extra="diagnose",
    ),
    Command(
        "synth",
        "write a synthetic measured trace with a hidden effect (labels in a separate file)",
        _synth_arguments,
        _synth,
    ),
)


def _unavailable(name: str, source: str, error: Exception) -> Command:
    """A command whose entry point does not load: listed, and its use (with any arguments)
    names the reason, and the extra to install when a module is missing."""
    if isinstance(error, ModuleNotFoundError) and not isinstance(error, MissingExtraError):
        error = extra_error(error, f"sma-gym {name}")
    reason = error.hint if isinstance(error, MissingExtraError) else f"{source} does not load"

    def run(args: argparse.Namespace) -> int:
        if isinstance(error, MissingExtraError):
            raise error
        raise ValueError(f"this command ({source}) could not be loaded: {type(error).__name__}: {error}")

    return Command(name, f"(unavailable: {reason})", lambda p: None, run, available=False)


def plugin_commands() -> list[Command]:
    """The commands declared in the :data:`COMMANDS_GROUP` entry-point group."""
    found = []
    for entry in entry_points(group=COMMANDS_GROUP):
        try:
            command = entry.load()
        except Exception as err:
            found.append(_unavailable(entry.name, entry.value, err))
            continue
        if not isinstance(command, Command) or command.name != entry.name:
            raise TypeError(
                f"entry point {entry.name} = {entry.value!r} in {COMMANDS_GROUP}: expected a sma_gym.cli.Command named {entry.name!r}"
            )
        found.append(command)
    return found


def all_commands() -> list[Command]:
    """Built-in and plugin commands, by name (a name defined twice is an error)."""
    commands: dict[str, Command] = {}
    for command in [*BUILTIN_COMMANDS, *plugin_commands()]:
        if command.name in commands:
            raise TypeError(f"sma-gym command {command.name!r} is defined twice ({COMMANDS_GROUP} entry points)")
        commands[command.name] = command
    return [commands[name] for name in sorted(commands)]


def build_parser(commands: Sequence[Command] | None = None) -> argparse.ArgumentParser:
    """The ``sma-gym`` parser with ``commands`` (default: :func:`all_commands`)."""
    from sma_gym import __version__

    parser = argparse.ArgumentParser(prog="sma-gym", description="SMA actuator simulator, environments and tools.")
    parser.add_argument("--version", action="version", version=f"sma-gym {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    for command in all_commands() if commands is None else commands:
        # Each command's --help says what it does (bench, warmup and evaluate showed no line).
        help_text, description = command.help, command.description or command.help
        absent = missing(*command.needs)
        if absent and command.available:
            # Listed with what to install, so --help tells the truth for any set of extras.
            help_text = f"(needs {', '.join(absent)}: {install_hint(absent, command.extra)}) {command.help}"
        if not command.available:
            description = command.help
        p = sub.add_parser(command.name, help=help_text, description=description)
        # argparse takes "-1e-6" for an option ("expected one argument"), its pattern of a
        # negative number having no exponent: the value is then checked and named as any other.
        p._negative_number_matcher = NEGATIVE_NUMBER
        command.add_arguments(p)
        p.set_defaults(func=command.run)
    return parser


NEGATIVE_NUMBER = re.compile(r"^-(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?$|^-(?:inf|nan)$", re.IGNORECASE)
"""What an argument that reads as a negative number looks like (``-5``, ``-.5``, ``-1e-6``)."""


def _subparser(parser: argparse.ArgumentParser, name: str) -> argparse.ArgumentParser:
    """The parser of the command ``name``."""
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return action.choices[name]


def main(argv: Sequence[str] | None = None) -> int:
    commands = all_commands()
    parser = build_parser(commands)
    # An unavailable command takes any arguments: its message (which extra to install) is
    # more use than "unrecognized arguments".
    args, unknown = parser.parse_known_args(argv)
    command = next(c for c in commands if c.name == args.command)
    expand_home(args)
    if unknown and command.available:
        # The command's own usage, not the list of commands.
        _subparser(parser, command.name).error(f"unrecognized arguments: {' '.join(unknown)}")
    try:
        with sigterm_as_interrupt():
            require(*command.needs, purpose=f"sma-gym {command.name}", extra=command.extra)
            return int(args.func(args) or 0)
    except MissingExtraError as err:
        # The message starts with what needs the extra, which is this command's own prefix.
        print(f"sma-gym {args.command}: error: {str(err).removeprefix(f'sma-gym {args.command}: ')}", file=sys.stderr)
        return 2
    except (ValueError, OSError) as err:
        if (interrupt := interrupt_behind(err)) is not None:
            how, code = stopped(interrupt)
            print(f"sma-gym {args.command}: {how}", file=sys.stderr)
            return code
        if isinstance(err, BrokenPipeError):
            # The reader of stdout went away (``| head``): nothing is left to tell it, and a
            # traceback would be noise. Outputs already written stay (they are written whole).
            with contextlib.suppress(OSError, ValueError):
                os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no second error at exit
            return 128 + 13  # the shell's code for SIGPIPE
        if isinstance(err, OSError):
            # A full disk, a folder made read-only meanwhile: one line naming the file, not a
            # traceback (what was written is whole or removed: the outputs are staged).
            where = f"{err.filename}: " if err.filename else ""
            print(f"sma-gym {args.command}: error: {where}{err.strerror or err}", file=sys.stderr)
            return 1
        print(f"sma-gym {args.command}: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as err:
        # Ctrl-C (or SIGTERM) is the user's choice, not a bug: no traceback; the shell's code
        # for the signal.
        how, code = stopped(err)
        print(f"sma-gym {args.command}: {how}", file=sys.stderr)
        return code


if __name__ == "__main__":
    # ``python -m sma_gym.cli``: run the importable module, whose Command the plugins build
    # (this file, run as __main__, defines a second, different Command class).
    from sma_gym.cli import main as _main

    sys.exit(_main())

"""Measured traces: the file format, loading and validation.

Format
------
A CSV file with a header row, SI units, one row per sample:

============== ======== ===========================================================
column         unit     meaning
============== ======== ===========================================================
t              s        time, strictly increasing (required)
duty           0..1     commanded PWM duty cycle (required)
position       m        measured contraction, positive = wire contracted (required)
resistance     ohm      V/I reading during the on-time (optional; > 0)
current        A        current during the on-time (optional)
wire_voltage   V        voltage across the wire during the on-time (optional)
force          N        bias-spring force (optional)
============== ======== ===========================================================

The electrical readings are the model's: taken during a PWM pulse, so a cell is left empty
where none could be (the duty is 0, or the pulse was too short to settle). A logger that
writes 0 where the wire was not driven is read as empty there (a 0 in a row whose duty is
0); any other reading in such a row is refused, as the model has none to compare it with.
The supply's voltage is a condition, not a column: it goes into the sidecar. A column named
``supply_voltage`` is refused with both meanings spelt out (files that ``sma-gym synth``
wrote before 2026-12-07 name the wire's voltage so: rename it ``wire_voltage``).

Conditions that are constant over the file go into an optional JSON sidecar next to it,
named ``<file>.json`` (e.g. ``step01.csv.json``; ``step01.json`` is accepted too)::

    {"supply_voltage_v": 24.0, "wire_diameter_m": 0.0005, "pwm_frequency_hz": 1000,
     "ambient_temperature_c": 20.0, "model": "bench-0.5mm-ht", "notes": "..."}

``model`` names the nominal model the data are diagnosed against (a preset or twin name, as
``sma-gym diagnose --model``; the option wins when both are given).

Loading checks everything and reports *every* problem with file, row and column (missing
columns, non-monotonic time, NaN where not allowed, duty outside [0, 1], unit slips such
as a position in millimetres or time in milliseconds). Files are only read, never written.
A double quote left open (it would swallow the lines after it) is named with its row, and a
cell such as ``1_0e-6`` (Python's float reads 1e-5) is no number.
A UTF-8 byte-order mark (Excel's "CSV UTF-8") and blank lines at the end are accepted; a
file needs at least two samples (``sma-gym diagnose`` loads with ``min_rows=DIAGNOSIS_MIN_ROWS``:
it fits more than ten and holds out 30 %) and at most ``MAX_CSV_BYTES`` (the read stops there).
"""

from __future__ import annotations

import csv
import io
import math
import os
import re
from array import array
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sma_gym._io import read_json_object, read_text, write_json, write_text
from sma_gym._validation import require_range
from sma_gym.params import parameter_bound

REQUIRED = ("t", "duty", "position")
OPTIONAL = ("resistance", "current", "wire_voltage", "force")
ELECTRICAL = ("resistance", "current", "wire_voltage")
"""The on-time readings: empty (or 0) where the duty is 0 (the model has none there)."""
KNOWN_COLUMNS = REQUIRED + OPTIONAL
SIDECAR_KEYS = {
    "supply_voltage_v": "driver.supply_voltage_v",
    "wire_diameter_m": "wire.diameter_m",
    "pwm_frequency_hz": "driver.pwm_frequency_hz",
    "ambient_temperature_c": "convection.ambient_temperature_c",
}
"""Each numeric sidecar condition and the actuator parameter it sets; its range is that
parameter's (:func:`sma_gym.params.parameter_bound`), so a sidecar the loader accepts is one
the model accepts (the loader's own ranges let a 4 mm wire through, refused later unnamed)."""
SIDECAR_TEXT_KEYS = ("model", "notes", "source")

MAX_PROBLEMS_SHOWN = 20
"""Problems of one kind named one by one per file; further ones are counted in one line."""

#: Plausibility bounds that catch unit slips (a Flexinol actuator's stroke is centimetres).
MAX_ABS_POSITION_M = 0.1
MAX_RESISTANCE_OHM = 1000.0
MAX_CURRENT_A = 50.0
MAX_FORCE_N = 1000.0
MAX_WIRE_VOLTAGE_V = 100.0

DIAGNOSIS_MIN_ROWS = 20
"""Fewest samples a file given to the diagnosis may have: it fits more than ten samples of
each output after holding out the last 30 % of a file, so fewer cannot be diagnosed."""
MAX_CSV_BYTES = 512 * 1024 * 1024
"""Largest file read (about 5 million rows); bigger is refused rather than read."""


class MeasuredDataError(ValueError):
    """Raised with every problem found, one per line ("file:row:column: message")."""

    def __init__(self, problems: Sequence[str]):
        self.problems = list(problems)
        super().__init__("\n".join(self.problems))


@dataclass(frozen=True)
class MeasuredTrace:
    """One measured run, in SI units (the columns of the format above, as float arrays of
    one length). Made from arrays, it is checked as a loaded file is (:class:`MeasuredDataError`
    naming ``path``, the row and the column: a position in millimetres, a time that does not
    increase, a NaN where a value is required)."""

    path: str
    t: np.ndarray
    duty: np.ndarray
    position: np.ndarray
    resistance: np.ndarray | None = None
    current: np.ndarray | None = None
    wire_voltage: np.ndarray | None = None
    force: np.ndarray | None = None
    conditions: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        where = str(self.path)
        columns: dict[str, np.ndarray] = {}
        for name in KNOWN_COLUMNS:
            value = getattr(self, name)
            if value is None:
                if name in REQUIRED:
                    raise MeasuredDataError([f"{where}: {name} = None; expected an array of {name} values"])
                continue
            try:
                column = np.array(value, dtype=float)  # a copy: the trace never shares the caller's array
            except (TypeError, ValueError):
                raise MeasuredDataError(
                    [f"{where}: {name}: a {type(value).__name__} that is not numbers; expected a 1-D array of floats"]
                ) from None
            if column.ndim != 1:
                raise MeasuredDataError([f"{where}: {name}: shape {column.shape}; expected a 1-D array (one per row)"])
            columns[name] = column
        lengths = {name: len(a) for name, a in columns.items()}
        if len(set(lengths.values())) > 1:
            raise MeasuredDataError([f"{where}: columns of different lengths {lengths}; expected one value per row"])
        _empty_where_off(columns)  # as a loaded file's
        for name, column in columns.items():
            column.flags.writeable = False
            object.__setattr__(self, name, column)
        unreported = {name: np.zeros(len(a), dtype=bool) for name, a in columns.items()}
        problems = _value_problems(columns, where, unreported)
        if problems:
            raise MeasuredDataError(problems)

    @property
    def name(self) -> str:
        return Path(self.path).name

    @property
    def duration_s(self) -> float:
        return float(self.t[-1] - self.t[0])

    @property
    def sample_period_s(self) -> float:
        return float(np.median(np.diff(self.t)))

    def outputs(self) -> dict[str, np.ndarray]:
        """Measured outputs the model can be compared on (position, resistance if any)."""
        out = {"position": self.position}
        if self.resistance is not None and np.isfinite(self.resistance).any():
            out["resistance"] = self.resistance
        return out

    def duty_at_control_steps(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """The duty per control step of ``dt`` from t[0]: each row's duty held until the next
        row (a zero-order hold), averaged over the step (:meth:`mean_duty`).

        Returns (times of the step ends, duty per step).
        """
        n = int(math.floor((self.t[-1] - self.t[0]) / dt + 1e-9))
        ends = self.t[0] + dt * np.arange(1, n + 1)
        return ends, self.mean_duty(ends - dt, ends)

    def mean_duty(self, starts: np.ndarray, ends: np.ndarray) -> np.ndarray:
        """Mean of the held duty over each interval [start, end): the energy a PWM delivers
        there. An interval inside one row's hold gets that row's duty exactly; one that
        spans several rows (a controller commanding faster than the model's control step,
        or jittered timestamps) their time-weighted mean, not the duty at its start (which
        would drop every other command of a 2 kHz controller replayed at 1 kHz)."""
        last_row = len(self.duty) - 1
        first = np.clip(np.searchsorted(self.t, starts + 1e-12, side="right") - 1, 0, last_row)
        last = np.clip(np.searchsorted(self.t, ends - 1e-12, side="right") - 1, 0, last_row)
        duty = self.duty[first].astype(float)
        spans = last > first
        if spans.any():
            # Integral of the held duty from t[0] to each row's start, then to any time.
            held = np.r_[0.0, np.cumsum(np.diff(self.t) * self.duty[:-1])]

            def integral(x: np.ndarray) -> np.ndarray:
                k = np.clip(np.searchsorted(self.t, x, side="right") - 1, 0, last_row)
                return held[k] + (x - self.t[k]) * self.duty[k]

            a, b = starts[spans], ends[spans]
            duty[spans] = (integral(b) - integral(a)) / (b - a)
        return duty

    def slice(self, start_s: float, stop_s: float) -> MeasuredTrace:
        keep = (self.t >= start_s) & (self.t <= stop_s)

        def part(a: np.ndarray | None) -> np.ndarray | None:
            return None if a is None else a[keep]

        return MeasuredTrace(
            path=f"{self.path}[{start_s:g}:{stop_s:g}s]",
            t=self.t[keep],
            duty=self.duty[keep],
            position=self.position[keep],
            resistance=part(self.resistance),
            current=part(self.current),
            wire_voltage=part(self.wire_voltage),
            force=part(self.force),
            conditions=dict(self.conditions),
        )


def sidecar_candidates(csv_path: Path) -> tuple[Path, ...]:
    """Where a file's sidecar may be, in the order it is looked for: ``<file>.json``, then
    ``<stem>.json`` (never the file itself)."""
    return tuple(
        c for c in (csv_path.with_name(csv_path.name + ".json"), csv_path.with_suffix(".json")) if c != csv_path
    )


def sidecar_path(csv_path: Path) -> Path | None:
    """The file's sidecar, if there is one (:func:`sidecar_candidates`)."""
    for candidate in sidecar_candidates(csv_path):
        if candidate.exists():
            return candidate
    return None


def _parse_float(text: str) -> float:
    text = text.strip()
    if text == "" or text.lower() in ("nan", "na", "null", "none"):
        return math.nan
    if "_" in text or not text.isascii():
        # Python reads "1_0e-6" as 1e-5 and full-width or Arabic-Indic digits as numbers; no
        # CSV writer means either.
        raise ValueError(text)
    return float(text)


_LINE = re.compile(r"[^\r\n]*(?:\r\n|\r|\n)|[^\r\n]+\Z")
"""One line with its end, split as ``io.StringIO(newline="")`` splits them (\\n, \\r\\n, \\r)."""


def _lines(text: str) -> Iterator[str]:
    """The lines of ``text``, one at a time: the reader holds no list of rows (a 47 MB file
    of 10^6 rows took 850 MB as lists of strings)."""
    for match in _LINE.finditer(text):
        yield match.group(0)


def _check_header(header: list[str], first: list[str], where: str) -> None:
    """Raise :class:`MeasuredDataError` with every problem of the header row (``first`` as
    read, ``header`` its names stripped)."""
    problems: list[str] = []
    separator = next((sep for sep in (";", "\t", "|") if len(header) == 1 and sep in header[0]), None)
    if separator is not None:
        # One column holding every name: another separator (spreadsheets in many locales use ';').
        raise MeasuredDataError(
            [
                f"{where}:1: header {header[0]!r} is one column separated by {separator!r}; expected commas ({','.join(REQUIRED)},...)"
            ]
        )
    if header and header[0].startswith("#"):
        # One message, not one per column: the loader reads no comments.
        raise MeasuredDataError(
            [
                f"{where}:1: {first[0].strip()!r}... is a comment line; expected the header ({','.join(REQUIRED)},...) "
                "on the first line (remarks belong in the sidecar's 'notes')"
            ]
        )
    shown_header = ", ".join(header[:10]) + (f", ... ({len(header)} names)" if len(header) > 10 else "")
    if len(header) > 2 and header[0] in REQUIRED and _is_number(header[1]):
        # One row per channel (an oscilloscope's or a transposed spreadsheet's export).
        raise MeasuredDataError(
            [
                f"{where}:1: the first row is {header[0]!r} followed by numbers ({shown_header}); expected one column "
                f"per quantity and one row per sample: is the file transposed?"
            ]
        )
    for name in REQUIRED:
        if name not in header:
            problems.append(f"{where}:1:{name}: missing required column (header: {shown_header})")
    unknown = [(k, name) for k, name in enumerate(header) if name not in KNOWN_COLUMNS]
    for k, name in unknown[:MAX_PROBLEMS_SHOWN]:
        if name == "":
            problems.append(
                f"{where}:1: column {k + 1} has no name (a pandas index written by to_csv, or a trailing comma?); "
                f"expected only {', '.join(KNOWN_COLUMNS)}"
            )
        elif name == "supply_voltage":
            problems.append(
                f"{where}:1:supply_voltage: not a column of this format; the voltage across the wire during the "
                "on-time is the column wire_voltage (files sma-gym synth wrote before 2026-12-07 name it "
                "supply_voltage: rename it), and the supply's voltage goes into the sidecar as supply_voltage_v"
            )
        else:
            problems.append(f"{where}:1:{name}: unknown column; expected only {', '.join(KNOWN_COLUMNS)}")
    if len(unknown) > MAX_PROBLEMS_SHOWN:
        problems.append(f"{where}:1: ... {len(unknown) - MAX_PROBLEMS_SHOWN} more unknown columns")
    if len(set(header)) != len(header):
        problems.append(f"{where}:1: duplicate column names in header ({shown_header})")
    if problems:
        raise MeasuredDataError(problems)


def _read_columns(p: Path, where: str, min_rows: int) -> tuple[dict[str, np.ndarray], list[str], dict[str, np.ndarray]]:
    """The CSV's columns by header name, the problems found reading them (a file that
    cannot be read as a table at all raises at once), and per column the rows whose cell
    is already reported (a wrong field count, a text that is no number), so that the value
    checks do not report them again as missing. Rows are parsed as they are read."""
    problems: list[str] = []
    try:
        text = read_text(p, MAX_CSV_BYTES, "measured data")
    except ValueError as err:
        raise MeasuredDataError([str(err)]) from None
    if not text.strip(" \t\r\n,"):
        raise MeasuredDataError([f"{where}: empty file, expected a header row {','.join(REQUIRED)}"])
    reader = csv.reader(_lines(text))
    read = 0  # rows read, the header's included
    last: list[str] = []

    def rows() -> Iterator[list[str]]:
        nonlocal read, last
        try:
            for row in reader:
                read += 1
                if reader.line_num != read:
                    # A quote left open swallows the lines after it into one field.
                    raise MeasuredDataError(
                        [
                            f"{where}:{read}: a double quote opened on this line runs on to line "
                            f"{reader.line_num}; expected one row per line (a stray '\"'?)"
                        ]
                    )
                last = row
                yield row
        except csv.Error as err:
            raise MeasuredDataError(
                [f"{where}:{read + 1}: not readable as CSV ({err}; a stray '\"'?); expected one row per line"]
            ) from None

    def check_last() -> None:
        if any("\n" in field or "\r" in field for field in last):
            # The same on the last line: the quote runs on to the end of the file, taking the
            # line's end (and any fields after it) into one field; line_num cannot tell.
            raise MeasuredDataError(
                [
                    f"{where}:{read}: a double quote opened on this line runs on to the end of the file; "
                    "expected one row per line (a stray '\"'?)"
                ]
            )

    stream = rows()
    first = next(stream)
    check_last()
    header = [h.strip() for h in first]
    _check_header(header, first, where)
    values = {name: array("d") for name in header}
    reported_rows: dict[str, list[int]] = {name: [] for name in header}
    # As the value checks: the first few of a kind are named, the rest counted (a file of
    # text in every row would otherwise print one line per row).
    shown = {"fields": 0, "number": 0}
    hidden = {"fields": 0, "number": 0}

    def report(kind: str, message: str) -> None:
        if shown[kind] < MAX_PROBLEMS_SHOWN:
            shown[kind] += 1
            problems.append(message)
        else:
            hidden[kind] += 1

    n = 0  # data rows taken

    def take(row: list[str]) -> None:
        nonlocal n
        line = n + 2
        if len(row) != len(header):
            report("fields", f"{where}:{line}: {len(row)} fields, expected {len(header)}")
            for name in header:
                values[name].append(math.nan)
                reported_rows[name].append(n)
        else:
            for name, text in zip(header, row):
                try:
                    values[name].append(_parse_float(text))
                except ValueError:
                    values[name].append(math.nan)
                    report("number", f"{where}:{line}:{name}: {text!r} is not a number")
                    reported_rows[name].append(n)
        n += 1

    blank: list[list[str]] = []  # blank rows not yet known to lie inside the data
    for row in stream:
        if not any(field.strip() for field in row):
            blank.append(row)  # blank lines at the end (editors and spreadsheets add them) are dropped
            continue
        for pending in blank:
            take(pending)
        blank.clear()
        take(row)
    check_last()
    # One minimum in both messages (a header-only file was told 2, then the same file with
    # two rows 20).
    why = (
        "" if min_rows <= 2 else " (the diagnosis fits more than ten samples after holding out the last 30 % of a file)"
    )
    if n < 2:
        raise MeasuredDataError([f"{where}: {n} data row(s), expected at least {max(min_rows, 2)}{why}"])
    if n < min_rows:  # reported with the file's other problems
        problems.append(f"{where}: {n} data row(s), expected at least {min_rows}{why}")
    if hidden["fields"]:
        problems.append(f"{where}: ... {hidden['fields']} more rows with the wrong number of fields")
    if hidden["number"]:
        problems.append(f"{where}: ... {hidden['number']} more cells that are not numbers")
    columns = {name: np.array(values[name], dtype=float) for name in header}
    reported = {}
    for name in header:
        reported[name] = np.zeros(n, dtype=bool)
        reported[name][reported_rows[name]] = True
    return columns, problems, reported


def _empty_where_off(columns: dict[str, np.ndarray]) -> None:
    """A logger's 0 in an electrical column where the duty is 0 (the wire was not driven):
    no reading, made empty in place."""
    if "duty" in columns:
        off = columns["duty"] == 0.0
        for name in ELECTRICAL:
            if name in columns:
                columns[name][off & (columns[name] == 0.0)] = math.nan


def _is_number(text: str) -> bool:
    try:
        return math.isfinite(_parse_float(text))
    except ValueError:
        return False


def _value_problems(columns: dict[str, np.ndarray], where: str, reported: dict[str, np.ndarray]) -> list[str]:
    """Missing, non-finite, non-increasing and out-of-range values, each with file:row:column
    (``reported``: cells already named by :func:`_read_columns`, not named again)."""
    problems: list[str] = []
    for name in REQUIRED:
        bad = np.flatnonzero(~np.isfinite(columns[name]) & ~reported[name])
        for i in bad[:20]:
            problems.append(f"{where}:{i + 2}:{name}: missing or non-finite value (required)")
        if bad.size > 20:
            problems.append(f"{where}:{name}: ... {bad.size - 20} more rows with missing values")
    for name in OPTIONAL:
        if name in columns:
            bad = np.flatnonzero(np.isinf(columns[name]))
            for i in bad[:20]:
                problems.append(f"{where}:{i + 2}:{name}: infinite value")

    t = columns["t"]
    dt = np.diff(t)
    nonmono = np.flatnonzero(~(dt > 0) & np.isfinite(dt))
    for i in nonmono[:20]:
        problems.append(
            f"{where}:{i + 3}:t: time {float(t[i + 1]):g} s does not increase (previous row {float(t[i]):g} s); expected strictly increasing"
        )
    if nonmono.size > 20:
        problems.append(f"{where}:t: ... {nonmono.size - 20} more non-increasing times")
    finite_dt = dt[np.isfinite(dt) & (dt > 0)]
    if finite_dt.size and np.median(finite_dt) >= 0.5:
        problems.append(
            f"{where}:t: median sample interval {np.median(finite_dt):g} s; expected seconds at >= 2 Hz "
            "(is the time in milliseconds?)"
        )

    duty = columns["duty"]
    out_of_range = np.flatnonzero(np.isfinite(duty) & ((duty < 0.0) | (duty > 1.0)))
    for i in out_of_range[:20]:
        hint = " (a percentage?)" if duty[i] > 1.0 and duty[i] <= 100.0 else ""
        problems.append(f"{where}:{i + 2}:duty: {float(duty[i]):g} outside [0, 1]{hint}")
    if out_of_range.size > 20:
        problems.append(f"{where}:duty: ... {out_of_range.size - 20} more values outside [0, 1]")

    position = columns["position"]
    big = np.flatnonzero(np.isfinite(position) & (np.abs(position) > MAX_ABS_POSITION_M))
    if big.size:
        i = big[0]
        problems.append(
            f"{where}:{i + 2}:position: {float(position[i]):g} m ({big.size} rows beyond +-{MAX_ABS_POSITION_M} m); "
            "expected metres (is the position in millimetres or micrometres?)"
        )
    for name, limit, unit in (
        ("resistance", MAX_RESISTANCE_OHM, "ohm"),
        ("current", MAX_CURRENT_A, "A"),
        ("force", MAX_FORCE_N, "N"),
        ("wire_voltage", MAX_WIRE_VOLTAGE_V, "V"),
    ):
        if name in columns:
            v = columns[name]
            # A wire always has a resistance: 0 ohm is a logger's fill value, not a reading.
            low_bad = v <= 0.0 if name == "resistance" else v < 0.0
            bad = np.flatnonzero(np.isfinite(v) & (low_bad | (v > limit)))
            if bad.size:
                i = bad[0]
                low = f"(0, {limit:g}]" if name == "resistance" else f"[0, {limit:g}]"
                problems.append(
                    f"{where}:{i + 2}:{name}: {float(v[i]):g} {unit} ({bad.size} row{'s' if bad.size > 1 else ''} "
                    f"outside the range); expected values in {low} {unit} (SI units)"
                )
    off = np.isfinite(duty) & (duty == 0.0)
    for name in ELECTRICAL:
        if name in columns:
            v = columns[name]
            bad = np.flatnonzero(off & np.isfinite(v))
            if bad.size:
                i = bad[0]
                problems.append(
                    f"{where}:{i + 2}:{name}: {float(v[i]):g} where the duty is 0 ({bad.size} "
                    f"row{'s' if bad.size > 1 else ''}); this column holds readings during a PWM pulse, which the "
                    "model has none of there: leave the cell empty (or 0) where the wire was not driven"
                )

    return problems


def _read_sidecar(p: Path) -> tuple[dict[str, Any], list[str]]:
    """The sidecar's conditions (if the file has one) and the problems found in it."""
    problems: list[str] = []
    conditions: dict[str, Any] = {}
    side = sidecar_path(p)
    if side is not None:
        try:
            raw = read_json_object(side, "sidecar")
        except ValueError as err:
            problems.append(str(err))
            raw = {}
        if raw.get("format") == "sma-gym-model":
            # A model file that shares the data's name (bench2.json beside bench2.csv) was
            # reported as five unknown sidecar keys (a new user's trial).
            where = (
                "rename the model file (a sidecar holds the file's conditions)"
                if side.name == f"{p.name}.json"
                else f"rename the model file, or write the conditions into {p.name}.json, which is read first"
            )
            return conditions, [
                f"{side}: a model file (format 'sma-gym-model'), read as the sidecar of {p.name} because of its "
                f"name; {where}"
            ]
        for key, value in raw.items():
            if key in SIDECAR_KEYS:
                b = parameter_bound(SIDECAR_KEYS[key])
                try:
                    if not isinstance(value, (int, float)):
                        raise ValueError(f"{key} = {value!r}: expected a number")
                    conditions[key] = require_range(
                        key, value, b.lower, b.upper, b.unit, lower_open=b.lower_open, upper_open=b.upper_open
                    )
                except ValueError as err:
                    problems.append(f"{side}: {err}")
            elif key in SIDECAR_TEXT_KEYS:
                if isinstance(value, str):
                    conditions[key] = value
                else:  # str() made null "None" and 5 "5"
                    problems.append(f"{side}: {key} = {value!r}: expected a string")
            else:
                problems.append(
                    f"{side}:{key}: unknown key; expected {', '.join(list(SIDECAR_KEYS) + list(SIDECAR_TEXT_KEYS))}"
                )
    return conditions, problems


def _require_path(path: object, what: str) -> Path:
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(
            f"{what} = {type(path).__name__} object: expected the path of a CSV file (str or os.PathLike); "
            "a trace in memory is a MeasuredTrace(path, t, duty, position, ...) made from its arrays"
        )
    return Path(path)


def load_trace(path: str | Path, min_rows: int = 2) -> MeasuredTrace:
    """Load and validate one CSV file (and its sidecar). Raises :class:`MeasuredDataError`.

    ``min_rows``: fewest data rows accepted (``DIAGNOSIS_MIN_ROWS`` for a diagnosis).
    """
    from sma_gym._validation import require_int_range

    p = _require_path(path, "path")
    require_int_range("min_rows", min_rows, 2, 10**9)
    where = str(p)
    if not p.exists():
        raise MeasuredDataError([f"{where}: file does not exist"])
    if p.is_dir():
        raise MeasuredDataError([f"{where}: is a directory, expected a CSV file"])
    columns, problems, reported = _read_columns(p, where, min_rows)
    _empty_where_off(columns)
    problems += _value_problems(columns, where, reported)
    conditions, sidecar_problems = _read_sidecar(p)
    problems += sidecar_problems
    if problems:
        raise MeasuredDataError(problems)
    t, duty, position = columns["t"], columns["duty"], columns["position"]
    return MeasuredTrace(
        path=str(p),
        t=t,
        duty=duty,
        position=position,
        resistance=columns.get("resistance"),
        current=columns.get("current"),
        wire_voltage=columns.get("wire_voltage"),
        force=columns.get("force"),
        conditions=conditions,
    )


def load_traces(paths: Sequence[str | Path] | str | Path, min_rows: int = 2) -> list[MeasuredTrace]:
    """Load several files, collecting the problems of all of them before raising (one path
    is one file, not a sequence of characters)."""
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    elif not isinstance(paths, Sequence) or isinstance(paths, bytes):
        raise TypeError(f"paths = {type(paths).__name__} object: expected a path or a list of paths of CSV files")
    traces = []
    problems: list[str] = []
    for path in paths:
        try:
            traces.append(load_trace(path, min_rows))
        except MeasuredDataError as err:
            problems.extend(err.problems)
    if problems:
        raise MeasuredDataError(problems)
    return traces


def write_trace(path: str | Path, trace: MeasuredTrace, *, overwrite: bool = False) -> Path:
    """Write a trace in the measured format (and its sidecar if it has conditions).

    ``overwrite`` replaces the CSV and the sidecar this function writes (``<file>.json``),
    and removes that sidecar when the new trace has no conditions (it would be read back
    with the new data). Without it, an existing CSV or sidecar is refused. A ``<stem>.json``
    beside the file, which :func:`load_trace` also reads as a sidecar, is never touched:
    it is refused unless the new trace's sidecar takes precedence over it."""
    p = Path(path)
    ours = sidecar_write_path(p)
    if not overwrite:
        for existing in (p, ours):
            if existing.exists():
                raise FileExistsError(f"{existing} exists; refusing to overwrite it (overwrite=True replaces it)")
    other = p.with_suffix(".json")
    if not trace.conditions and other != p and other.exists():
        raise FileExistsError(
            f"{other} exists and load_trace would read it as the sidecar of {p.name}, whose trace has no "
            "conditions; remove or rename it, or write the trace under another name"
        )
    cols = ["t", "duty", "position"]
    arrays = [trace.t, trace.duty, trace.position]
    for name in OPTIONAL:
        value = getattr(trace, name)
        if value is not None:
            cols.append(name)
            arrays.append(value)
    buffer = io.StringIO(newline="")
    writer = csv.writer(buffer)
    writer.writerow(cols)
    for row in zip(*arrays):
        writer.writerow(["" if not math.isfinite(v) else repr(float(v)) for v in row])
    # Sidecar first, then the CSV (each atomic): a CSV never appears without its conditions.
    if trace.conditions:
        write_json(ours, dict(trace.conditions))
    else:
        ours.unlink(missing_ok=True)  # a stale one would be read back with the new data
    write_text(p, buffer.getvalue())
    return p


def sidecar_write_path(csv_path: str | Path) -> Path:
    """Where :func:`write_trace` puts the sidecar of ``csv_path``: ``<file>.json``."""
    return Path(str(csv_path) + ".json")


REAL_BENCH_RUNS = ("step01.csv", "ramp01.csv", "step03.csv", "step07.csv")
"""The four shared runs of the 0.5 mm HT Flexinol bench (``../shared/data/real``): the
twin ``bench-0.5mm-ht`` is identified on all four, the fidelity plot shows them."""


def real_bench_folder() -> Path | None:
    """The shared real-data folder if it holds all of :data:`REAL_BENCH_RUNS`, else None."""
    folder = find_real_data_dir()
    if folder is None or not all((folder / name).is_file() for name in REAL_BENCH_RUNS):
        return None
    return folder


REAL_DATA_ENV = "SMA_GYM_REAL_DATA"
"""The environment variable that names the real-data folder wherever it is (a clone away
from ``../shared`` does not find it otherwise)."""


def find_real_data_dir() -> Path | None:
    """The shared real-data folder: ``$SMA_GYM_REAL_DATA`` if set (it must be a folder), else
    ``../shared/data/real`` from the working directory or the package, if present."""
    named = os.environ.get(REAL_DATA_ENV)
    if named:
        if not Path(named).is_dir():
            raise ValueError(
                f"{REAL_DATA_ENV} = {named!r}: expected a folder holding the bench's runs (e.g. step01.csv)"
            )
        return Path(named)
    here = Path(__file__).resolve()
    for parent in [Path.cwd(), *here.parents]:
        candidate = parent.parent / "shared" / "data" / "real"
        if candidate.is_dir():
            return candidate
        candidate = parent / "shared" / "data" / "real"
        if candidate.is_dir():
            return candidate
    return None

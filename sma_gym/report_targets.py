"""The report's 125 results as data: ids, values, calibration flags and tolerances.

``report_targets.json`` (shipped in the package) is generated once from the spec's
``REPORT_TARGETS.md`` table by::

    python -m sma_gym.report_targets PATH/TO/REPORT_TARGETS.md

and never edited by hand; ``tests/test_fidelity.py`` checks that it still matches the spec
file when that file is available. Each row keeps the spec's id, quantity, section, report
value and calibration flag, plus two things derived here: the numbers in the report value
(in the report's units, for the rows that compare numbers) and the tolerance kind of the
spec's single convention (:data:`TOLERANCES`).

The tolerance kind follows the convention's wording:

* ``table``: a number from a table (or the text): within +-30 %;
* ``control error``: a steady-state error below 0.1 mm: within +-0.03 mm absolute;
* ``overshoot``: within +-30 % or +-0.05 mm, whichever is wider;
* ``sine error``: a Table 6.1 sine error (hardware): same sign and within a factor 2;
* ``figure``: a number read off a figure or an axis: within a factor 1.5 (fig. 6.4's slope,
  A27, too: issue 11's own goal for it, a factor 2, is a goal, not the row's tolerance);
* ``qualitative``: the stated direction or ordering holds (each row says how it is tested).
"""

from __future__ import annotations

import json
import math
import re
import sys
from dataclasses import asdict, dataclass
from functools import lru_cache
from pathlib import Path

DATA_FILE = Path(__file__).with_name("report_targets.json")

TABLE_RELATIVE = 0.30
CONTROL_ERROR_ABS_MM = 0.03
OVERSHOOT_RELATIVE = 0.30
OVERSHOOT_ABS_MM = 0.05
SINE_ERROR_FACTOR = 2.0
FIGURE_FACTOR = 1.5

TOLERANCES: dict[str, str] = {
    "table": "within +-30 %",
    "control error": "within +-0.03 mm",
    "overshoot": "within +-30 % or +-0.05 mm",
    "sine error": "same sign, within a factor 2",
    "figure": "within a factor 1.5",
    "qualitative": "the stated direction or ordering holds",
}

# Kinds the rows of groups A, 8 and 9 cannot be told apart by wording alone (B, Q and 7
# rows follow from their quantity, see ``_tolerance_kind``).
_KIND_BY_ID: dict[str, str] = {
    **{i: "table" for i in ("A1", "A3", "A4", "A5", "A6", "A7", "A8", "A10", "A11", "8k", "9a-d", "9r")},
    **{f"8{c}": "table" for c in "abcdefg"},
    **{i: "figure" for i in ("A14", "A19", "A23", "A24", "A25", "A26", "9f", "9h")},
    "A27": "figure",
}

_NUMBER = re.compile(r"[+\-\u2212]?\d+(?:\.\d+)?")


@dataclass(frozen=True)
class Target:
    """One result of the report (one row of REPORT_TARGETS.md)."""

    id: str
    """The spec's id; the one range id ``9a–d`` is spelt ``9a-d``."""
    quantity: str
    section: str
    report: str
    """The report value as the spec writes it (units included)."""
    calibration: bool
    """A fitted parameter or a controller choice is tuned to this row: reported, not counted."""
    tolerance: str
    """A key of :data:`TOLERANCES`."""
    numbers: tuple[float, ...]
    """The numbers in ``report``, in order and in its units (unicode minus read as minus)."""

    @property
    def tolerance_text(self) -> str:
        return TOLERANCES[self.tolerance]

    def within(self, simulated: float, reported: float | None = None) -> bool:
        """``simulated`` (in the report's unit) against ``reported`` (default: the first number).

        Only for numeric kinds; qualitative rows state their own test.
        """
        r = self.numbers[0] if reported is None else reported
        return within_tolerance(self.tolerance, simulated, r)


def within_tolerance(kind: str, simulated: float, reported: float) -> bool:
    """The convention's test of ``simulated`` against ``reported`` (same unit) for ``kind``."""
    if simulated is None or not math.isfinite(simulated):
        return False
    if kind == "table":
        return abs(simulated - reported) <= TABLE_RELATIVE * abs(reported)
    if kind == "control error":
        return abs(simulated - reported) <= CONTROL_ERROR_ABS_MM
    if kind == "overshoot":
        return abs(simulated - reported) <= max(OVERSHOOT_RELATIVE * abs(reported), OVERSHOOT_ABS_MM)
    if kind == "sine error":
        return simulated * reported > 0.0 and within_factor(simulated, reported, SINE_ERROR_FACTOR)
    if kind == "figure":
        return within_factor(simulated, reported, FIGURE_FACTOR)
    raise ValueError(
        f"tolerance kind = {kind!r}: not a numeric kind (expected one of {sorted(set(TOLERANCES) - {'qualitative'})})"
    )


def within_factor(simulated: float, reported: float, factor: float) -> bool:
    """Same sign and |simulated / reported| in [1 / factor, factor]."""
    if not math.isfinite(simulated) or reported == 0.0:
        return False
    ratio = simulated / reported
    return ratio > 0.0 and 1.0 / factor <= ratio <= factor


# --------------------------------------------------------------------------------------
# Parsing the spec's table (used once to generate the JSON, and by the test)
# --------------------------------------------------------------------------------------
def _tolerance_kind(target_id: str, quantity: str, report: str) -> str:
    if target_id in _KIND_BY_ID:
        return _KIND_BY_ID[target_id]
    if target_id.startswith("B"):
        if "overshoot" in quantity:
            return "overshoot"
        if "sine error" in quantity:
            return "sine error"
        if "steady-state error" in quantity:
            # "osc." is not a number: the statement is that the controller oscillates.
            return "qualitative" if not _NUMBER.search(report) else "control error"
    return "qualitative"


def _numbers(text: str) -> tuple[float, ...]:
    return tuple(float(m.replace("\u2212", "-")) for m in _NUMBER.findall(text))


def parse_report_targets(markdown: str) -> tuple[Target, ...]:
    """The rows of REPORT_TARGETS.md's table, in order."""
    targets = []
    for line in markdown.splitlines():
        line = line.strip()
        if not line.startswith("|") or line.startswith(("|---", "| id ")):
            continue
        cells = [c.strip() for c in line.strip("|").split("|")]
        if len(cells) != 5:
            raise ValueError(f"REPORT_TARGETS row with {len(cells)} cells (expected 5): {line!r}")
        target_id, quantity, section, report, calibration = cells
        target_id = target_id.replace("\u2013", "-")
        targets.append(
            Target(
                id=target_id,
                quantity=quantity,
                section=section,
                report=report,
                calibration=calibration == "calibration",
                tolerance=_tolerance_kind(target_id, quantity, report),
                numbers=_numbers(report),
            )
        )
    ids = [t.id for t in targets]
    if len(set(ids)) != len(ids):
        raise ValueError("REPORT_TARGETS has duplicate ids")
    return tuple(targets)


def write_data_file(markdown_path: Path, out: Path = DATA_FILE) -> Path:
    """Regenerate ``report_targets.json`` from the spec's markdown."""
    targets = parse_report_targets(Path(markdown_path).read_text(encoding="utf-8"))
    rows = [{**asdict(t), "numbers": list(t.numbers)} for t in targets]
    out.write_text(json.dumps(rows, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
    return out


@lru_cache(maxsize=1)
def load_targets() -> tuple[Target, ...]:
    """The shipped targets, in the spec's order."""
    rows = json.loads(DATA_FILE.read_text(encoding="utf-8"))
    return tuple(Target(**{**r, "numbers": tuple(r["numbers"])}) for r in rows)


def target(target_id: str) -> Target:
    """The target with id ``target_id`` (e.g. ``"B4"``, ``"9a-d"``)."""
    for t in load_targets():
        if t.id == target_id:
            return t
    raise KeyError(f"target id = {target_id!r}: not in REPORT_TARGETS")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        raise SystemExit("usage: python -m sma_gym.report_targets PATH/TO/REPORT_TARGETS.md")
    print(write_data_file(Path(sys.argv[1])))

"""Randomised operating conditions for the robustness env (report chapter 7).

Declarative: each condition is either a fixed value or a range to draw from at reset;
:meth:`Conditions.draw` draws them, in a fixed order, from the env's ``np_random`` and
returns the model to simulate plus a plain dict of what was drawn (it goes into ``info``).

The report's chapter 7 conditions are the supply (5 to 15 V, §7.2), natural or forced
convection (§7.1) and the wire diameter (0.2 to 0.5 mm, §7.3). On top, a parameter spread
stands for the unit-to-unit and model uncertainty a controller must survive: convection
+-15 %, transformation temperatures +-3 K, recoverable strain +-5 %, preload +-20 %,
resistivity +-5 % (``spread`` scales all of these; 0 switches them off).
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Callable
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

from sma_gym._validation import require_range
from sma_gym.model import ModelConfig
from sma_gym.params import FORCED_CONVECTION_FACTOR

CONVECTIONS = ("natural", "forced")

SPREAD_HALF_WIDTHS = {"h_scale": 0.15, "shift": 3.0, "eps_scale": 0.05, "preload_scale": 0.2, "rho_scale": 0.05}
"""Half-widths of the parameter spread at ``spread`` 1, in the order they are drawn: the
convection's log-scale, the transformation shift [K], and the relative spreads of the
recoverable strain, the spring preload and the resistivity (the module docstring's +-15 %,
+-3 K, +-5 %, +-20 %, +-5 %)."""


def _spread_terms(draws: dict[str, float]) -> dict[str, float]:
    """The drawn (or corner) offsets as the factors and shift :meth:`Conditions._build` takes."""
    return {
        "h_scale": float(np.exp(draws["h_scale"])),
        "shift": draws["shift"],
        **{k: 1.0 + draws[k] for k in ("eps_scale", "preload_scale", "rho_scale")},
    }


def _as_range(name: str, value: Any, lower: float, upper: float, unit: str) -> tuple[float, float]:
    if isinstance(value, np.ndarray) and value.ndim == 1:
        value = value.tolist()  # a (low, high) pair given as an array
    if isinstance(value, (tuple, list)):
        if len(value) != 2:
            raise ValueError(
                f"{name} = {value!r}: expected a number or a (low, high) pair in [{lower:g}, {upper:g}] {unit}"
            )
        lo = require_range(name, value[0], lower, upper, unit)
        hi = require_range(name, value[1], lower, upper, unit)
        if hi < lo:
            raise ValueError(f"{name} = {value!r}: expected low <= high")
        return lo, hi
    v = require_range(name, value, lower, upper, unit)
    return v, v


@dataclass(frozen=True)
class Conditions:
    """Ranges (or fixed values) of the randomised conditions.

    The field defaults are the robustness env's defaults (the one place they are defined):
    supply 5-15 V (§7.2), natural or forced convection (§7.1), 0.2-0.5 mm wire (§7.3) and
    the full parameter spread.
    """

    supply_voltage_v: tuple[float, float] = (5.0, 15.0)
    convection: tuple[str, ...] = CONVECTIONS
    wire_diameter_m: tuple[float, float] = (0.2e-3, 0.5e-3)
    spread: float = 1.0

    @classmethod
    def from_kwargs(
        cls,
        supply_voltage_v: Any = None,
        convection: Any = None,
        wire_diameter_m: Any = None,
        spread: Any = None,
    ) -> Conditions:
        """Validate env kwargs: numbers fix a condition, (low, high) pairs randomise it,
        ``convection`` is ``"natural"`` (the model's own), ``"forced"`` (the model's times
        ``FORCED_CONVECTION_FACTOR``, the report's fan) or ``"random"``; ``None`` keeps the default."""
        default = cls()
        if convection is None or convection == "random":
            conv: tuple[str, ...] = default.convection if convection is None else CONVECTIONS
        elif convection in CONVECTIONS:
            conv = (convection,)
        else:
            raise ValueError(f"convection = {convection!r}: expected 'natural', 'forced' or 'random'")
        return cls(
            supply_voltage_v=default.supply_voltage_v
            if supply_voltage_v is None
            else _as_range("supply_voltage_v", supply_voltage_v, 1.0, 30.0, "V"),
            convection=conv,
            wire_diameter_m=default.wire_diameter_m
            if wire_diameter_m is None
            else _as_range("wire_diameter_m", wire_diameter_m, 0.05e-3, 1.0e-3, "m"),
            spread=default.spread if spread is None else require_range("spread", spread, 0.0, 3.0),
        )

    def draw(self, base: ModelConfig, rng: np.random.Generator) -> tuple[ModelConfig, dict[str, Any]]:
        """Draw one condition (fixed order of draws: same seed, same condition)."""
        u = rng.uniform
        voltage = float(u(*self.supply_voltage_v))
        # Always one draw over both kinds: numpy draws nothing for a single choice, so fixing
        # the convection shifted every later draw and the same seed gave another wire.
        convection = self.convection[int(rng.integers(len(CONVECTIONS))) % len(self.convection)]
        diameter = float(u(*self.wire_diameter_m))
        draws = {name: float(u(-half, half)) * self.spread for name, half in SPREAD_HALF_WIDTHS.items()}
        return self._build(base, voltage, convection, diameter, **_spread_terms(draws))

    def corners(self) -> list[dict[str, Any]]:
        """Every combination of the ends of the ranges (each condition at its low or high end,
        each convection given; a fixed value once): where a draw is most extreme."""
        ends: dict[str, list] = {
            "voltage": sorted(set(self.supply_voltage_v)),
            "convection": list(self.convection),
            "diameter": sorted(set(self.wire_diameter_m)),
            **{name: sorted({-half * self.spread, half * self.spread}) for name, half in SPREAD_HALF_WIDTHS.items()},
        }
        corners = []
        for values in itertools.product(*ends.values()):
            corner = dict(zip(ends, values, strict=True))
            fixed = {k: corner.pop(k) for k in ("voltage", "convection", "diameter")}
            corners.append({**fixed, **_spread_terms(corner)})
        return corners

    def check(self, base: ModelConfig, check_model: Callable[[ModelConfig], None]) -> None:
        """Refuse ranges that can draw a wire ``base`` cannot be (a preload past the thinnest
        wire's strength, transformation temperatures shifted below the surroundings) or one
        ``check_model`` refuses (a reference beyond its stroke): checked at every corner of
        the ranges, since each such limit moves one way with each condition. Such a draw failed
        at some reset, and every reset after it (a refused reset restores the generator, so it
        drew the same condition again)."""
        for corner in self.corners():
            try:
                model, _ = self._build(base, **corner)
                check_model(model)
            except ValueError as err:
                shown = (
                    f"supply {corner['voltage']:g} V, {corner['convection']} convection, wire diameter "
                    f"{corner['diameter'] * 1e3:g} mm; spread {self.spread:g}: transformation shift "
                    f"{corner['shift']:+g} K, strain x{corner['eps_scale']:g}, preload x{corner['preload_scale']:g}"
                )
                raise ValueError(
                    f"supply_voltage_v, convection, wire_diameter_m, spread = {self.supply_voltage_v}, "
                    f"{self.convection}, {self.wire_diameter_m}, {self.spread:g}: the condition ({shown}) gives a wire "
                    f"the episode cannot run on ({err}); expected ranges whose every draw can (narrow them, lower "
                    "the spread, or change what the error names)"
                ) from None

    @staticmethod
    def _build(
        base: ModelConfig,
        voltage: float,
        convection: str,
        diameter: float,
        *,
        h_scale: float,
        shift: float,
        eps_scale: float,
        preload_scale: float,
        rho_scale: float,
    ) -> tuple[ModelConfig, dict[str, Any]]:
        """The model and the condition record of one drawn (or corner) condition."""
        p = base.actuator
        w, c = p.wire, p.convection
        factor = h_scale * (FORCED_CONVECTION_FACTOR if convection == "forced" else 1.0)
        actuator = replace(
            p,
            wire=replace(
                w,
                diameter_m=diameter,
                austenite_start_c=w.austenite_start_c + shift,
                austenite_finish_c=w.austenite_finish_c + shift,
                martensite_start_c=w.martensite_start_c + shift,
                martensite_finish_c=w.martensite_finish_c + shift,
                max_transformation_strain=w.max_transformation_strain * eps_scale,
                resistivity_martensite_ohm_m=w.resistivity_martensite_ohm_m * rho_scale,
                resistivity_austenite_ohm_m=w.resistivity_austenite_ohm_m * rho_scale,
            ),
            convection=replace(c, h0_w_m2_k=c.h0_w_m2_k * factor, h2_w_m2_k3=c.h2_w_m2_k3 * factor),
            driver=replace(p.driver, supply_voltage_v=voltage),
            mechanism=replace(p.mechanism, spring_preload_n=p.mechanism.spring_preload_n * preload_scale),
            name=f"robust({voltage:.1f} V, {convection}, {diameter * 1e3:.2f} mm)",
        )
        condition = {
            "supply_voltage_v": voltage,
            "convection": convection,
            "wire_diameter_m": diameter,
            "convection_scale": h_scale,
            "transformation_shift_k": shift,
            "strain_scale": eps_scale,
            "preload_scale": preload_scale,
            "resistivity_scale": rho_scale,
        }
        return replace(base, actuator=actuator), condition


def require_no_silent_override(
    model: ModelConfig, reference: ModelConfig, given: set[str], label: object = None
) -> None:
    """Refuse a ``model`` whose own supply, wire or convection the draws would change unasked.

    The draws set the supply voltage and the wire diameter outright and multiply the
    model's convection by the fan's factor for "forced"; for the default model that is the
    report's chapter 7. A model that differs from ``reference`` (the env's default model)
    in one of those is the user's own actuator: drawing over it silently replaced a 20 V
    supply by 5-15 V, a twin's 0.5 mm wire by 0.2-0.5 mm, and cooled a fan-cooled model
    2.5x harder again while labelling the draw "natural". So the user says which they mean,
    by passing the condition's kwarg (a number or "natural" keeps it; a range or "random"
    draws it). ``label`` is the ``model`` argument as the user gave it (a preset name, a
    path, a model), named in the error: a corrected model's actuator keeps the name of the
    preset it was diagnosed from, which the user never typed."""
    p, r = model.actuator, reference.actuator
    problems = []
    if "supply_voltage_v" not in given and p.driver.supply_voltage_v != r.driver.supply_voltage_v:
        v = p.driver.supply_voltage_v
        problems.append(
            f"its supply {v:g} V would be drawn from {Conditions().supply_voltage_v} V: pass supply_voltage_v={v:g} to "
            "keep it or a (low, high) range to draw it"
        )
    if "wire_diameter_m" not in given and p.wire.diameter_m != r.wire.diameter_m:
        d = p.wire.diameter_m
        problems.append(
            f"its wire diameter {d:g} m would be drawn from {Conditions().wire_diameter_m} m: pass wire_diameter_m={d:g} "
            "to keep it or a (low, high) range to draw it"
        )
    if "convection" not in given and p.convection != r.convection:
        problems.append(
            "its convection differs from the default model's, and a draw of 'forced' multiplies it by "
            f"{FORCED_CONVECTION_FACTOR:g} (the report's fan): pass convection='natural' to keep it as it is, or "
            "'random' / 'forced' to add the fan"
        )
    if problems:
        raise ValueError(
            f"model = {_shown(model, label)}: the robustness env draws its "
            "conditions at every reset, and " + "; ".join(problems)
        )


def _shown(model: ModelConfig, label: object) -> str:
    """How an error names the model: as the user gave it when that was a name or a path;
    a configuration object by its name, which a changed copy of a preset keeps, so it is
    said to be the configuration's and not the preset's."""
    if isinstance(label, (str, os.PathLike)):
        return repr(str(label))
    return f"{type(label).__name__}(name={model.actuator.name!r}, ...)"


CONDITION_KWARGS = tuple(f.name for f in fields(Conditions))
"""The env kwargs that set the randomised conditions (only the robustness env takes them)."""

CONDITION_INFO = {
    "condition_supply_voltage_v": "supply voltage [V]",
    "condition_forced_convection": "forced: the model's convection times the report's fan factor (True), or natural: the model's own (bool)",
    "condition_wire_diameter_m": "wire diameter [m]",
    "condition_convection_scale": "spread factor of the convection coefficient [-]",
    "condition_transformation_shift_k": "shift of the transformation temperatures [K]",
    "condition_strain_scale": "factor of the recoverable strain [-]",
    "condition_preload_scale": "factor of the spring preload [-]",
    "condition_resistivity_scale": "factor of the resistivities [-]",
}
"""The ``info`` entries of a drawn condition: the same keys for every draw, so batched
clients (vector envs, TorchRL) can stack them."""
CONDITION_INFO_KEYS = tuple(CONDITION_INFO)


def condition_info(condition: dict[str, Any]) -> dict[str, float | bool]:
    """A drawn condition (:meth:`Conditions.draw`) as flat ``info`` entries.

    Numbers stay floats; the convection name becomes the bool
    ``condition_forced_convection``, so every value is a plain JSON scalar of fixed type.
    """
    flat: dict[str, float | bool] = {}
    for key in CONDITION_INFO_KEYS:
        name = key[len("condition_") :]
        flat[key] = condition["convection"] == "forced" if name == "forced_convection" else float(condition[name])
    return flat

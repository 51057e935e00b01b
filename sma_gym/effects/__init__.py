"""Named, optional model extensions ("effects").

Each effect is a physical term the report's model lacks or is unsure of (docs/model.md §11). It
has a name, parameters with units, bounds and an *off* value, and is off by default: a
model with every effect at its off value is the report's model, bit for bit.

The terms themselves live in the physics module they belong to (friction in mechanics,
latent heat in the heat balance, ...), written so that the off value makes them vanish;
this module only declares them and turns a user's settings into the numbers the simulator
core reads. The diagnosis workflow uses exactly these declarations as its candidates.

Some effects have alternative *forms* (e.g. a second-order instead of a first-order sensor
lag). Candidates are first fitted in the ``default`` form; the diagnosis tries the other
forms only where the data ask for them (an effect found, in later rounds; a candidate with
evidence in an ``unexplained`` round; ``sma_gym.diagnosis.workflow``). Synthetic test data
hide an effect in its other form, so that the first fit never meets the shape that made the
data (the 'inverse crime' of fitting data with the model that generated it); the
independent generator of the tests has forms of its own.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from sma_gym._validation import require_finite


@dataclass(frozen=True)
class EffectParameter:
    """One parameter of an effect."""

    name: str
    unit: str
    off: float
    lower: float
    upper: float
    description: str
    typical: float
    """A value clearly visible in the outputs, used by examples and tests."""


@dataclass(frozen=True)
class Effect:
    """Declaration of a named effect."""

    name: str
    title: str
    description: str
    source: str
    parameters: tuple[EffectParameter, ...]
    forms: tuple[str, ...] = ("default",)
    outputs: tuple[str, ...] = ("position", "resistance")
    """Which measured outputs the effect can change (diagnosis uses this)."""
    forms_with_own_law: tuple[str, ...] = ()
    """Forms that change the model even at the off values (another law, not a size: the
    latent heat released at 0.7x on cooling, power-law convection, a uniform spread of the
    wire's own transformation temperatures): an effect in one of them is never off."""

    def parameter(self, name: str) -> EffectParameter:
        for p in self.parameters:
            if p.name == name:
                return p
        raise ValueError(
            f"effect {self.name!r} has no parameter {name!r}; expected one of {[p.name for p in self.parameters]}"
        )

    @property
    def off_values(self) -> dict[str, float]:
        return {p.name: p.off for p in self.parameters}


def _p(
    name: str, unit: str, off: float, lower: float, upper: float, typical: float, description: str
) -> EffectParameter:
    return EffectParameter(name, unit, off, lower, upper, description, typical)


EFFECTS: dict[str, Effect] = {
    e.name: e
    for e in (
        Effect(
            name="transformation_spread",
            title="Transformation-temperature spread",
            description=(
                "The wire transforms over a wider range of temperatures than the nominal "
                "model says: resistive heating is less uniform, the transition temperatures "
                "vary more along the wire (§5.7). Adds an independent spread of standard "
                "deviation spread_k to the wire's nominal transformation_spread_k (variances "
                "add): the transformation starts earlier and ends later."
            ),
            source="§5.7",
            parameters=(
                _p("spread_k", "K", 0.0, 0.0, 20.0, 6.0, "standard deviation of the local transformation temperatures"),
            ),
            forms=("default", "uniform"),
            forms_with_own_law=("uniform",),
        ),
        Effect(
            name="minor_loop_width",
            title="Wider minor loops",
            description=(
                "The wire moves back later after a reversal than the nominal hysterons say: "
                "its narrowest local loops are wider (a real wire's partial contraction can "
                "hold for seconds after the power goes off). No hysteron's loop is narrower "
                "than min_width_share times the hysterons' mean width (the wide ones kept, "
                "so the major loop widens a little); minor loops inside it widen most "
                "(§5.6, docs/model.md §3)."
            ),
            source="§5.6",
            parameters=(
                _p(
                    "min_width_share",
                    "-",
                    0.0,
                    0.0,
                    1.0,
                    0.6,
                    "narrowest hysteron loop as a share of the mean loop width",
                ),
            ),
            forms=("default", "mean"),
        ),
        Effect(
            name="latent_heat",
            title="Latent heat of transformation",
            description=(
                "The latent heat the transformation absorbs (M->A) and releases (A->M) differs "
                "from the wire's nominal latent_heat_j_kg (the datasheet's 24.2 J/g for "
                "Flexinol; NiTi alloys range over about 15-30 J/g, and the report's own model "
                "had none, §5.8): Delta_H becomes nominal + change_j_kg (never below zero) in "
                "the heat balance's Delta_H m xi' term."
            ),
            source="§5.8",
            parameters=(
                _p("change_j_kg", "J/kg", 0.0, -24200.0, 24200.0, -12000.0, "change of the latent heat per unit mass"),
            ),
            forms=("default", "asymmetric"),
            forms_with_own_law=("asymmetric",),
        ),
        Effect(
            name="convection_change",
            title="Changed convection law",
            description=(
                "The heat loss differs from h0 + h2 T^2: a fan, a draught, a different "
                "temperature dependence (§5.4, §5.8, §7.1). h becomes "
                "scale * (h0 + h1 (T - T_amb) + h2 T^2)."
            ),
            source="§5.4, §5.8, §7.1",
            parameters=(
                _p("scale", "-", 1.0, 0.2, 5.0, 1.6, "multiplier on the convection coefficient"),
                _p("h1_w_m2_k2", "W/(m^2 K^2)", 0.0, -0.6, 3.0, 0.6, "added linear temperature dependence of h"),
            ),
            forms=("default", "power"),
            forms_with_own_law=("power",),
        ),
        Effect(
            name="warm_surroundings",
            title="Surroundings warmed by the wire",
            description=(
                "The wire does not convect to an infinite room at the ambient temperature: the "
                "air around it, the clamps, the sleigh and the housing take up part of its heat "
                "and warm (most after long heating at high power), then relax to the ambient "
                "over tens of seconds. The wire then cools more slowly after a long contraction "
                "than after a short one (§5.4, §5.8). The temperature the wire convects to obeys "
                "dT_s/dt = gain_k_j * P_conv - (T_s - T_amb) / time_constant_s."
            ),
            source="§5.4, §5.8",
            parameters=(
                _p("gain_k_j", "K/J", 0.0, 0.0, 1.0, 0.1, "warming of the surroundings per joule the wire convects"),
                _p(
                    "time_constant_s", "s", 30.0, 2.0, 300.0, 20.0, "time the surroundings take to relax to the ambient"
                ),
            ),
            forms=("default", "electrical"),
        ),
        Effect(
            name="coulomb_friction",
            title="Coulomb friction",
            description=(
                "Dry friction in the guide or the etched 'bones' of the MigaOne (§3.2): a force "
                "of constant magnitude opposing motion, and sticking below it."
            ),
            source="§3.2",
            parameters=(_p("force_n", "N", 0.0, 0.0, 3.0, 0.6, "kinetic friction force"),),
            forms=("default", "stribeck"),
        ),
        Effect(
            name="sensor_lag",
            title="Position-sensor lag",
            description=(
                "The position reading lags the true position more than the nominal filter "
                "says: a slower filter, a compliant sensor coupling (§3.1, §3.4)."
            ),
            source="§3.1",
            parameters=(_p("time_constant_s", "s", 0.0, 0.0, 0.5, 0.05, "time constant of the extra lag"),),
            forms=("default", "second-order"),
            outputs=("position",),
        ),
        Effect(
            name="abbe_offset",
            title="Sensor (Abbe) offset",
            description=(
                "The position sensor is off the line of motion; the actuator rotates when the "
                "direction of motion changes, so the reading steps by offset_m between "
                "contraction and extension (§3.2, Abbe's principle). It grows with wear."
            ),
            source="§3.2",
            parameters=(
                _p("offset_m", "m", 0.0, -2e-3, 2e-3, 0.3e-3, "step of the reading between contracting and extending"),
            ),
            forms=("default", "wear"),
            outputs=("position",),
        ),
        Effect(
            name="supply_sag",
            title="Supply-voltage sag",
            description=(
                "The supply sags under load: a series resistance (source, wiring, MOSFET) "
                "between the ideal supply and the wire, so the wire sees less than the nominal "
                "voltage (§7.2)."
            ),
            source="§7.2",
            parameters=(_p("series_resistance_ohm", "ohm", 0.0, 0.0, 10.0, 1.0, "series resistance"),),
            forms=("default", "quadratic"),
        ),
        Effect(
            name="pulse_settling",
            title="Electrical settling of each PWM pulse",
            description=(
                "Voltage and current need time to settle after every switch-on (§4.1, fig. 4.1: "
                "about 50 us). If the power settles too, each pulse delivers less energy than "
                "V^2/R times its width: a dead zone at small duty and slower response at high "
                "multiplexing frequencies (§9.2). Current rises as 1 - exp(-t/tau)."
            ),
            source="§4.1, §9.2",
            parameters=(_p("rise_time_constant_s", "s", 0.0, 0.0, 60e-6, 12e-6, "time constant of the current rise"),),
            forms=("default", "delay"),
        ),
    )
}


def effect_names() -> tuple[str, ...]:
    """Names of every effect in the library."""
    return tuple(EFFECTS)


def get_effect(name: str) -> Effect:
    try:
        return EFFECTS[name]
    except KeyError:
        raise ValueError(f"effect = {name!r}: expected one of {', '.join(map(repr, EFFECTS))}") from None


class ReadOnlyValues(dict):
    """An effect setting's checked values: a dict (JSON, ``dataclasses.asdict``, pickle and
    copies take it as one) that refuses to change."""

    def _refuse(self, *args: Any, **kwargs: Any) -> None:
        raise TypeError("an effect's values are read-only: make another setting (ModelConfig.with_effect)")

    __setitem__ = __delitem__ = __ior__ = clear = pop = popitem = setdefault = update = _refuse  # type: ignore[assignment]

    def __reduce__(self) -> tuple[Any, ...]:
        return (ReadOnlyValues, (dict(self),))


@dataclass(frozen=True)
class EffectSetting:
    """An effect switched on with parameter values (and optionally a non-default form)."""

    name: str
    values: Mapping[str, float]
    form: str = "default"

    def __post_init__(self) -> None:
        effect = get_effect(self.name)
        if self.form not in effect.forms:
            raise ValueError(f"effect {self.name!r} form = {self.form!r}: expected one of {effect.forms}")
        clean: dict[str, float] = dict(effect.off_values)
        for key, value in dict(self.values).items():
            spec = effect.parameter(key)
            number = require_finite(f"{self.name}.{key}", value, spec.unit)
            if number < spec.lower or number > spec.upper:
                raise ValueError(
                    f"{self.name}.{key} = {value!r}: expected a value in [{spec.lower:g}, {spec.upper:g}] ({spec.unit})"
                )
            clean[key] = number
        # Read-only: the checked values could be changed afterwards (a NaN force simulated).
        object.__setattr__(self, "values", ReadOnlyValues(clean))

    @property
    def is_off(self) -> bool:
        """True when the model is the one without the effect: every parameter at its off
        value, in a form that is inert there (:attr:`Effect.forms_with_own_law` are not: the
        model's name hid a latent heat released at 0.7x that moved the wire by 1 mm)."""
        effect = get_effect(self.name)
        if self.form in effect.forms_with_own_law:
            return False
        return all(self.values[p.name] == p.off for p in effect.parameters)

    def to_dict(self) -> dict[str, Any]:
        return {"parameters": dict(self.values), "form": self.form}


@dataclass(frozen=True)
class EffectSet:
    """A set of effects switched on. Empty = the report's model."""

    settings: tuple[EffectSetting, ...] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        names = [s.name for s in self.settings]
        if len(set(names)) != len(names):
            raise ValueError(f"effects = {names!r}: each effect may appear once")

    @classmethod
    def of(cls, spec: EffectSet | Mapping[str, Any] | Iterable[EffectSetting] | None) -> EffectSet:
        """Build from an ``EffectSet``, a ``{name: {param: value}}`` mapping, settings, or None.

        A mapping value may also be ``{"parameters": {...}, "form": "..."}``.
        """
        if spec is None:
            return cls()
        if isinstance(spec, EffectSet):
            return spec
        if isinstance(spec, Mapping):
            settings = []
            for name, value in spec.items():
                if isinstance(value, EffectSetting):
                    if value.name != name:  # the key was silently ignored
                        raise ValueError(f"effects[{name!r}] = a setting of {value.name!r}: expected one of {name!r}")
                    settings.append(value)
                    continue
                if not isinstance(value, Mapping):
                    raise ValueError(f"effects[{name!r}] = {value!r}: expected a mapping of parameter values")
                if "parameters" in value or "form" in value:
                    unknown = set(value) - {"parameters", "form"}
                    if unknown:
                        raise ValueError(
                            f"effects[{name!r}]: unknown key(s) {sorted(unknown)} beside 'parameters'/'form'; expected "
                            f"{{'parameters': {{{', '.join(f'{k!r}: ...' for k in sorted(unknown))}}}, 'form': ...}} "
                            "(a flat mapping of parameter values takes no 'form')"
                        )
                    parameters = value.get("parameters", {})
                    if not isinstance(parameters, Mapping):
                        raise ValueError(
                            f"effects[{name!r}]['parameters'] = {parameters!r}: expected a mapping of parameter "
                            "names to values"
                        )
                    settings.append(EffectSetting(name, dict(parameters), value.get("form", "default")))
                else:
                    settings.append(EffectSetting(name, dict(value)))
            return cls(tuple(settings))
        if isinstance(spec, (str, bytes)) or not isinstance(spec, Iterable):
            raise ValueError(f"effects = {spec!r}: expected a mapping {{name: {{parameter: value}}}} or EffectSettings")
        settings = tuple(spec)
        for setting in settings:
            if not isinstance(setting, EffectSetting):  # ['latent_heat'] failed with an AttributeError
                raise ValueError(
                    f"effects = {spec!r}: {setting!r} is no EffectSetting; expected a mapping "
                    "{name: {parameter: value}} or EffectSetting(name, values, form) items"
                )
        return cls(settings)

    def get(self, name: str) -> EffectSetting | None:
        for s in self.settings:
            if s.name == name:
                return s
        return None

    def value(self, effect: str, parameter: str) -> float:
        setting = self.get(effect)
        if setting is None:
            return get_effect(effect).parameter(parameter).off
        return setting.values[parameter]

    def form(self, effect: str) -> str:
        setting = self.get(effect)
        return "default" if setting is None else setting.form

    def with_setting(self, setting: EffectSetting) -> EffectSet:
        rest = tuple(s for s in self.settings if s.name != setting.name)
        return EffectSet(rest + (setting,))

    def active(self) -> tuple[EffectSetting, ...]:
        return tuple(s for s in self.settings if not s.is_off)

    def to_dict(self) -> dict[str, Any]:
        return {s.name: s.to_dict() for s in self.settings}

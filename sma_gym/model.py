"""A model configuration: actuator parameters plus the effects switched on.

This is what the diagnosis workflow writes after it has added a missing effect, and what
every env accepts at ``gymnasium.make(..., model=...)``: a preset or twin name
(:mod:`sma_gym.models`), a path to a JSON
file written by :meth:`ModelConfig.save`, a :class:`ModelConfig`, or bare
:class:`~sma_gym.params.ActuatorParams`.

File format (JSON)::

    {
      "format": "sma-gym-model",
      "version": 1,
      "actuator": { "wire": {...}, "mechanism": {...}, "convection": {...},
                    "driver": {...}, "sensors": {...}, "name": "...", "description": "..." },
      "effects": { "latent_heat": {"parameters": {"change_j_kg": -8000.0}, "form": "default"} },
      "notes": "free text, e.g. how the model was obtained"
    }
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from sma_gym._io import read_json_object, write_json
from sma_gym.effects import EffectSet, EffectSetting, get_effect
from sma_gym.models import twin_names, twin_path
from sma_gym.params import ActuatorParams, preset, preset_names

FORMAT_NAME = "sma-gym-model"
FORMAT_VERSION = 1
FILE_KEYS = ("format", "version", "actuator", "effects", "notes")
"""The top-level keys of a model file (:meth:`ModelConfig.to_dict`); any other is refused."""


@dataclass(frozen=True)
class ModelConfig:
    """Actuator parameters and the effects switched on."""

    actuator: ActuatorParams = field(default_factory=ActuatorParams)
    effects: EffectSet = field(default_factory=EffectSet)
    notes: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.actuator, ActuatorParams):
            raise ValueError(f"ModelConfig.actuator = {self.actuator!r}: expected ActuatorParams")
        if not isinstance(self.notes, str):  # saved, it made a file load_model refused
            raise ValueError(f"ModelConfig.notes = {self.notes!r}: expected a string")
        object.__setattr__(self, "effects", EffectSet.of(self.effects))

    @property
    def name(self) -> str:
        active = [s.name for s in self.effects.active()]
        return self.actuator.name + ("+" + "+".join(active) if active else "")

    def with_effect(self, name: str, values: Mapping[str, float], form: str | None = None) -> ModelConfig:
        """Copy with one effect set. ``values`` update the model's own setting of the effect
        where it has one (a partial mapping changes only the parameters it names; it reset
        the others to their off values, e.g. a fitted time constant), and start from the off
        values where it has none; ``form`` replaces the effect's form (``None``: its form in
        the model, else ``"default"``). An empty mapping is refused, as in a model file: it
        set nothing and read as the effect switched on."""
        if not isinstance(values, Mapping):
            raise ValueError(f"with_effect({name!r}, {values!r}): expected a mapping of parameter names to values")
        if not values:
            names = [p.name for p in get_effect(name).parameters]
            raise ValueError(f"with_effect({name!r}, {{}}): no parameter value given; expected some of {names}")
        current = self.effects.get(name)
        merged = {**(current.values if current is not None else {}), **values}
        form = form if form is not None else (current.form if current is not None else "default")
        return replace(self, effects=self.effects.with_setting(EffectSetting(name, merged, form)))

    def with_actuator(self, **changes: Any) -> ModelConfig:
        """Copy with actuator fields changed (``"driver.supply_voltage_v": 15.0``, ...)."""
        return replace(self, actuator=self.actuator.with_changes(**changes))

    def to_dict(self) -> dict[str, Any]:
        actuator = self.actuator.to_dict()
        _encode_inf(actuator)
        return {
            "format": FORMAT_NAME,
            "version": FORMAT_VERSION,
            "actuator": actuator,
            "effects": self.effects.to_dict(),
            "notes": self.notes,
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], *, source: str = "model configuration") -> ModelConfig:
        if not isinstance(data, Mapping):
            raise ValueError(f"{source}: expected a JSON object, got {type(data).__name__}")
        if data.get("format") != FORMAT_NAME:
            # A measured file's sidecar given as a model said only this (a new user's trial).
            hint = (
                " (a model file written by ModelConfig.save or sma-gym diagnose starts with it; a measured file's "
                "sidecar of conditions is not a model)"
                if "format" not in data
                else ""
            )
            raise ValueError(f"{source}: 'format' = {data.get('format')!r}: expected {FORMAT_NAME!r}{hint}")
        if data.get("version") != FORMAT_VERSION or isinstance(data.get("version"), bool):  # true == 1
            raise ValueError(f"{source}: 'version' = {data.get('version')!r}: expected {FORMAT_VERSION}")
        unknown = sorted(set(data) - set(FILE_KEYS))
        if unknown:
            # A misspelt "effects" would otherwise load the model without its effects.
            raise ValueError(f"{source}: unknown key(s) {unknown}: expected only {list(FILE_KEYS)}")
        notes = data.get("notes", "")
        if not isinstance(notes, str):
            raise ValueError(f"{source}: 'notes' = {notes!r}: expected a string")
        for key in ("actuator", "effects"):
            if not isinstance(data.get(key, {}), Mapping):
                kind = type(data[key]).__name__
                raise ValueError(f"{source}: {key!r} is a JSON {kind}: expected a JSON object {{name: {{...}}}}")
        try:
            for name, value in data.get("effects", {}).items():
                nested = isinstance(value, Mapping) and ("parameters" in value or "form" in value)
                given = value.get("parameters", {}) if nested else value
                if isinstance(given, Mapping) and not given:
                    # An effect listed with no values loaded as off: the file said "on", the model ran without it.
                    raise ValueError(
                        f"effect {name!r} gives no parameter values: expected its parameters "
                        f"{[p.name for p in get_effect(name).parameters]} (or leave the effect out)"
                    )
                missing = (
                    [p.name for p in get_effect(name).parameters if p.name not in given]
                    if isinstance(given, Mapping)
                    else []
                )
                if missing:
                    # As the actuator's fields: one left out took its off value, silently (a
                    # warm_surroundings without its gain loaded and ran as no effect at all).
                    raise ValueError(
                        f"effect {name!r} leaves out {missing}: expected every parameter of the effect "
                        f"{[p.name for p in get_effect(name).parameters]} (a model file gives every value)"
                    )
            actuator = ActuatorParams.from_dict(data.get("actuator", {}))
            effects = EffectSet.of(data.get("effects", {}))
        except (TypeError, ValueError) as err:
            raise ValueError(f"{source}: {err}") from None
        return cls(actuator=actuator, effects=effects, notes=notes)

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the configuration as JSON (see the module docstring)."""
        return write_json(path, self.to_dict())

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> ModelConfig:
        """Read a model file (``~`` is the home folder, as pandas reads it; a shell
        expands it, a Python string does not); any problem is a ``ValueError`` naming the
        file (see :mod:`sma_gym._io`)."""
        source = Path(path).expanduser()
        data = read_json_object(source, "model file")
        return cls.from_dict(data, source=f"model file {str(source)!r}")


ModelSpec = str | os.PathLike | ModelConfig | ActuatorParams | Mapping[str, Any] | None


def model_names() -> tuple[str, ...]:
    """Every name :func:`load_model` resolves: the actuator presets and the shipped twins."""
    return preset_names() + twin_names()


def load_model(spec: ModelSpec = None) -> ModelConfig:
    """Resolve a preset or twin name, a JSON file path, a dict, parameters or a config.

    A string is a preset's or twin's name where it is one, else a path; a ``pathlib.Path``
    (any ``os.PathLike``) is always a file, so a file named like a preset is read with one."""
    if spec is None:
        return ModelConfig()
    if isinstance(spec, ModelConfig):
        return spec
    if isinstance(spec, ActuatorParams):
        return ModelConfig(actuator=spec)
    if isinstance(spec, Mapping):
        if "format" not in spec and set(spec) == _ACTUATOR_KEYS:
            # ``dataclasses.asdict`` of ActuatorParams, as Gymnasium's EnvSpec.to_json writes
            # an env's ``model=ActuatorParams(...)``.
            return ModelConfig(actuator=ActuatorParams.from_dict(spec))
        return ModelConfig.from_dict(_from_dataclass_dict(spec))
    if isinstance(spec, os.PathLike):
        return ModelConfig.load(os.fspath(spec))  # a Path means a file (it read the preset of its name)
    if isinstance(spec, str):
        text = spec
        if text in preset_names():
            return ModelConfig(actuator=preset(text))
        if text in twin_names():
            return ModelConfig.load(twin_path(text))
        if text.endswith(".json") or os.path.sep in text or text.startswith("~") or os.path.exists(text):
            return ModelConfig.load(text)
        raise ValueError(
            f"model = {text!r}: expected a preset name ({', '.join(model_names())}) or a path to a model JSON file"
        )
    raise ValueError(f"model = {spec!r}: expected a preset name, a path, ModelConfig or ActuatorParams")


_ACTUATOR_KEYS = {f.name for f in fields(ActuatorParams)}


def _from_dataclass_dict(spec: Mapping[str, Any]) -> Mapping[str, Any]:
    """``dataclasses.asdict`` of a :class:`ModelConfig` in the file's layout: what Gymnasium's
    ``EnvSpec.to_json`` makes of an env's ``model=ModelConfig(...)`` (the env could not be
    made again from its JSON spec: "'format' = None"). Any other mapping as it is."""
    effects = spec.get("effects")
    if "format" in spec or set(spec) != {"actuator", "effects", "notes"} or not isinstance(effects, Mapping):
        return spec
    settings = effects.get("settings")
    if set(effects) != {"settings"} or not isinstance(settings, (list, tuple)):
        return spec
    if not all(isinstance(e, Mapping) and set(e) == {"name", "values", "form"} for e in settings):
        return spec
    return {
        **spec,
        "format": FORMAT_NAME,
        "version": FORMAT_VERSION,
        "effects": {e["name"]: {"parameters": e["values"], "form": e["form"]} for e in settings},
    }


def _encode_inf(tree: Any) -> None:
    if isinstance(tree, dict):
        for key, value in tree.items():
            if isinstance(value, float) and math.isinf(value):
                tree[key] = "inf"
            else:
                _encode_inf(value)

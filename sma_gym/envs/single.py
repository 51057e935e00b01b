"""Single-actuator environments: ``SMATracking-v0``, ``SMASelfSensing-v0``, ``SMARobust-v0``.

Each id has its own class (:class:`SMATrackingEnv`, :class:`SMASelfSensingEnv`,
:class:`SMARobustEnv`) whose docstring is its contract in Gymnasium's sections. They share
:class:`SMAEnv`, configured by a :class:`Variant`, and the validated :class:`Settings`
that the native vector env (:mod:`sma_gym.envs.vector`) uses too.
"""

from __future__ import annotations

import inspect
import json
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from sma_gym._validation import require_choice, require_options, require_range, require_scalar_action
from sma_gym.envs import ImportableSpec, docs, task
from sma_gym.envs import references as refs
from sma_gym.envs.conditions import (
    CONDITION_INFO,
    CONDITION_KWARGS,
    Conditions,
    condition_info,
    require_no_silent_override,
)
from sma_gym.envs.render import EpisodeRendering
from sma_gym.envs.task import (
    DEFAULT_CONTROL_PERIOD_S,
    DEFAULT_ENERGY_WEIGHT,
    DEFAULT_OVERHEAT_C,
    DEFAULT_PWM_MODE,
    DEFAULT_REFERENCE,
    UnstartedEnvs,
)
from sma_gym.model import ModelConfig, ModelSpec, load_model, model_names
from sma_gym.simulator import PWM_MODES, Simulator

_ONE_ACTUATOR = np.zeros(1, dtype=np.int64)

ReferenceSpec = str | dict | tuple[str, ...] | list[str]
Range = float | tuple[float, float]


@dataclass(frozen=True)
class Variant:
    """What distinguishes the single-actuator envs."""

    name: str
    observation: int
    """Observation set: :data:`~sma_gym.envs.task.OBS_POSITION` or ``OBS_SELF_SENSING``."""
    duty_range: task.DutyRange
    randomised: bool = False
    default_model: str = "standard"


TRACKING = Variant("tracking", task.OBS_POSITION, task.DutyRange(0.0, 1.0))
# The report's self-sensing experiments ran with a fan (§4.2): with the minimum duty that
# keeps R readable, natural convection cannot cool the wire back down at 10 V (§4.1).
SELF_SENSING = Variant(
    "self-sensing", task.OBS_SELF_SENSING, task.DutyRange(0.05, 0.8), default_model="forced-convection"
)
ROBUST = Variant("robust", task.OBS_POSITION, task.DutyRange(0.0, 1.0), randomised=True)


class UnexpectedKwargError(TypeError, ValueError):
    """An env kwarg the env does not take. A ``TypeError``, as Python raises for an unexpected
    keyword, with Python's wording, because tools probe an env's constructor that way (TorchRL's
    ``GymEnv`` passes ``frameskip`` and drops it on that ``TypeError``); and a ``ValueError``, as
    every other bad kwarg here and as this package raised before."""


def reject_unknown(unknown: dict[str, Any], accepted: tuple[str, ...]) -> None:
    """Raise :class:`UnexpectedKwargError` for env kwargs that are not in the env's signature."""
    if not unknown:
        return
    name = min(unknown)
    if name in CONDITION_KWARGS:
        field = {"supply_voltage_v": "driver.supply_voltage_v", "wire_diameter_m": "wire.diameter_m"}.get(name)
        own = f", or sma_gym.load_model().with_actuator(**{{{field!r}: ...}})" if field else ""
        raise UnexpectedKwargError(
            f"{name} = {unknown[name]!r}: only the robustness env takes conditions; here the model carries them: "
            f"model= one of {', '.join(repr(m) for m in model_names())}, a model JSON file{own}"
        )
    if name == "pwm_mode":
        raise UnexpectedKwargError("pwm_mode: the multiplexed env is always PWM-resolved")
    if name == "autoreset_mode":
        # make_vec passes its keywords to each sub-env in the "sync" and "async" modes.
        raise UnexpectedKwargError(
            f"autoreset_mode = {unknown[name]!r} is a vector env's setting, not an env's: with "
            "vectorization_mode='sync' or 'async' give it as vector_kwargs={'autoreset_mode': ...}; "
            "the native vector env (vectorization_mode='vector_entry_point') takes it directly"
        )
    raise UnexpectedKwargError(
        f"got an unexpected keyword argument {name!r}: unknown env kwargs {sorted(unknown)}, expected some of "
        f"{list(accepted)}"
    )


def keyword_settings(init: Callable[..., Any], exclude: tuple[str, ...] = ()) -> dict[str, inspect.Parameter]:
    """The keyword-only settings of an env constructor (names, defaults, annotations), by name.

    Their one definition is the signature of :class:`SMAEnv` (and, adding the conditions,
    :class:`SMARobustEnv`); the other envs take them as ``**settings`` (:func:`with_settings`)
    and show them in their signatures (:func:`spell_out_settings`), so a setting added there
    reaches every env.
    """
    params = inspect.signature(init).parameters.values()
    return {p.name: p for p in params if p.kind is inspect.Parameter.KEYWORD_ONLY and p.name not in exclude}


def with_settings(
    arguments: dict[str, Any], shared: dict[str, inspect.Parameter], given: dict[str, Any]
) -> dict[str, Any]:
    """For :meth:`Settings.from_arguments`: the constructor's own ``arguments`` (its
    ``locals()``), each ``shared`` setting as ``given`` or its default, and what is left of
    ``given`` as ``unknown``."""
    rest = dict(given)
    own = {k: v for k, v in arguments.items() if k not in ("self", "__class__", "settings")}
    return {**own, **{name: rest.pop(name, p.default) for name, p in shared.items()}, "unknown": rest}


def spell_out_settings(init: Callable[..., Any], shared: dict[str, inspect.Parameter]) -> None:
    """Show ``shared`` in ``init``'s signature in place of its ``**settings`` (for
    ``help()``, IDEs and :func:`inspect.signature`)."""
    own = [p for p in inspect.signature(init).parameters.values() if p.kind is not inspect.Parameter.VAR_KEYWORD]
    init.__signature__ = inspect.Signature([*own, *shared.values()])  # type: ignore[attr-defined]


@dataclass(frozen=True)
class Settings:
    """Validated env kwargs shared by the single envs, the multiplexed env and the vector env."""

    model: ModelConfig
    control_period_s: float
    reference: tuple[Any, ...]
    energy_weight: float
    overheat_limit_c: float
    pwm_mode: str
    conditions: Conditions | None

    @classmethod
    def from_arguments(cls, variant: Variant, arguments: dict[str, Any], **fixed: Any) -> Settings:
        """Validate an env's keyword arguments; each error names the value and what was expected.

        ``arguments`` is ``dict(locals())`` at the top of the env's ``__init__``: every
        parameter of its signature (where the defaults are), and ``unknown`` for names not
        in it, which raise :class:`UnexpectedKwargError` (a ``ValueError``). ``fixed`` sets what the env does not let the user
        choose (the multiplexed env's ``pwm_mode``). The condition kwargs (``None``: the
        default of :class:`Conditions`) are accepted by a randomised variant only.
        """
        # ``variant`` is the vector env's, set by its registered entry point, not a user's choice.
        accepted = tuple(name for name in arguments if name not in ("self", "unknown", "__class__", "variant"))
        if not variant.randomised:
            # In the signature (shared by every variant) but refused here: not worth listing.
            accepted = tuple(name for name in accepted if name not in CONDITION_KWARGS)
        reject_unknown(arguments.get("unknown", {}), accepted)
        a = {**arguments, **fixed}
        m = load_model(variant.default_model if a["model"] is None else a["model"])
        changes = {}
        if a["position_noise_std_m"] is not None:
            changes["sensors.position_noise_std_m"] = require_range(
                "position_noise_std_m", a["position_noise_std_m"], 0.0, 1e-3, "m"
            )
        if a["resistance_noise_std_ohm"] is not None:
            changes["sensors.resistance_noise_std_ohm"] = require_range(
                "resistance_noise_std_ohm", a["resistance_noise_std_ohm"], 0.0, 1.0, "ohm"
            )
        if changes:
            m = m.with_actuator(**changes)
        reference = a["reference"]
        if isinstance(reference, (str, dict)):
            names = (reference,)
        elif isinstance(reference, (list, tuple)):
            names = tuple(reference)
        else:
            raise ValueError(
                f"reference = {reference!r}: expected a reference name ({', '.join(refs.NAMED)}), a reference "
                "dict, or a list of them"
            )
        if not names:
            raise ValueError("reference = (): expected at least one reference name")
        for name in names:
            if not isinstance(name, dict):
                require_choice("reference", name, refs.NAMED)
        given = {key: a[key] for key in CONDITION_KWARGS if a.get(key) is not None}
        if not variant.randomised:
            reject_unknown(given, accepted)
        elif a["model"] is not None:
            require_no_silent_override(m, load_model(variant.default_model), set(given), a["model"])
        settings = cls(
            model=m,
            control_period_s=require_range("control_period_s", a["control_period_s"], 1e-4, 0.1, "s"),
            reference=names,
            energy_weight=require_range("energy_weight", a["energy_weight"], 0.0, 10.0),
            overheat_limit_c=require_range("overheat_limit_c", a["overheat_limit_c"], 40.0, 500.0, "degC"),
            pwm_mode=require_choice("pwm_mode", a["pwm_mode"], PWM_MODES),
            conditions=Conditions.from_kwargs(**given) if variant.randomised else None,
        )
        # Every wire an episode can get: the model, and every corner of the conditions' ranges
        # (after the model, so that what no condition causes is named plainly).
        require_usable(m, variant, names, settings.overheat_limit_c)
        if settings.conditions is not None:
            # 30-50 ms for the 256 corners of the default ranges: once per configuration.
            key = json.dumps(
                [m.to_dict(), names, asdict(settings.conditions), variant.name, settings.overheat_limit_c],
                sort_keys=True,
                default=repr,
            )
            if key not in _USABLE_CONDITIONS:
                settings.conditions.check(
                    m, lambda drawn: require_usable(drawn, variant, names, settings.overheat_limit_c)
                )
                _USABLE_CONDITIONS[key] = None
                if len(_USABLE_CONDITIONS) > 256:
                    del _USABLE_CONDITIONS[next(iter(_USABLE_CONDITIONS))]
        return settings

    def task_state(self, n: int, observation: int) -> task.TaskState:
        """Task data for n actuators with these settings."""
        return task.TaskState(n, observation, self.energy_weight, self.overheat_limit_c)


def draw_actuator(
    sim: Simulator, i: int, rng: np.random.Generator, settings: Settings, options: dict | None
) -> tuple[ModelConfig | None, dict[str, Any] | None, refs.Reference]:
    """Phase one of resetting actuator i: check ``options`` and draw its condition (robust;
    else ``None`` for both) and reference from ``rng``. Changes nothing else; refused, it
    leaves ``rng`` as it found it, so a bad option leaves the episode running as it was
    (Gymnasium's ``TimeLimit`` wrapper of ``gym.make`` restarts its step count before the
    env's reset runs, which no env can undo).

    A single env and the vector env reset an actuator only through this and
    :func:`start_actuator` (the vector env draws for every sub-env before it starts any),
    so that the same seed gives the same episode in both."""
    options = require_options(options)
    unknown = set(options) - {"reference"}
    if unknown:
        raise ValueError(f"reset options {sorted(unknown)}: expected only 'reference'")
    before = rng.bit_generator.state
    try:
        model = condition = None
        stroke_m = float(sim.usable_stroke_m[i])
        if settings.conditions is not None:
            model, condition = settings.conditions.draw(settings.model, rng)
            stroke_m = model.actuator.usable_stroke_m  # what set_model gives the simulator
        reference = refs.resolve(options.get("reference"), rng, stroke_m, settings.reference)
    except Exception:
        rng.bit_generator.state = before
        raise
    return model, condition, reference


def start_actuator(
    sim: Simulator,
    state: task.TaskState,
    i: int,
    drawn: tuple[ModelConfig | None, dict[str, Any] | None, refs.Reference],
) -> dict[str, Any] | None:
    """Phase two: give actuator i what :func:`draw_actuator` drew and start its episode;
    returns the condition."""
    model, condition, reference = drawn
    if model is not None:
        sim.set_model(i, model)
    state.set_reference(i, reference)
    sim.reset(np.array([i]))
    state.reset_actuator(i, sim)
    return condition


def require_usable(model: ModelConfig, variant: Variant, reference: Sequence, overheat_limit_c: float) -> None:
    """Refuse a wire on which an env's episodes cannot run: a reference (a dict's fields, the
    report's fixed levels) beyond its stroke, an overheat limit it reaches before it moves
    (every episode would end before the wire moved), or, with the resistance observed, PWM
    pulses shorter than the settling at the env's smallest duty (no reading there)."""
    a = model.actuator
    for name in reference:
        refs.resolve(name, np.random.default_rng(0), a.usable_stroke_m, "step")
    start_c = a.highest_rest_temperature_c
    if overheat_limit_c <= start_c:
        raise ValueError(
            f"overheat_limit_c = {overheat_limit_c!r}: the wire of {a.name!r} starts to contract at "
            f"{start_c:.1f} degC (ActuatorParams.highest_rest_temperature_c), so every episode would end before the "
            "wire moved; expected a limit above it"
        )
    if variant.observation == task.OBS_SELF_SENSING and variant.duty_range.low < a.driver.min_readable_duty:
        raise ValueError(
            f"model {a.name!r}: Driver.pwm_frequency_hz = {a.driver.pwm_frequency_hz!r} and settling_time_s = "
            f"{a.driver.settling_time_s!r} need a duty of {a.driver.min_readable_duty:.3g} for a V/I reading "
            f"(Driver.min_readable_duty), above the env's smallest, {variant.duty_range.low:g}: the resistance could "
            f"not be read at every duty; expected pwm_frequency_hz at most "
            f"{variant.duty_range.low / a.driver.settling_time_s:g} Hz"
        )


_USABLE_CONDITIONS: dict[str, None] = {}
"""Configurations whose condition ranges passed :meth:`Conditions.check` (JSON keys, oldest
first): a vector env's sub-envs, and every ``gym.make`` of the same settings, check once."""


def _made_with(name: str, doc: str) -> property:
    """A setting of :class:`Settings` as a read-only attribute of the env: setting it raised
    nothing and changed nothing (``env.unwrapped.overheat_limit_c = 90``, SB3's ``set_attr``),
    as ``control_period_s`` did before it was guarded."""

    def get(self: MadeWith) -> Any:
        return getattr(self.settings, name)

    def refuse(self: MadeWith, value: Any) -> None:
        raise AttributeError(
            f"{name} = {value!r}: fixed when the env is made (it was checked against the model and the "
            f"references, and the simulator built with it); make another env: gym.make(id, {name}=...)"
        )

    return property(get, refuse, doc=doc)


class MadeWith:
    """An env's settings as made (:class:`Settings`), read-only except ``energy_weight``: the
    simulator and the spaces were built from them and they were checked together, so changing
    one afterwards would change nothing it does (or leave it unchecked)."""

    settings: Settings
    task: task.TaskState

    READ_ONLY: ClassVar[tuple[str, ...]] = ("control_period_s", "model", "reference", "overheat_limit_c", "pwm_mode")
    """The settings that cannot be changed after make (the vector envs' ``set_attr`` refuses them too)."""

    model = _made_with("model", "The model the env was made with (a robust env's nominal one).")
    reference = _made_with(
        "reference", "The ``reference`` kwarg as made (names or dicts); the episode's own: reference_description()."
    )
    overheat_limit_c = _made_with("overheat_limit_c", "Temperature that ends an episode [degC], fixed at make.")
    pwm_mode = _made_with("pwm_mode", "How the simulator applies the duty (``PWM_MODES``), fixed at make.")

    @property
    def energy_weight(self) -> float:
        """Weight of the electrical power in the reward [-]; may be set between episodes or
        steps (a reward curriculum), checked as the kwarg is, and acts from the next step."""
        return self.settings.energy_weight

    @energy_weight.setter
    def energy_weight(self, value: Any) -> None:
        weight = require_range("energy_weight", value, 0.0, 10.0)
        self.settings = replace(self.settings, energy_weight=weight)
        self.task.energy_weight = weight
        rebind = getattr(self, "_bind_task", None)  # envs that bind the step's outputs once
        if rebind is not None:
            rebind()

    @property
    def control_period_s(self) -> float:
        """Simulated seconds per step [s]: the ``control_period_s`` kwarg, fixed at make."""
        return self.settings.control_period_s

    @control_period_s.setter
    def control_period_s(self, value: Any) -> None:
        raise AttributeError(
            f"control_period_s = {value!r}: fixed when the env is made (its simulator steps "
            f"{self.settings.control_period_s!r} s); make another env: gym.make(id, control_period_s=...)"
        )


class SMAEnv(MadeWith, EpisodeRendering, ImportableSpec, gym.Env):
    """Base of the single-actuator envs (one per :class:`Variant`; see the subclasses).

    Besides the Gymnasium API: :meth:`reference_description`, ``condition`` (robustness:
    the drawn condition), ``position_scale_m``, ``resistance_scale_ohm``, ``duty_range``,
    ``control_period_s``, ``feature_names``, :meth:`duty_for`, :meth:`action_for`.
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 100}
    variant: ClassVar[Variant] = TRACKING

    def __init__(
        self,
        render_mode: str | None = None,
        *,
        model: ModelSpec = None,
        control_period_s: float = DEFAULT_CONTROL_PERIOD_S,
        reference: ReferenceSpec = DEFAULT_REFERENCE,
        energy_weight: float = DEFAULT_ENERGY_WEIGHT,
        overheat_limit_c: float = DEFAULT_OVERHEAT_C,
        pwm_mode: str = DEFAULT_PWM_MODE,
        position_noise_std_m: float | None = None,
        resistance_noise_std_ohm: float | None = None,
        **unknown: Any,
    ):
        self._setup(Settings.from_arguments(self.variant, locals()), render_mode)

    def _setup(self, settings: Settings, render_mode: str | None) -> None:
        variant = self.variant
        self.settings = settings
        self._init_rendering(render_mode, settings.control_period_s)
        self.sim = Simulator(settings.model, control_period_s=settings.control_period_s, pwm_mode=settings.pwm_mode)
        self.task = settings.task_state(1, variant.observation)
        low, high = task.bounds(variant.observation)
        self.observation_space = spaces.Box(low, high, dtype=np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32)
        self.feature_names = task.FEATURES[variant.observation]
        self.duty_range = variant.duty_range
        self._set_scales()
        self._unstarted = UnstartedEnvs(1, vector=False)
        self._warned_after_end = False
        self._duty = np.zeros((1, 1))
        self._obs = np.zeros((1, len(self.feature_names)), dtype=np.float32)
        self._reward = np.zeros(1)
        self._term = np.zeros(1, dtype=np.bool_)
        self._ref = np.zeros(1)
        self.condition: dict[str, Any] | None = None
        """The condition drawn at the last reset (robustness env), else ``None``."""
        self._condition_info: dict[str, float | bool] = {}
        self._bind_task()

    def _bind_task(self) -> None:
        """The step's outputs, bound once (again when ``energy_weight`` is set)."""
        self._evaluate = self.task.bind(self.sim, _ONE_ACTUATOR, self._obs, self._reward, self._term, self._ref)

    def _set_scales(self) -> None:
        self.position_scale_m = float(self.sim.usable_stroke_m[0])
        self.resistance_scale_ohm = float(self.sim.cold_resistance_ohm[0])

    # ------------------------------------------------------------------------------------
    def duty_for(self, action: float) -> float:
        """Duty applied for a (clipped) action in [-1, 1] (:meth:`DutyRange.duty_for`)."""
        return self.duty_range.duty_for(action)

    def action_for(self, duty: float) -> float:
        """Inverse of :meth:`duty_for` (for controllers that compute a duty)."""
        return self.duty_range.action_for(duty)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        kept = (self._np_random, self._np_random_seed, self.sim.rng)
        super().reset(seed=seed)
        self.sim.rng = self.np_random
        try:
            drawn = draw_actuator(self.sim, 0, self.np_random, self.settings, options)
        except Exception:
            # Refused: not even the seed is applied, so the running episode goes on as it was.
            self._np_random, self._np_random_seed, self.sim.rng = kept
            raise
        self.condition = start_actuator(self.sim, self.task, 0, drawn)
        if self.condition is not None:
            self._condition_info = condition_info(self.condition)
            self._set_scales()
        self._evaluate()
        self._warned_after_end = False
        self._unstarted.started()
        self._start_rendering()
        return self._obs[0].copy(), self._info()

    def reference_description(self) -> dict[str, Any]:
        """The episode's reference: ``kind``, ``name`` and its parameters (keys depend on the kind)."""
        return self.task.describe_references()[0]

    def step(self, action):
        self._unstarted.require_none()
        if self._term[0] and not self._warned_after_end:
            task.warn_step_after_termination()  # once per episode
            self._warned_after_end = True
        a = require_scalar_action(action)
        duty = self.duty_range.duty_for(a)
        self._duty[0, 0] = duty
        self.sim.step_unchecked(self._duty)
        self.task.last_duty[0] = duty
        self._evaluate()
        if self.render_mode is not None:
            self._rendered_step()
        return self._obs[0].copy(), float(self._reward[0]), bool(self._term[0]), False, self._info()

    def _info(self) -> dict[str, Any]:
        info = self.task.info_of(self.sim, 0, self._ref[0])
        info.update(self._condition_info)
        return info

    def _render_title(self) -> str:
        return f"{self.spec.id if self.spec else 'SMA'}: {self.settings.model.name}"


class SMATrackingEnv(SMAEnv):
    __doc__ = docs.env_doc(
        "One SMA wire actuator tracking a position reference (``SMATracking-v0``).",
        Description="""
            A Flexinol-type NiTi wire pulls against a bias spring (the report's MigaOne
            actuator: 0.3 mm wire, 10 V supply, 500 Hz PWM, natural convection). PWM current
            heats it, it transforms from martensite to austenite and contracts; convection
            cools it and the spring stretches it back through a 7-8 K hysteresis. The agent
            chooses the duty each control step so that the position follows a reference
            (steps, ramps, sines, smooth random profiles), seeing the measured position, the
            wire resistance, the reference with its rate and a preview, and its last duty.
            """,
        Action_Space=docs.join("`Box(-1, 1, (1,), float32)`; duty range [0, 1].", docs.ACTION),
        Observation_Space=docs.join(
            "`Box(low, high, (10,), float32)`, each feature scaled to order one and clipped:",
            task.feature_table(task.OBS_POSITION),
            """
            `stroke` is the usable stroke and `R_cold` the cold extended wire's resistance;
            they are attributes (`position_scale_m`, `resistance_scale_ohm`), as are
            `duty_range` and `control_period_s`, so a controller can turn the features back
            into SI units.
            """,
        ),
        Rewards=docs.REWARD,
        Starting_State=docs.START,
        Episode_End=docs.EPISODE_END,
        Info=docs.join(
            "The same keys at reset and at every step, each a Python `float`, `int` or `bool` "
            "(`json.dumps(info)` works):",
            docs.INFO_KEYS,
            "The episode's reference in full: `env.unwrapped.reference_description()`.",
        ),
        Arguments=docs.arguments(docs.RENDER_MODE, docs.ARGUMENTS, docs.PWM_MODE),
        Version_History=docs.VERSION_0_2,
    )

    variant = TRACKING


class SMASelfSensingEnv(SMAEnv):
    __doc__ = docs.env_doc(
        "The tracking task without a position sensor (``SMASelfSensing-v0``).",
        Description="""
            The tracking env's actuator and task, but the agent sees the wire's resistance,
            current and voltage (V/I readings) instead of its position: the report's
            self-sensing control (§4). The reward still uses the true position. The default
            model is `forced-convection`, the report's self-sensing setup (§4.2): with the
            minimum duty, natural convection at 10 V cannot cool the wire back down (§4.1).
            """,
        Action_Space=docs.join(
            """
            `Box(-1, 1, (1,), float32)`; duty range [0.05, 0.8], so that every PWM pulse
            outlasts the 50 us settling and R can always be read (report §4.1, T9), except
            while the driver's end-of-travel cut holds the power off and no current flows
            (`resistance_valid` is then 0 and the last reading is held).
            """,
            docs.ACTION,
        ),
        Observation_Space=docs.join(
            "`Box(low, high, (10,), float32)`, each feature scaled to order one and clipped "
            "(`I_cold`: the cold wire's current):",
            task.feature_table(task.OBS_SELF_SENSING),
        ),
        Rewards=docs.REWARD,
        Starting_State=docs.START,
        Episode_End=docs.EPISODE_END,
        Info=docs.join("As the tracking env:", docs.INFO_KEYS),
        Arguments=docs.arguments(docs.RENDER_MODE, docs.ARGUMENTS, docs.PWM_MODE),
        Version_History=docs.VERSION_0_2,
    )

    variant = SELF_SENSING


class SMARobustEnv(SMAEnv):
    __doc__ = docs.env_doc(
        "The tracking task under randomised operating conditions (``SMARobust-v0``).",
        Description="""
            The tracking env under the report's chapter-7 conditions (supply voltage,
            natural or forced convection, wire diameter) plus a parameter spread that stands
            for unit-to-unit and model uncertainty, all drawn at every reset (ranges and
            spread: :class:`~sma_gym.envs.conditions.Conditions`).
            """,
        Action_Space=docs.join("`Box(-1, 1, (1,), float32)`; duty range [0, 1].", docs.ACTION),
        Observation_Space=docs.join(
            "As the tracking env, scaled by this episode's actuator (its stroke and cold resistance):",
            task.feature_table(task.OBS_POSITION),
        ),
        Rewards=docs.REWARD,
        Starting_State=docs.join(
            docs.START,
            """
            The condition is drawn first, from the same generator (same seed, same
            condition); `env.unwrapped.condition` holds it as a dict.
            """,
        ),
        Episode_End=docs.EPISODE_END,
        Info=docs.join(
            "The tracking env's keys,", docs.INFO_KEYS, "and the drawn condition:", task.info_list(CONDITION_INFO)
        ),
        Arguments=docs.arguments(
            docs.RENDER_MODE,
            docs.ARGUMENTS,
            docs.PWM_MODE,
            """
            - `supply_voltage_v`, `wire_diameter_m`: a number fixes the condition, a
              `(low, high)` pair draws it uniformly; `convection`: `"natural"` (the
              model's own), `"forced"` (the model's times 2.5, the report's fan) or
              `"random"`; `spread` (0 to 3) scales the parameter spread (0: none).
              `None` (the default): the default of :class:`~sma_gym.envs.conditions.Conditions`.
              With a `model` whose supply, wire diameter or convection differs from the
              default model's, each of those kwargs must be given (the draws would
              change the model's own value unasked): `ValueError` otherwise, saying which.
            """,
        ),
        Version_History=docs.ROBUST_MODEL_CHECK + docs.VERSION_0_2,
    )

    variant = ROBUST

    def __init__(
        self,
        render_mode: str | None = None,
        *,
        supply_voltage_v: Range | None = None,
        convection: str | None = None,
        wire_diameter_m: Range | None = None,
        spread: float | None = None,
        **settings: Any,
    ):
        # The settings of SMAEnv (model, reference, ...): one definition, spelled out below.
        arguments = with_settings(locals(), SINGLE_SETTINGS, settings)
        self._setup(Settings.from_arguments(self.variant, arguments), render_mode)


SINGLE_SETTINGS = keyword_settings(SMAEnv.__init__)
"""The single envs' settings (``model``, ``control_period_s``, ``reference``, ...)."""

spell_out_settings(SMARobustEnv.__init__, SINGLE_SETTINGS)

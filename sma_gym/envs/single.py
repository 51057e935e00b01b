"""Single-actuator environments: position tracking, self-sensing, robustness.

All three are one class, :class:`SMAEnv`, configured by a :class:`Variant`:

* ``SMATracking-v0``: sees the measured position, the resistance, the reference (with rate
  and preview) and its last duty. Duty range [0, 1].
* ``SMASelfSensing-v0``: the same task without a position sensor: it sees resistance,
  current and voltage (V/I readings) but not the position; the duty is kept in [0.05, 0.8]
  so that every PWM pulse outlasts the 50 us settling and R can always be read (report
  §4.1, T9) — except while the driver's end-of-travel cut holds the power off, when no
  current flows (the ``resistance_valid`` feature is then 0 and the last reading is held).
  The reward still uses the true position. Default model: ``forced-convection``, the
  report's self-sensing setup (§4.2): with the minimum duty, natural convection at 10 V
  cannot cool the wire back down (§4.1).
* ``SMARobust-v0``: the tracking task under the report's chapter-7 conditions (supply 5-15 V,
  natural or forced convection, 0.2-0.5 mm wire) plus parameter spread, drawn at every reset
  from ``self.np_random`` and reported in ``info`` (``condition_*`` keys) and in full in
  ``env.unwrapped.condition``; kwargs fix any of them.

Action: ``Box(-1, 1, (1,), float32)``, mapped affinely onto the allowed duty range,
``duty = lo + (a + 1) / 2 * (hi - lo)``; values outside [-1, 1] are clipped, NaN or inf raise
``ValueError``. Each step advances the simulator by ``control_period_s`` (default 10 ms; the
report's controllers run at 1 kHz, pass ``control_period_s=0.001`` for that).

Observation, reward: see :mod:`sma_gym.envs.task`. ``terminated`` when the wire exceeds
``overheat_limit_c`` (150 degC by default: Flexinol's trained memory degrades when held much
hotter); episodes are truncated by ``max_episode_steps`` (registered: 1000 steps = 10 s).

``info`` (the same keys at reset and at every step, each a plain ``float``, ``int`` or
``bool``, so ``json.dumps(info)`` works and batched clients can stack it): the true state
(``position_m``, ``position_measured_m``, ``temperature_c``, ``martensite_fraction``,
``stress_pa``), ``reference_m``, ``reference_kind`` (0 step, 1 ramp, 2 sine, 3 random),
``power_w`` and ``electrical_energy_j`` (since reset), ``spring_force_n`` (what the
report's force transducer reads), ``duty``, ``resistance_valid``, ``time_s``; robustness
adds the drawn condition as ``condition_supply_voltage_v``, ``condition_forced_convection``
(bool), ``condition_wire_diameter_m``, ``condition_convection_scale``,
``condition_transformation_shift_k``, ``condition_strain_scale``,
``condition_preload_scale``, ``condition_resistivity_scale``. The full description of the
episode's reference (kind, name, parameters, waypoints: keys depend on the kind) is
``env.unwrapped.reference_description()``; the drawn condition as a dict is
``env.unwrapped.condition``.

Unknown kwargs raise ``ValueError``. ``env.spec.id`` is the module-qualified id
(``"sma_gym:SMATracking-v0"``), which ``gymnasium.make`` resolves in any process, also one
that has not imported ``sma_gym``.

The constants that define the observation are attributes, so a controller can turn the
features back into SI units: ``position_scale_m`` (the stroke), ``resistance_scale_ohm``
(the cold resistance), ``duty_range`` and ``control_period_s``.

Version history (ids stay ``-v0``: the dynamics and rewards are unchanged):

* 0.2: ``info`` is flat and JSON-serialisable: the nested ``info["reference"]`` (reset) and
  ``info["condition"]`` are gone (use ``reference_description()`` and ``condition``;
  ``reference_kind`` and ``condition_*`` carry their numbers), values are Python scalars
  instead of numpy ones; unknown kwargs raise ``ValueError`` instead of ``TypeError``;
  ``env.spec.id`` carries the ``sma_gym:`` prefix; ``render()`` no longer switches
  matplotlib's global backend.
* 0.1: first release.
"""

from __future__ import annotations

import inspect
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from sma_gym._validation import require_action, require_choice, require_range
from sma_gym.core import layout as L
from sma_gym.envs import ImportableSpec, task
from sma_gym.envs import references as refs
from sma_gym.envs.conditions import Conditions, condition_info
from sma_gym.envs.render import Renderer
from sma_gym.model import ModelConfig, ModelSpec, load_model
from sma_gym.simulator import PWM_MODES, Simulator

DEFAULT_CONTROL_PERIOD_S = 10e-3
DEFAULT_OVERHEAT_C = 150.0
_ALL_COLUMNS = np.zeros(1, dtype=np.int64)

STATE_INFO = (
    ("position_m", L.S_X),
    ("position_measured_m", L.S_POS_MEAS),
    ("temperature_c", L.S_T),
    ("martensite_fraction", L.S_XI),
    ("stress_pa", L.S_SIGMA),
    ("power_w", L.S_POWER),
    ("electrical_energy_j", L.S_E_ELECTRIC),
    ("spring_force_n", L.S_FORCE),
    ("duty", L.S_DUTY_CMD),
    ("time_s", L.S_TIME),
)
"""``info`` entries read straight from a simulator state row: (key, row)."""


@dataclass(frozen=True)
class Variant:
    """What distinguishes the single-actuator envs."""

    name: str
    observation: int
    duty_range: tuple[float, float]
    randomised: bool = False
    default_model: str = "standard"


TRACKING = Variant("tracking", task.TRACKING, (0.0, 1.0))
# The report's self-sensing experiments ran with a fan (§4.2): with the minimum duty that
# keeps R readable, natural convection cannot cool the wire back down at 10 V (§4.1).
SELF_SENSING = Variant("self-sensing", task.SELF_SENSING, (0.05, 0.8), default_model="forced-convection")
ROBUST = Variant("robust", task.TRACKING, (0.0, 1.0), randomised=True)


@dataclass(frozen=True)
class Settings:
    """Validated env kwargs shared by the single env and the vector env."""

    model: ModelConfig
    control_period_s: float
    reference: tuple[Any, ...]
    energy_weight: float
    overheat_limit_c: float
    pwm_mode: str
    conditions: Conditions | None

    @classmethod
    def from_kwargs(cls, variant: Variant, **kwargs: Any) -> "Settings":
        """Validate the env kwargs; an unknown name raises ``ValueError`` listing the known ones."""
        known = tuple(inspect.signature(cls._from_known).parameters)[1:]
        unknown = sorted(set(kwargs) - set(known))
        if unknown:
            raise ValueError(f"unknown env kwargs {unknown}: expected some of {list(known)}")
        return cls._from_known(variant, **kwargs)

    @classmethod
    def _from_known(
        cls,
        variant: Variant,
        model: ModelSpec = None,
        control_period_s: float = DEFAULT_CONTROL_PERIOD_S,
        reference: str | dict | tuple[str, ...] | list[str] = refs.TRAINING_KINDS,
        energy_weight: float = 0.0,
        overheat_limit_c: float = DEFAULT_OVERHEAT_C,
        pwm_mode: str = "averaged",
        position_noise_std_m: float | None = None,
        resistance_noise_std_ohm: float | None = None,
        supply_voltage_v: Any = (5.0, 15.0),
        convection: Any = "random",
        wire_diameter_m: Any = (0.2e-3, 0.5e-3),
        spread: Any = 1.0,
    ) -> "Settings":
        m = load_model(variant.default_model if model is None else model)
        changes = {}
        if position_noise_std_m is not None:
            changes["sensors.position_noise_std_m"] = require_range("position_noise_std_m", position_noise_std_m, 0.0, 1e-3, "m")
        if resistance_noise_std_ohm is not None:
            changes["sensors.resistance_noise_std_ohm"] = require_range(
                "resistance_noise_std_ohm", resistance_noise_std_ohm, 0.0, 1.0, "ohm"
            )
        if changes:
            m = m.with_actuator(**changes)
        names = (reference,) if isinstance(reference, (str, dict)) else tuple(reference)
        if not names:
            raise ValueError("reference = (): expected at least one reference name")
        for name in names:
            if isinstance(name, dict):
                # Validates every field, levels against the nominal model's stroke (reset
                # checks again against the actuator's own).
                refs.resolve(name, np.random.default_rng(0), task.stroke_of_actuator(m.actuator), "step")
            else:
                require_choice("reference", name, refs.NAMED)
        conditions = None
        if variant.randomised:
            conditions = Conditions.from_kwargs(supply_voltage_v, convection, wire_diameter_m, spread)
        else:
            defaults = {"supply_voltage_v": (5.0, 15.0), "convection": "random", "wire_diameter_m": (0.2e-3, 0.5e-3), "spread": 1.0}
            given = {"supply_voltage_v": supply_voltage_v, "convection": convection, "wire_diameter_m": wire_diameter_m, "spread": spread}
            for key, value in given.items():
                if value != defaults[key]:
                    raise ValueError(f"{key} = {value!r}: only the robustness env randomises conditions; use model= here")
        return cls(
            model=m,
            control_period_s=require_range("control_period_s", control_period_s, 1e-4, 0.1, "s"),
            reference=names,
            energy_weight=require_range("energy_weight", energy_weight, 0.0, 10.0),
            overheat_limit_c=require_range("overheat_limit_c", overheat_limit_c, 40.0, 500.0, "degC"),
            pwm_mode=require_choice("pwm_mode", pwm_mode, PWM_MODES),
            conditions=conditions,
        )


def reset_column(sim: Simulator, state: task.TaskState, i: int, rng: np.random.Generator, settings: Settings, options: dict | None) -> dict[str, Any] | None:
    """Reset actuator i: draw its condition (robust) and reference from ``rng``.

    The one place a single env and the vector env reset an actuator, so that the same seed
    gives the same episode in both. Returns the drawn condition (``None`` unless the
    variant randomises conditions); the reference is ``state.references[i]``.
    """
    options = {} if options is None else options
    unknown = set(options) - {"reference"}
    if unknown:
        raise ValueError(f"reset options {sorted(unknown)}: expected only 'reference'")
    condition = None
    if settings.conditions is not None:
        model, condition = settings.conditions.draw(settings.model, rng)
        sim.set_model(i, model)
    stroke = task.stroke_of(sim.params[i])
    ref = refs.resolve(options.get("reference"), rng, stroke, settings.reference)
    state.set_reference(i, ref)
    sim.reset(np.array([i]))
    state.reset_column(i, sim.params[i])
    return condition


class SMAEnv(ImportableSpec, gym.Env):
    """One SMA actuator tracking a position reference.

    Spaces, reward, episode end, ``info`` keys, kwargs and version history: see the module
    docstring. Besides the Gymnasium API: :meth:`reference_description`, ``condition``
    (robustness: the drawn condition), ``position_scale_m``, ``resistance_scale_ohm``,
    ``duty_range``, ``control_period_s``, :meth:`duty_for`, :meth:`action_for`.
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 100}

    def __init__(self, variant: Variant = TRACKING, render_mode: str | None = None, **kwargs: Any):
        self.variant = variant
        self.settings = Settings.from_kwargs(variant, **kwargs)
        self._renderer = Renderer(render_mode, self.metadata["render_modes"])
        self.render_mode = render_mode
        self.metadata = dict(self.metadata, render_fps=max(1, round(1.0 / self.settings.control_period_s)))
        self.sim = Simulator(
            self.settings.model, control_period_s=self.settings.control_period_s, pwm_mode=self.settings.pwm_mode
        )
        self.task = task.TaskState(1)
        low, high = task.bounds(variant.observation)
        self.observation_space = spaces.Box(low, high, dtype=np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32)
        self.feature_names = task.FEATURES[variant.observation]
        self.duty_range = variant.duty_range
        self.control_period_s = self.settings.control_period_s
        self._set_scales()
        lo, hi = variant.duty_range
        self._duty_lo = lo
        self._duty_half_range = 0.5 * (hi - lo)
        self._duty = np.zeros((1, 1))
        self._obs = np.zeros((1, len(self.feature_names)), dtype=np.float32)
        self._reward = np.zeros(1)
        self._term = np.zeros(1, dtype=np.bool_)
        self._ref = np.zeros(1)
        self.condition: dict[str, Any] | None = None
        """The condition drawn at the last reset (robustness env), else ``None``."""
        self._condition_info: dict[str, float | bool] = {}

    def _set_scales(self) -> None:
        params = self.sim.params[0]
        self.position_scale_m = task.stroke_of(params)
        self.resistance_scale_ohm = float(params[L.P_RHO_M] * params[L.P_LENGTH] / params[L.P_AREA])

    # ------------------------------------------------------------------------------------
    def duty_for(self, action: float) -> float:
        """Duty applied for a (clipped) action in [-1, 1]."""
        a = -1.0 if action < -1.0 else (1.0 if action > 1.0 else action)
        return self._duty_lo + (a + 1.0) * self._duty_half_range

    def action_for(self, duty: float) -> float:
        """Inverse of :meth:`duty_for` (for controllers that compute a duty)."""
        return (duty - self._duty_lo) / self._duty_half_range - 1.0

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self.sim.rng = self.np_random
        self.condition = reset_column(self.sim, self.task, 0, self.np_random, self.settings, options)
        if self.condition is not None:
            self._condition_info = condition_info(self.condition)
            self._set_scales()
        self._outputs()
        self._renderer.reset()
        self._record()
        return self._obs[0].copy(), self._info()

    def reference_description(self) -> dict[str, Any]:
        """The episode's reference: ``kind``, ``name`` and its parameters (keys depend on the kind)."""
        return self.task.references[0].describe()

    def step(self, action):
        a = float(require_action(action, 1)[0])
        duty = self.duty_for(a)
        self._duty[0, 0] = duty
        self.sim.step_unchecked(self._duty)
        self.task.last_duty[0] = duty
        self._outputs()
        self._record()
        if self.render_mode == "human":
            self.render()
        return self._obs[0].copy(), float(self._reward[0]), bool(self._term[0]), False, self._info()

    def _outputs(self) -> None:
        t = self.task
        s = self.settings
        task.task_outputs(
            self.sim.state, self.sim.params, self.variant.observation, t.kind, t.params, t.wp_t, t.wp_x, t.held,
            t.last_duty, s.energy_weight, s.overheat_limit_c, self._obs, self._reward, self._term, self._ref,
            _ALL_COLUMNS,
        )

    def _info(self) -> dict[str, Any]:
        st = self.sim.state[0]
        # Python scalars, not numpy ones: json.dumps and loggers refuse np.bool_.
        info: dict[str, Any] = {key: float(st[row]) for key, row in STATE_INFO}
        info["reference_m"] = float(self._ref[0])
        info["reference_kind"] = int(self.task.kind[0])
        info["resistance_valid"] = bool(st[L.S_R_MEAS] == st[L.S_R_MEAS])
        info.update(self._condition_info)
        return info

    # ------------------------------------------------------------------------------------
    def _record(self) -> None:
        if self.render_mode is None:
            return  # nothing is drawn: skip building the sample (it is on every step's path)
        st = self.sim.state[0]
        self._renderer.record(
            t=st[L.S_TIME],
            position=st[L.S_X],
            reference=self._ref[0],
            duty=st[L.S_DUTY_CMD],
            resistance=self.task.held[0, 0],
            temperature=st[L.S_T],
        )

    def render(self) -> np.ndarray | None:
        """``rgb_array``: the episode so far as a (640, 640, 3) uint8 frame; ``human``: show it."""
        return self._renderer.render(f"{self.spec.id if self.spec else 'SMA'}: {self.settings.model.name}")

    def close(self) -> None:
        self._renderer.close()

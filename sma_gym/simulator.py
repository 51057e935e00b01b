"""The simulator: n actuators advanced together in control steps.

>>> from sma_gym import Simulator
>>> sim = Simulator("standard", n=1)
>>> sim.step(1.0)                 # one 1 ms control step at full duty
>>> float(sim.position_m[0]) >= 0
True

Every user (envs, multiplexer, vector env, model fitting) goes through this class and the
single compiled core in :mod:`sma_gym.core.kernel`. State lives in ``state`` and parameters
in ``params`` (one row per actuator, fields in :mod:`sma_gym.core.layout`). The properties
below are named views of them, each an array over actuators with its unit in its name; they
always show the current values without copying. Code outside the simulator and the
compiled core reads these views (or :meth:`Simulator.read`), never the layout indices.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from operator import itemgetter
from typing import Any

import numpy as np

from sma_gym._validation import (
    require_choice,
    require_finite,
    require_float_array,
    require_int_range,
    require_range,
)
from sma_gym.core import layout as L
from sma_gym.core.kernel import advance
from sma_gym.electrical.multiplexer import Multiplexer
from sma_gym.electrical.pwm import RISE_FORMS, SAG_FORMS
from sma_gym.electrical.sensors import ABBE_FORMS, LAG_ORDERS
from sma_gym.model import ModelConfig, ModelSpec, load_model
from sma_gym.params import ActuatorParams
from sma_gym.physics.mechanics import FRICTION_FORMS
from sma_gym.physics.resistance import wire_resistance
from sma_gym.physics.thermal import CONVECTION_FORMS, LATENT_COOLING_FACTORS, SURROUNDINGS_FORMS

PWM_MODES = ("averaged", "resolved")

DEFAULT_MAX_TEMPERATURE_STEP_K = 0.5
"""Largest temperature change per integration sub-step (accuracy bound, see core.kernel)."""

DEFAULT_MAX_SUBSTEP_S = 10e-3

DEFAULT_MAX_POSITION_STEP_M = 10e-6
"""Largest position change per sub-step within 2 mm of the end-of-travel cut: resolves the
fast arrival and the stress transient of the stop (at 20 V the wire arrives at ~0.2 m/s),
which moves hysterons irreversibly."""

DEFAULT_MAX_TEMPERATURE_STEP_AT_CUT_K = 0.01
"""Largest temperature change per sub-step in the cut's switching band (from 0.1 mm below
the release point up to the cut) while the wire conducts, for a wire that heats at
:data:`BAND_REFERENCE_HEATING_RATE_K_S` or faster (see :func:`band_widening`); the general
bound applies if smaller, and while the cut holds the circuit open (the cooling wire's
release is timed by the position bound). A wire latched at the cut cools ~8 K while its
position falls by the 0.2 mm release, so a tenth of a micrometre of position moves the
release by ~0.06 ms, and at 20 V the wire re-heats at ~1000 K/s: the relay cycle stays in
phase with a fine reference only if each release is timed to a fraction of a millisecond.
Measured at 20 V on random duty sequences (``benchmarks/bench_integration.py --seeds 10``,
50 ms to 1 s blocks) against a 30 us reference: 0.34 mm / 7.9 K with the general bounds
alone, within 0.05 mm / 0.49 K on 30 of 30 with 0.01 K and 1 um."""

DEFAULT_MAX_POSITION_STEP_AT_CUT_M = 1e-6
"""Largest position change per sub-step in the cut's switching band, for a wire that heats
at :data:`BAND_REFERENCE_HEATING_RATE_K_S` or faster (see above and :func:`band_widening`)."""

BAND_REFERENCE_HEATING_RATE_K_S = 1000.0
"""[K/s]: full-power heating rate (:attr:`~sma_gym.params.ActuatorParams.full_power_heating_rate_k_s`)
at and above which the switching band's bounds apply as given (the report's wire at 20 V:
1015 K/s)."""

BAND_MAX_WIDENING = 4.0
"""Largest factor :func:`band_widening` applies to the switching band's bounds."""


def band_widening(actuator: ActuatorParams) -> float:
    """Factor on the switching band's bounds for an actuator: how many times slower than
    :data:`BAND_REFERENCE_HEATING_RATE_K_S` it heats at full power, between 1 and
    :data:`BAND_MAX_WIDENING`.

    The band's bounds time the relay cycle's release, and an error in that time costs
    temperature at the rate the wire re-heats: a wire heating 4x slower needs 4x less
    precision. Measured on the report's wire (``benchmarks/bench_integration.py --seeds
    10``): at 10 V (254 K/s, factor 3.9) 0.04 K and 4 um keep 30 of 30 random duty
    sequences within 0.018 mm / 0.10 K of the 30 us reference (the 20 V bounds: 0.023 mm /
    0.27 K), 0.1 K and 10 um only 25 of 30; envs driven by random actions, whose wires sit
    at the cut most of the time, run 1.2x instead of 0.8x Pendulum-v1
    (``benchmarks/bench_envs.py``). At 20 V the wider bounds lose 1 of 30 (1.2 K). Applied
    with the PWM averaged only (:func:`pack_params`).
    """
    rate = actuator.full_power_heating_rate_k_s
    return min(max(BAND_REFERENCE_HEATING_RATE_K_S / rate, 1.0), BAND_MAX_WIDENING)


_NO_NOISE = np.zeros((0, 4, 0))
_NO_RECORD = np.zeros((0, 0, 0))
_NO_FIELDS = np.zeros(0, dtype=np.int64)


def pack_params(
    model: ModelConfig,
    *,
    pwm_mode: str = "averaged",
    pwm_period_s: float | None = None,
    phase: float = 0.0,
    duty_max: float = 1.0,
    max_substep_s: float = DEFAULT_MAX_SUBSTEP_S,
    max_temperature_step_k: float = DEFAULT_MAX_TEMPERATURE_STEP_K,
    max_position_step_m: float = DEFAULT_MAX_POSITION_STEP_M,
    max_temperature_step_at_cut_k: float = DEFAULT_MAX_TEMPERATURE_STEP_AT_CUT_K,
    max_position_step_at_cut_m: float = DEFAULT_MAX_POSITION_STEP_AT_CUT_M,
) -> np.ndarray:
    """Turn a model configuration into one actuator's row of the core's parameter matrix."""
    require_choice("pwm_mode", pwm_mode, PWM_MODES)
    p = model.actuator
    w, m, c, d, s = p.wire, p.mechanism, p.convection, p.driver, p.sensors
    fx = model.effects
    row = np.zeros(L.N_PARAMS)

    row[L.P_AREA] = w.area_m2
    row[L.P_LENGTH] = w.length_m
    row[L.P_HEAT_CAP] = w.heat_capacity_j_k
    row[L.P_SPECIFIC_HEAT] = w.specific_heat_j_kg_k
    row[L.P_SURFACE] = w.surface_m2

    h_scale = c.scale_for(w.diameter_m)
    conv_scale = fx.value("convection_change", "scale")
    conv_form = fx.form("convection_change")
    row[L.P_CONV_FORM] = CONVECTION_FORMS[conv_form]
    if conv_form == "power":
        row[L.P_H0] = c.h0_w_m2_k * h_scale
        row[L.P_H2] = c.h2_w_m2_k3 * h_scale
        row[L.P_CONV_POWER_SCALE] = conv_scale
    else:
        row[L.P_H0] = conv_scale * c.h0_w_m2_k * h_scale
        row[L.P_H1] = conv_scale * fx.value("convection_change", "h1_w_m2_k2") * h_scale
        row[L.P_H2] = conv_scale * c.h2_w_m2_k3 * h_scale
        row[L.P_CONV_POWER_SCALE] = 1.0
    row[L.P_T_AMB] = c.ambient_temperature_c

    row[L.P_D_A] = w.youngs_modulus_austenite_pa
    row[L.P_D_M] = w.youngs_modulus_martensite_pa
    row[L.P_EPS0] = w.max_transformation_strain
    row[L.P_ALPHA_TH_A] = w.thermal_expansion_austenite_1_k
    row[L.P_ALPHA_TH_M] = w.thermal_expansion_martensite_1_k
    row[L.P_C_A] = w.stress_coefficient_austenite_pa_k
    row[L.P_C_M] = w.stress_coefficient_martensite_pa_k
    # Nominal latent heat plus the latent_heat effect's change (off = 0); in kelvin per unit xi.
    latent = max(0.0, w.latent_heat_j_kg + fx.value("latent_heat", "change_j_kg")) / w.specific_heat_j_kg_k
    row[L.P_LATENT] = latent
    row[L.P_LATENT_COOL] = latent * LATENT_COOLING_FACTORS[fx.form("latent_heat")]
    # The transformation_spread effect adds an independent spread: variances add.
    shift_h, shift_c, weights, widening_k = w.hysterons(
        fx.value("transformation_spread", "spread_k"),
        fx.form("transformation_spread"),
        fx.value("minor_loop_width", "min_width_share"),
        fx.form("minor_loop_width"),
    )
    # A spread wide for the branch range widens every branch (loop widths unchanged).
    row[L.P_A_S] = w.austenite_start_c - 0.5 * widening_k
    row[L.P_A_F] = w.austenite_finish_c + 0.5 * widening_k
    row[L.P_M_S] = w.martensite_start_c + 0.5 * widening_k
    row[L.P_M_F] = w.martensite_finish_c - 0.5 * widening_k
    row[L.P_N_NODES] = len(weights)
    for k, (sh, sc, wt) in enumerate(zip(shift_h, shift_c, weights)):
        row[L.P_NODE_HEAT0 + k] = sh
        row[L.P_NODE_COOL0 + k] = sc
        row[L.P_NODE_WEIGHT0 + k] = wt

    row[L.P_RHO_M] = w.resistivity_martensite_ohm_m
    row[L.P_RHO_A] = w.resistivity_austenite_ohm_m
    row[L.P_TCR_M] = w.resistivity_tcr_martensite_1_k
    row[L.P_TCR_A] = w.resistivity_tcr_austenite_1_k
    row[L.P_T_REF_R] = w.resistivity_reference_c

    row[L.P_MASS] = m.moving_mass_kg
    row[L.P_DAMPING] = m.damping_n_s_m
    row[L.P_K_SPRING] = m.spring_stiffness_n_m
    row[L.P_F_PRE] = m.spring_preload_n
    row[L.P_SIGMA0] = p.rest_stress_pa
    row[L.P_F_COULOMB] = fx.value("coulomb_friction", "force_n")
    row[L.P_SURR_GAIN] = fx.value("warm_surroundings", "gain_k_j")
    row[L.P_SURR_TAU] = fx.value("warm_surroundings", "time_constant_s")
    row[L.P_SURR_FORM] = SURROUNDINGS_FORMS[fx.form("warm_surroundings")]
    row[L.P_FRICTION_FORM] = FRICTION_FORMS[fx.form("coulomb_friction")]

    row[L.P_V_SUPPLY] = d.supply_voltage_v
    row[L.P_R_SERIES] = fx.value("supply_sag", "series_resistance_ohm")
    row[L.P_SAG_FORM] = SAG_FORMS[fx.form("supply_sag")]
    row[L.P_SAG_I_REF] = d.supply_voltage_v / w.cold_resistance_ohm
    period = 1.0 / d.pwm_frequency_hz if pwm_period_s is None else float(pwm_period_s)
    row[L.P_PWM_PERIOD] = period
    row[L.P_PWM_PHASE] = phase
    row[L.P_DUTY_MAX] = duty_max
    row[L.P_RESOLVED] = 1.0 if pwm_mode == "resolved" else 0.0
    row[L.P_T_SETTLE] = d.settling_time_s
    row[L.P_TAU_RISE] = fx.value("pulse_settling", "rise_time_constant_s")
    row[L.P_RISE_FORM] = RISE_FORMS[fx.form("pulse_settling")]
    row[L.P_EOT] = d.end_of_travel_m
    row[L.P_EOT_RELEASE] = d.end_of_travel_release_m

    fc = s.position_filter_cutoff_hz
    row[L.P_TAU_FILTER] = 1.0 / (2.0 * math.pi * fc) if fc > 0.0 else 0.0
    row[L.P_TAU_LAG] = fx.value("sensor_lag", "time_constant_s")
    row[L.P_LAG_ORDER] = LAG_ORDERS[fx.form("sensor_lag")]
    row[L.P_ABBE] = fx.value("abbe_offset", "offset_m")
    row[L.P_ABBE_FORM] = ABBE_FORMS[fx.form("abbe_offset")]
    row[L.P_POS_NOISE] = s.position_noise_std_m
    row[L.P_POS_RESOLUTION] = s.position_resolution_m
    row[L.P_R_NOISE] = s.resistance_noise_std_ohm
    row[L.P_I_NOISE] = s.current_noise_std_a
    row[L.P_V_NOISE] = s.voltage_noise_std_v

    row[L.P_H_MAX] = max_substep_s
    row[L.P_DT_MAX] = max_temperature_step_k
    row[L.P_DX_MAX] = max_position_step_m
    # PWM-resolved, the release's timing also picks the pulse in which the wire re-heats:
    # widened there, 16 of 30 sequences at 10 V stayed within the goal instead of 20.
    widening = band_widening(p) if pwm_mode == "averaged" else 1.0
    row[L.P_DT_BAND] = max_temperature_step_at_cut_k * widening
    row[L.P_DX_BAND] = max_position_step_at_cut_m * widening

    row[L.P_STROKE] = p.usable_stroke_m
    row[L.P_R_COLD] = w.cold_resistance_ohm
    return row


_DUTY_EXPECTED = "expected finite values (values outside [0, 1] are clipped to the duty range)"
"""What a non-finite duty is told: the only duty refused (out-of-range duty is clipped)."""


class Simulator:
    """n SMA actuators advanced together by control steps of ``control_period_s``.

    Parameters
    ----------
    model:
        A preset name, a model JSON path, a :class:`ModelConfig`, :class:`ActuatorParams`,
        or a sequence of these (one per actuator; then ``n`` may be omitted).
    n:
        Number of actuators when ``model`` is a single model.
    control_period_s:
        Length of one :meth:`step` (the report's control loop runs at 1 kHz).
    pwm_mode:
        ``"averaged"`` (fast, default) or ``"resolved"`` (pulse by pulse).
    multiplexer:
        A :class:`Multiplexer` sweeping one PWM over the actuators (requires n equal to its
        ``n_actuators``); implies per-actuator duty at most 1/n and phase-shifted slots.
    pwm_slots:
        The general form of the above: one ``(period_s, phase, duty_max)`` per actuator.
        Actuators on one multiplexer do not interact (only one conducts at a time), so one
        actuator with ``(1 / f_cycle, 0, 1 / n)`` simulates any actuator of an n-bank exactly;
        this lets experiments batch many banks into one run.
    seed, rng:
        Randomness for sensor noise (only drawn when a noise level is non-zero).
    max_substep_s, max_temperature_step_k, max_position_step_m:
        Accuracy bounds of the integration sub-step (see :mod:`sma_gym.core.kernel`):
        10 ms, 0.5 K and 10 um (within 2 mm of the end-of-travel cut) by default.
    max_temperature_step_at_cut_k, max_position_step_at_cut_m:
        The same bounds in the cut's switching band, from 0.1 mm below its release point up
        to the cut, where the relay cycle of cut and release must stay in phase: 0.01 K and
        1 um by default, for a wire that heats at 1000 K/s or faster at full power; with the
        PWM averaged a slower one gets them widened up to 4x (:func:`band_widening`). The
        smaller of these and the general bounds applies.
    """

    def __init__(
        self,
        model: ModelSpec | Sequence[ModelSpec] = None,
        n: int | None = None,
        *,
        control_period_s: float = 1e-3,
        pwm_mode: str = "averaged",
        multiplexer: Multiplexer | None = None,
        pwm_slots: Sequence[tuple[float, float, float]] | None = None,
        seed: int | None = None,
        rng: np.random.Generator | None = None,
        max_substep_s: float = DEFAULT_MAX_SUBSTEP_S,
        max_temperature_step_k: float = DEFAULT_MAX_TEMPERATURE_STEP_K,
        max_position_step_m: float = DEFAULT_MAX_POSITION_STEP_M,
        max_temperature_step_at_cut_k: float = DEFAULT_MAX_TEMPERATURE_STEP_AT_CUT_K,
        max_position_step_at_cut_m: float = DEFAULT_MAX_POSITION_STEP_AT_CUT_M,
    ) -> None:
        require_choice("pwm_mode", pwm_mode, PWM_MODES)
        self.control_period_s = require_range("control_period_s", control_period_s, 1e-6, 10.0, "s")
        require_range("max_substep_s", max_substep_s, 1e-7, 0.1, "s")
        require_range("max_temperature_step_k", max_temperature_step_k, 1e-4, 10.0, "K")
        require_range("max_position_step_m", max_position_step_m, 1e-8, 1e-2, "m")
        require_range("max_temperature_step_at_cut_k", max_temperature_step_at_cut_k, 1e-4, 10.0, "K")
        require_range("max_position_step_at_cut_m", max_position_step_at_cut_m, 1e-8, 1e-2, "m")
        if isinstance(model, (list, tuple)):
            models = [load_model(m) for m in model]
            if n is not None and n != len(models):
                raise ValueError(f"n = {n!r}: expected {len(models)} (one per model given)")
            if not models:
                raise ValueError("model = []: expected at least one model")
        else:
            count = 1 if n is None else n
            if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or not 1 <= count <= MAX_ACTUATORS:
                # (10**12 ended in a MemoryError naming nothing)
                raise ValueError(f"n = {n!r}: expected an integer in [1, {MAX_ACTUATORS}]")
            models = [load_model(model)] * int(count)
        self.models: list[ModelConfig] = list(models)
        self.n = len(models)
        self.pwm_mode = pwm_mode
        self.multiplexer = multiplexer
        if multiplexer is not None and multiplexer.n_actuators != self.n:
            raise ValueError(
                f"multiplexer.n_actuators = {multiplexer.n_actuators}: expected {self.n} (the number of actuators)"
            )
        if multiplexer is not None and pwm_slots is not None:
            raise ValueError("give either multiplexer or pwm_slots, not both")
        if multiplexer is not None:
            pwm_slots = [(multiplexer.period_s, multiplexer.phase(j), multiplexer.duty_max) for j in range(self.n)]
        self._slots = None
        if pwm_slots is not None:
            pwm_slots = [_pwm_slot(j, slot) for j, slot in enumerate(pwm_slots)]
            self._slots = pwm_slots
            if len(pwm_slots) != self.n:
                raise ValueError(f"pwm_slots has {len(pwm_slots)} entries: expected {self.n} (one per actuator)")
            for j, (period, phase, duty_max) in enumerate(pwm_slots):
                require_range(f"pwm_slots[{j}].period_s", period, 1e-6, 1.0, "s")
                require_range(f"pwm_slots[{j}].phase", phase, 0.0, 1.0, upper_open=True)
                require_range(f"pwm_slots[{j}].duty_max", duty_max, 0.0, 1.0, lower_open=True)
        self.rng = _generator(seed, rng)
        self.max_substep_s = max_substep_s
        self.max_temperature_step_k = max_temperature_step_k
        self.max_position_step_m = max_position_step_m
        self.max_temperature_step_at_cut_k = max_temperature_step_at_cut_k
        self.max_position_step_at_cut_m = max_position_step_at_cut_m

        packed = []
        cache: dict[int, np.ndarray] = {}
        self._accuracy = {
            "max_substep_s": max_substep_s,
            "max_temperature_step_k": max_temperature_step_k,
            "max_position_step_m": max_position_step_m,
            "max_temperature_step_at_cut_k": max_temperature_step_at_cut_k,
            "max_position_step_at_cut_m": max_position_step_at_cut_m,
        }
        for index, m in enumerate(models):
            if pwm_slots is not None:
                period, phase, duty_max = pwm_slots[index]
                row = pack_params(
                    m,
                    pwm_mode=pwm_mode,
                    pwm_period_s=period,
                    phase=phase,
                    duty_max=duty_max,
                    **self._accuracy,
                )
            else:
                key = id(m)
                if key not in cache:
                    cache[key] = pack_params(m, pwm_mode=pwm_mode, **self._accuracy)
                row = cache[key]
            packed.append(row)
        self.params = np.ascontiguousarray(np.stack(packed, axis=0))
        self.state = np.zeros((self.n, L.N_STATE))
        self._has_noise = bool(np.any(self.params[:, [L.P_POS_NOISE, L.P_R_NOISE, L.P_I_NOISE, L.P_V_NOISE]] > 0.0))
        self._duty_buffer = np.zeros((1, self.n))
        self._noise_buffer = np.empty((1, 4, self.n))  # one step's draw, refilled in place
        self.reset()

    # ------------------------------------------------------------------------------------
    # Reset and stepping
    # ------------------------------------------------------------------------------------
    def reset(
        self, mask: np.ndarray | None = None, *, temperature_c: float | np.ndarray | None = None, seed: Any = None
    ) -> None:
        """Put actuators (all, those where a boolean ``mask`` is True, or those at the
        indices in an integer ``mask``) at rest: cold, extended.

        ``seed`` restarts the sensor-noise generator (every actuator's: one stream serves
        them all), so that ``reset(seed=s)`` and the same duties give the same readings.

        ``temperature_c`` starts them at another temperature, still fully martensitic: at
        most where the coldest hysteron starts to transform at the rest stress (A_s + sigma0 /
        C_A lowered by the spread: ``ActuatorParams.highest_rest_temperature_c``, with the
        model's effects), i.e. a state the wire can rest in.
        """
        which = slice(None) if mask is None else self._actuators(mask)
        rng = None if seed is None else _generator(seed, None)  # set once every argument passed
        p = self.params
        s = self.state
        t_amb = p[which, L.P_T_AMB]
        if temperature_c is None:
            t0 = t_amb
        else:
            t0 = require_float_array("temperature_c", temperature_c, "degC")
            try:
                t0 = np.broadcast_to(t0, np.shape(t_amb))
            except ValueError:
                raise ValueError(
                    f"temperature_c has shape {np.shape(t0)}: expected a scalar or one per actuator reset "
                    f"({np.shape(t_amb)[0]})"
                ) from None
            limit = self._rest_limit_c(which)
            if not np.all(np.isfinite(t0)) or np.any(t0 > limit) or np.any(t0 < -60.0):
                raise ValueError(
                    f"temperature_c = {temperature_c!r}: expected a finite value between -60 degC and the "
                    f"stress-shifted start of the wire's transformation ({float(np.min(limit)):.1f} degC)"
                )
        if rng is not None:
            self.rng = rng
        s[which, :] = 0.0
        s[which, L.S_T] = t0
        s[which, L.S_T_RESET] = t0
        s[which, L.S_T_SURR] = t_amb  # the surroundings start at the ambient temperature
        s[which, L.S_XI] = 1.0
        s[which, L.S_XI_NODE0 : L.S_XI_NODE0 + L.MAX_SPREAD_NODES] = 1.0
        s[which, L.S_DIRECTION] = -1.0
        abbe = np.where(p[which, L.P_ABBE_FORM] > 0.5, 0.3, 1.0) * (-0.5 * p[which, L.P_ABBE])
        # Thermal expansion at a warm start lengthens the wire a little (x < 0).
        x0 = np.zeros_like(t0) if temperature_c is None else self._rest_position(which, t0)
        s[which, L.S_X] = x0
        s[which, L.S_SIGMA] = (p[which, L.P_F_PRE] + p[which, L.P_K_SPRING] * x0) / p[which, L.P_AREA]
        reading = x0 + abbe
        s[which, L.S_FILTER] = reading
        s[which, L.S_LAG1] = reading
        s[which, L.S_LAG2] = reading
        s[which, L.S_POS_MEAS] = reading
        s[which, L.S_R_MEAS] = np.nan
        s[which, L.S_I_MEAS] = np.nan
        s[which, L.S_V_MEAS] = np.nan
        # The first PWM period of actuator j starts after phase_j * period.
        s[which, L.S_PWM_TAU] = (1.0 - p[which, L.P_PWM_PHASE]) * p[which, L.P_PWM_PERIOD]
        s[which, L.S_R_TRUE] = wire_resistance(
            x0,
            1.0,
            t0,
            p[which, L.P_RHO_M],
            p[which, L.P_RHO_A],
            p[which, L.P_TCR_M],
            p[which, L.P_TCR_A],
            p[which, L.P_T_REF_R],
            p[which, L.P_LENGTH],
            p[which, L.P_AREA],
        )
        s[which, L.S_FORCE] = p[which, L.P_F_PRE] + p[which, L.P_K_SPRING] * x0

    def set_model(self, index: int, model: ModelSpec) -> None:
        """Give actuator ``index`` another model (e.g. a randomised condition at an env reset).

        Its PWM slot, mode and accuracy bounds stay; call :meth:`reset` for it afterwards.
        """
        # (True was read as index 1 by the list and as every row by the parameter array.)
        index = require_int_range("index", index, 0, self.n - 1)
        m = load_model(model)
        if self._slots is not None:
            period, phase, duty_max = self._slots[index]
            row = pack_params(
                m, pwm_mode=self.pwm_mode, pwm_period_s=period, phase=phase, duty_max=duty_max, **self._accuracy
            )
        else:
            row = pack_params(m, pwm_mode=self.pwm_mode, **self._accuracy)
        self.models[index] = m
        self.params[index] = row
        self._has_noise = bool(np.any(self.params[:, [L.P_POS_NOISE, L.P_R_NOISE, L.P_I_NOISE, L.P_V_NOISE]] > 0.0))

    @property
    def has_noise(self) -> bool:
        """True if any actuator's sensors are noisy (then each step draws from ``rng``)."""
        return self._has_noise

    def __copy__(self) -> Simulator:
        # A shallow copy shared the state arrays and the generator: stepping the copy moved
        # the original. A simulator is its arrays, so every copy is a deep one.
        import copy

        return copy.deepcopy(self)

    def _actuators(self, mask: Any) -> np.ndarray:
        """``reset``'s ``mask`` checked: booleans of shape (n,), or indices in [0, n) (numpy's
        own IndexError, or a scalar True read as 'index 10 out of bounds', named nothing)."""
        which = np.asarray(mask)
        if which.size == 0:
            return np.zeros(0, dtype=int)
        if which.dtype == bool:
            if which.shape != (self.n,):
                raise ValueError(f"mask has shape {which.shape}: expected booleans of shape ({self.n},) or indices")
            return which
        if not np.issubdtype(which.dtype, np.integer) or which.ndim != 1:
            raise ValueError(f"mask = {mask!r}: expected booleans of shape ({self.n},) or a 1-D array of indices")
        if which.min() < 0 or which.max() >= self.n:
            raise ValueError(f"mask = {mask!r}: indices must lie in [0, {self.n - 1}]")
        return which

    def _rest_limit_c(self, which) -> np.ndarray:
        """The warmest temperature at which the wire rests fully martensitic [degC]: where its
        coldest hysteron starts to transform at the stress of its rest position there. The
        warm wire's expansion slackens the spring a little (:meth:`_rest_position`), so this
        lies a little below the ambient limit ``ActuatorParams.highest_rest_temperature_c``
        (0.02 K for the standard wire)."""
        p = self.params
        rows = np.atleast_2d(p[which])
        # Unused node rows are zero: mask them so they cannot lower the minimum.
        used = np.arange(L.MAX_SPREAD_NODES)[None, :] < rows[:, L.P_N_NODES, None]
        heat = rows[:, L.P_NODE_HEAT0 : L.P_NODE_HEAT0 + L.MAX_SPREAD_NODES]
        ambient_limit = (
            rows[:, L.P_A_S] + np.where(used, heat, np.inf).min(axis=1) + rows[:, L.P_SIGMA0] / rows[:, L.P_C_A]
        )
        # T = ambient_limit - beta (T - T_amb): the rest stress falls by k x0(T) / A, x0 linear in T.
        t_amb = rows[:, L.P_T_AMB]
        dx_dt = self._rest_position(which, t_amb + 1.0)
        beta = -rows[:, L.P_K_SPRING] * dx_dt / (rows[:, L.P_AREA] * rows[:, L.P_C_A])
        return (ambient_limit + beta * t_amb) / (1.0 + beta)

    def _rest_position(self, which, t0: np.ndarray) -> np.ndarray:
        """Static position of a martensitic wire at temperature t0 (thermal expansion only)."""
        p = self.params
        area, length, d_m = p[which, L.P_AREA], p[which, L.P_LENGTH], p[which, L.P_D_M]
        strain = -p[which, L.P_ALPHA_TH_M] * (t0 - p[which, L.P_T_AMB])
        # k x + F_pre = A (sigma0 + D_M (strain - x / l0))
        return area * d_m * strain / (p[which, L.P_K_SPRING] + area * d_m / length)

    def step(self, duty: float | np.ndarray) -> None:
        """Advance one control step with the given duty cycle(s) (clipped to [0, duty_max]).

        Raises ``ValueError`` for NaN/inf or a wrong shape.
        """
        if type(duty) is float or (type(duty) is int and abs(duty) < 2**53):
            # Fast path for one scalar (a single env calls this every control step).
            if not math.isfinite(duty):
                raise ValueError(f"duty = {duty!r}: {_DUTY_EXPECTED}")
            if self.n == 1:
                self._duty_buffer[0, 0] = duty
            else:
                self._duty_buffer.fill(duty)
        else:
            arr = require_float_array("duty", duty)
            if arr.ndim == 0:
                self._duty_buffer[0, :] = float(arr)
            elif arr.shape == (self.n,):
                self._duty_buffer[0, :] = arr
            else:
                raise ValueError(f"duty has shape {arr.shape}: expected a scalar or shape ({self.n},)")
            if not np.isfinite(self._duty_buffer).all():
                raise ValueError(f"duty = {duty!r}: {_DUTY_EXPECTED}")
        self.step_unchecked(self._duty_buffer)

    def step_unchecked(self, duty_2d: np.ndarray, noise: np.ndarray | None = None) -> None:
        """Fast path for the envs: ``duty_2d`` is a finite float64 array of shape (1, n).

        ``noise`` (shape (1, 4, n), standard normals for the position, resistance, current
        and voltage readings) replaces the draw from ``rng``; the vector env uses it to draw
        each sub-env's noise from that sub-env's own generator.
        """
        if noise is None:
            # Drawn into a reused buffer: the same numbers as a fresh array, without the
            # allocation (this runs on every env step).
            noise = self.rng.standard_normal(out=self._noise_buffer) if self._has_noise else _NO_NOISE
        advance(self.state, self.params, duty_2d, self.control_period_s, noise, _NO_RECORD, _NO_FIELDS)

    def set_pulse_start(self, fraction: np.ndarray) -> None:
        """Where each actuator's pulse starts within its PWM period, as a fraction of the period.

        Resolved mode only (the averaged mode has no pulses). Latched with the duty at the
        next period start and kept until set again; :meth:`reset` puts it back to 0 (the
        pulse at the period start, the fixed slots' layout). A shared-budget multiplexer
        (:meth:`~sma_gym.electrical.multiplexer.Multiplexer.layout`) lays the pulses end to
        end with it. Raises ``ValueError`` for a wrong shape or values outside [0, 1).
        """
        arr = np.asarray(fraction, dtype=float)
        if arr.shape != (self.n,) or not np.all((arr >= 0.0) & (arr < 1.0)):
            raise ValueError(f"pulse start = {fraction!r}: expected shape ({self.n},) with values in [0, 1)")
        self.state[:, L.S_PULSE_START_CMD] = arr

    def run(
        self,
        duty: np.ndarray,
        record: Iterable[str] = ("position_m", "position_measured_m", "temperature_c", "martensite_fraction"),
    ) -> dict[str, np.ndarray]:
        """Run ``len(duty)`` control steps and return the recorded state after each.

        ``duty`` has shape (n_steps,) (same for every actuator) or (n_steps, n). ``record``
        names state quantities (see :data:`RECORDABLE`); each is returned with shape
        (n_steps, n). ``"time_s"`` is always included.
        """
        arr = require_float_array("duty", duty)
        if arr.ndim == 1:
            arr = np.repeat(arr[:, None], self.n, axis=1)
        if arr.ndim != 2 or arr.shape[1] != self.n:
            raise ValueError(f"duty has shape {np.shape(duty)}: expected (n_steps,) or (n_steps, {self.n})")
        if not np.all(np.isfinite(arr)):
            bad = np.argwhere(~np.isfinite(arr))[0]
            where = f"{bad[0]}" if np.ndim(duty) == 1 else f"{bad[0]}, {bad[1]}"  # the column too, for (n_steps, n)
            raise ValueError(f"duty[{where}] = {arr[tuple(bad)]!r}: {_DUTY_EXPECTED}")
        _fields_of(record, "record")
        names = list(dict.fromkeys(["time_s", *record]))
        fields = np.asarray(_fields_of(names, "record"), dtype=np.int64)
        n_steps = arr.shape[0]
        out = np.empty((n_steps, len(fields), self.n))
        noise = self.rng.standard_normal((n_steps, 4, self.n)) if self._has_noise else _NO_NOISE
        advance(self.state, self.params, np.ascontiguousarray(arr), self.control_period_s, noise, out, fields)
        return {name: out[:, j, :] for j, name in enumerate(names)}

    # ------------------------------------------------------------------------------------
    # Views of the state (shape (n,), always current)
    # ------------------------------------------------------------------------------------
    @property
    def position_m(self) -> np.ndarray:
        """True contraction x [m] (0 = extended)."""
        return self.state[:, L.S_X]

    @property
    def velocity_m_s(self) -> np.ndarray:
        """Contraction velocity x' [m/s]."""
        return self.state[:, L.S_V]

    @property
    def temperature_c(self) -> np.ndarray:
        """Wire temperature [degC]."""
        return self.state[:, L.S_T]

    @property
    def stress_pa(self) -> np.ndarray:
        """Wire stress [Pa]."""
        return self.state[:, L.S_SIGMA]

    @property
    def martensite_fraction(self) -> np.ndarray:
        """Martensite fraction xi, mean over the hysterons [-] (1 = cold, extended)."""
        return self.state[:, L.S_XI]

    @property
    def position_measured_m(self) -> np.ndarray:
        """Last position reading (filtered, sampled, with noise if configured) [m]."""
        return self.state[:, L.S_POS_MEAS]

    @property
    def resistance_measured_ohm(self) -> np.ndarray:
        """Last resistance reading V/I [ohm]; NaN where no reading was possible (pulse
        shorter than the settling time, no pulse, end-of-travel cut)."""
        return self.state[:, L.S_R_MEAS]

    @property
    def current_measured_a(self) -> np.ndarray:
        """Last current reading (on-time) [A]; NaN where none was possible."""
        return self.state[:, L.S_I_MEAS]

    @property
    def voltage_measured_v(self) -> np.ndarray:
        """Last wire-voltage reading (on-time) [V]; NaN where none was possible."""
        return self.state[:, L.S_V_MEAS]

    @property
    def resistance_ohm(self) -> np.ndarray:
        """True wire resistance now [ohm]."""
        return self.state[:, L.S_R_TRUE]

    @property
    def power_w(self) -> np.ndarray:
        """Mean electrical power into the wire over the last control step [W]."""
        return self.state[:, L.S_POWER]

    @property
    def electrical_energy_j(self) -> np.ndarray:
        """Electrical energy into the wire since reset [J]."""
        return self.state[:, L.S_E_ELECTRIC]

    @property
    def spring_force_n(self) -> np.ndarray:
        """Bias-spring force k x + F_pre [N] (what the report's force transducer reads)."""
        return self.state[:, L.S_FORCE]

    @property
    def time_s(self) -> np.ndarray:
        """Simulated time since reset [s]."""
        return self.state[:, L.S_TIME]

    @property
    def duty_applied(self) -> np.ndarray:
        """Duty of the last control step's command, clipped to [0, duty_max]: what the driver
        was given, not what it delivered (in the resolved PWM mode it latches a command at its
        next PWM period, so at 1 kHz over a 500 Hz PWM every other command is never applied;
        the end-of-travel cut holds the power off whatever the duty): ``power_w`` is what
        was delivered."""
        return self.state[:, L.S_DUTY_CMD]

    @property
    def end_of_travel_cut(self) -> np.ndarray:
        """True where the driver's end-of-travel cut holds the power off (a new bool array)."""
        return self.state[:, L.S_EOT_CUT] > 0.5

    def read(self, names: Sequence[str]) -> dict[str, np.ndarray]:
        """Copies of the named state quantities (names of :data:`RECORDABLE`), each shape (n,)."""
        return {name: self.state[:, field].copy() for name, field in zip(names, _fields_of(names, "names"))}

    def read_actuator(self, index: int, names: tuple[str, ...]) -> dict[str, float]:
        """The named state quantities of actuator ``index`` as Python floats.

        One conversion of the actuator's state row and a getter cached per ``names``: cheap
        enough for every env step.
        """
        return dict(zip(names, self.read_actuator_values(index, names)))

    def read_actuator_values(self, index: int, names: tuple[str, ...]) -> tuple[float, ...]:
        """:meth:`read_actuator`'s values alone, in the order of ``names`` (a tuple)."""
        if type(names) is not tuple:  # a list is unhashable, a string would be read as letters
            _fields_of(names, "names")
            names = tuple(names)
        getter = _GETTERS.get(names)
        if getter is None:
            fields = _fields_of(names, "names")
            # itemgetter of one field returns the value, not a 1-tuple
            getter = _GETTERS[names] = (lambda row, f=fields[0]: (row[f],)) if len(fields) == 1 else itemgetter(*fields)
        return getter(self.state[index].tolist())

    # ------------------------------------------------------------------------------------
    # Views of the parameters (shape (n,))
    # ------------------------------------------------------------------------------------
    @property
    def duty_max(self) -> np.ndarray:
        """Largest duty each actuator may get (1 / n when multiplexed)."""
        return self.params[:, L.P_DUTY_MAX]

    @property
    def usable_stroke_m(self) -> np.ndarray:
        """Usable stroke [m] (:attr:`~sma_gym.params.ActuatorParams.usable_stroke_m`)."""
        return self.params[:, L.P_STROKE]

    @property
    def cold_resistance_ohm(self) -> np.ndarray:
        """Resistance of the cold, extended wire [ohm] (:attr:`~sma_gym.params.Wire.cold_resistance_ohm`)."""
        return self.params[:, L.P_R_COLD]

    @property
    def supply_voltage_v(self) -> np.ndarray:
        """Driver supply voltage [V]."""
        return self.params[:, L.P_V_SUPPLY]

    def energy_balance(self) -> dict[str, np.ndarray]:
        """Energy accounts since reset [J], one value per actuator.

        ``electrical + latent_released = convected + stored_heat + mechanical_work`` holds
        to rounding (the integrator books what it applies); ``residual`` is the difference.
        ``mechanical_work`` in turn equals ``kinetic + spring + dissipated`` up to the
        numerical damping of the implicit step where it is not trapezoidal
        (``mechanical_residual``; see ``core.kernel``).
        """
        s, p = self.state, self.params
        stored = p[:, L.P_HEAT_CAP] * (s[:, L.S_T] - s[:, L.S_T_RESET])
        kinetic = 0.5 * p[:, L.P_MASS] * s[:, L.S_V] ** 2
        x = s[:, L.S_X]
        # Potential of the preloaded spring relative to rest (x = 0).
        spring = 0.5 * p[:, L.P_K_SPRING] * x**2 + p[:, L.P_F_PRE] * x
        out = {
            "electrical": s[:, L.S_E_ELECTRIC].copy(),
            "latent_released": s[:, L.S_E_LATENT].copy(),
            "convected": s[:, L.S_E_CONVECTED].copy(),
            "stored_heat": stored,
            "mechanical_work": s[:, L.S_W_MECHANICAL].copy(),
            "kinetic": kinetic,
            "spring": spring,
            "dissipated": s[:, L.S_E_DISSIPATED].copy(),
        }
        out["residual"] = (
            out["electrical"] + out["latent_released"] - out["convected"] - stored - out["mechanical_work"]
        )
        out["mechanical_residual"] = out["mechanical_work"] - kinetic - spring - out["dissipated"]
        return out


MAX_ACTUATORS = 10_000_000
"""Most actuators one simulator holds (its state and parameter rows take about 1 kB each: 10 GB here)."""

RECORDABLE = tuple(sorted(L.STATE_FIELDS))
"""Names of the state quantities :meth:`Simulator.run` records and :meth:`Simulator.read` reads."""


_GETTERS: dict[tuple[str, ...], Callable[[list[float]], tuple[float, ...]]] = {}


def _pwm_slot(j: int, slot: Any) -> tuple[float, float, float]:
    """One ``(period_s, phase, duty_max)`` of ``pwm_slots``, its numbers checked by name
    (a pair failed to unpack, a string '0.002' was taken as a number)."""
    if isinstance(slot, (str, bytes)) or not hasattr(slot, "__len__") or len(slot) != 3:
        raise ValueError(f"pwm_slots[{j}] = {slot!r}: expected (period_s, phase, duty_max)")
    period, phase, duty_max = (
        require_finite(f"pwm_slots[{j}].{what}", value) for what, value in zip(("period_s", "phase", "duty_max"), slot)
    )
    return period, phase, duty_max


def _generator(seed: Any, rng: Any) -> np.random.Generator:
    """The sensor-noise generator from ``seed`` or ``rng`` (one of them), named when wrong: a
    ``RandomState`` ran in ``run`` and failed in ``step``; ``rng=3`` failed at the first step."""
    if rng is not None:
        if seed is not None:
            raise ValueError(f"seed = {seed!r} and rng: expected one of the two")
        if not isinstance(rng, np.random.Generator):
            raise ValueError(
                f"rng = {rng!r}: expected a numpy.random.Generator (np.random.default_rng(seed)), or seed=..."
            )
        return rng
    if seed is not None and not isinstance(seed, np.random.SeedSequence):
        seed = require_int_range("seed", seed, 0, 2**63 - 1)
    return np.random.default_rng(seed)


def _fields_of(names: Sequence[str], what: str) -> list[int]:
    """Layout indices of named state quantities; an unknown name raises ``ValueError``."""
    if isinstance(names, str) or not isinstance(names, (list, tuple)):
        # A single string was read as its letters ("record contains 'p'").
        raise ValueError(f"{what} = {names!r}: expected a list or tuple of names, e.g. ('position_m',)")
    try:
        return [L.STATE_FIELDS[name] for name in names]
    except KeyError as err:
        raise ValueError(f"{what} contains {err.args[0]!r}: expected names from {sorted(L.STATE_FIELDS)}") from None

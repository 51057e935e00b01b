"""An independent truth generator for synthetic measured SMA-actuator data (issue 12).

Why this exists
---------------
``sma-gym synth`` generates its test data with the very kernel the diagnosis fits, so a
benchmark built on it can be passed by a diagnosis that has learnt the kernel's quirks (the
"inverse crime"). This module is a *second* implementation of the same physics, written
from the equations of ``docs/model.md`` §2-§5 and the parameter docstrings of
:mod:`sma_gym.params`, that shares no code with ``sma_gym.core``, ``sma_gym.physics`` or
``sma_gym.simulator``. It reads the same parameter values
(:class:`sma_gym.params.ActuatorParams`) and writes the same measured-data format
(:class:`sma_gym.data.MeasuredTrace`), so ``sma-gym diagnose`` can read its files.

What is deliberately different from our kernel
----------------------------------------------
========================= ========================================= =========================================
aspect                    our kernel                                this generator
========================= ========================================= =========================================
stress                    integrated closed form sigma(x, T, xi)    rate form (report eq. 5.2): sigma is a state,
                                                                    sigma' = D(xi) eps' - D alpha T' - D eps0 xi'
minor loops               Preisach sum of play operators (hysterons) one xi with the continuity-fixed rescaled-
                          spread in centre and width                cosine (proportional) law, reversal memory
                                                                    (mode, xi_r, scale q/p), 0.02 K switch band
wider minor loops         no hysteron narrower than a share of the  a dead band after every reversal: xi holds
                          mean width (a floor on the widths)        for min_width_share x 7.5 K, then the
                                                                    proportional law from where it stands
transformation spread     Gaussian spread of hysteron centres       the branch itself is smoothed: mean of the
                                                                    cosine branch over *logistic* quantile shifts
sigma/xi algebraic loop   inside the implicit step                  closed-form solve in every RHS evaluation
integrator                backward / exponential Euler, adaptive    fixed-step explicit RK4, 50 us
sensor filter, lag        discrete first-order updates per sub-step ODE states integrated with the mechanics
Coulomb friction          set-valued stick-slip                     smooth F_c tanh(v / 2 mm/s)
Abbe offset               steps with the direction of motion,       backlash: the offset turns over the first
                          before the sensor filter                  0.1 mm of travel after a reversal, added
                                                                    after the filter and lag
========================= ========================================= =========================================

Step size: the stiffest mode is the austenitic wire against the moving mass,
omega = sqrt((D_A A / l0 + k) / M_t) = sqrt(21750 / 0.0088) = 1570 rad/s (250 Hz). Explicit
RK4 is stable for |lambda h| < 2.78, i.e. h < 1.8 ms, and with h = 50 us omega h = 0.08, so
the local error of the oscillation (~(omega h)^5 / 120) is below 1e-7 per step. The tanh
friction adds an equivalent damping F_c / v_s / M_t = 0.6 / 0.002 / 0.0088 = 3.4e4 1/s, so
:func:`rk4_substeps` shortens the step until h (omega + c_eq / M_t) <= 1 (28 us for 0.6 N,
6 us for the 3 N upper bound): stable with margin and the friction's time constant resolved.

Everything is in SI units with temperatures in degC (as in :mod:`sma_gym.params`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numba
import numpy as np

from sma_gym.data import MeasuredTrace
from sma_gym.params import ActuatorParams, preset

# ------------------------------------------------------------------------------------------
# Effects, in independent forms. Names and parameter names match ``sma_gym.effects`` so a
# benchmark can score the diagnosis's answer by name; the values are typical sizes.
# ------------------------------------------------------------------------------------------

#: effect name -> {parameter name: typical value} (units as in sma_gym.effects).
INDEPENDENT_EFFECTS: dict[str, dict[str, float]] = {
    "sensor_lag": {"time_constant_s": 0.05},
    "convection_change": {"scale": 1.6, "h1_w_m2_k2": 0.0},
    "coulomb_friction": {"force_n": 0.6},
    "supply_sag": {"series_resistance_ohm": 1.0},
    "latent_heat": {"change_j_kg": -12000.0},
    "transformation_spread": {"spread_k": 6.0},
    "abbe_offset": {"offset_m": 0.3e-3},
    "minor_loop_width": {"min_width_share": 0.6},
}

EXCITATIONS = ("steps", "ramps", "sine", "chirp", "random")
CONTROL_PERIOD_S = 1e-3
"""The duty is held for one control period (the report's 1 kHz loop), as in ``sma-gym synth``."""
KP_PER_M = 1000.0
"""P-controller gain of the recorded closed-loop excitations (the report's Kp, §6)."""
REST_S = 1.0
"""Every excitation starts with a second at rest (the recording's sensor zero)."""
INTEGRATOR_STEP_S = 50e-6
"""RK4 step (see the module docstring for the stability/accuracy argument)."""
SWITCH_BAND_K = 0.02
"""Hysteresis of the heating/cooling switch on the effective temperature [K]: without it,
round-off in T would flip the branch every step (and the proportional law ratchets)."""
FRICTION_SMOOTHING_M_S = 2e-3
"""Velocity scale v_s of the tanh friction [m/s]: sharp enough to act as Coulomb friction
at the actuator's 10-200 mm/s, smooth enough for the explicit step."""
ABBE_TURN_M = 50e-6
"""Half the travel over which the actuator's tilt (and so the Abbe error) turns over [m]."""
SPREAD_NODES = 16
"""Quantile nodes of the logistic temperature spread that smooth the cosine branches."""
DEAD_BAND_FULL_K = 7.5
"""Dead band after a reversal [K] at min_width_share = 1: the mean loop width of our
kernel's nominal hysterons (15 K x (1 - 1/2)), read off the parameter docstrings, so that
the same share means a comparable delay; the form (a band, then the proportional law) is
our own."""

# State vector of the ODE (indices).
X, V, TEMP, SIGMA, XI, FILT, LAG, ABBE, E_EL, E_CONV, E_LAT, W_MECH = range(12)
N_Y = 12

# Flat parameter vector (indices), filled by :func:`pack`.
(
    P_MASS,
    P_DAMP,
    P_K,
    P_FPRE,
    P_AREA,
    P_L0,
    P_DM,
    P_DA,
    P_ALPHA_A,
    P_EPS0,
    P_AS,
    P_AF,
    P_MS,
    P_MF,
    P_CA,
    P_CM,
    P_MCP,
    P_LAMBDA_K,
    P_DH_M,
    P_H0,
    P_H1,
    P_H2,
    P_TAMB,
    P_SURF,
    P_V,
    P_RS,
    P_RHOM,
    P_RHOA,
    P_TCRM,
    P_TCRA,
    P_TREF,
    P_EOT,
    P_EOT_REL,
    P_TAU_F,
    P_TAU_LAG,
    P_ABBE,
    P_FC,
    P_PWM_PERIOD,
    P_SETTLE,
    P_ALPHA_M,
    P_DEAD_BAND,
) = range(41)
N_P = 41


@dataclass(frozen=True)
class Physics:
    """The packed parameters, the spread nodes and the effect that was applied."""

    vector: np.ndarray
    spread_nodes_k: np.ndarray
    effect: str | None
    effect_values: dict[str, float]


def pack(
    params: ActuatorParams, effect: str | None = None, effect_values: Mapping[str, float] | None = None
) -> Physics:
    """Turn an :class:`ActuatorParams` and one hidden effect into the numbers the ODE reads."""
    if effect in (None, "none"):
        effect, values = None, {}
    else:
        if effect not in INDEPENDENT_EFFECTS:
            raise ValueError(f"effect = {effect!r}: expected none or one of {', '.join(INDEPENDENT_EFFECTS)}")
        values = dict(INDEPENDENT_EFFECTS[effect])
        for key, value in dict(effect_values or {}).items():
            if key not in values:
                raise ValueError(f"effect {effect!r} has no parameter {key!r}; expected {sorted(values)}")
            values[key] = float(value)
    w, m, c, d, s = params.wire, params.mechanism, params.convection, params.driver, params.sensors
    p = np.zeros(N_P)
    area = math.pi * w.diameter_m**2 / 4.0
    mass = w.density_kg_m3 * area * w.length_m
    latent = w.latent_heat_j_kg + (values["change_j_kg"] if effect == "latent_heat" else 0.0)
    latent = max(latent, 0.0)  # a negative latent heat would be unphysical
    h_scale = (w.diameter_m / c.reference_diameter_m) ** c.diameter_exponent
    if effect == "convection_change":
        h_scale *= values["scale"]
    p[P_MASS] = m.moving_mass_kg
    p[P_DAMP] = m.damping_n_s_m
    p[P_K] = m.spring_stiffness_n_m
    p[P_FPRE] = m.spring_preload_n
    p[P_AREA] = area
    p[P_L0] = w.length_m
    p[P_DM] = w.youngs_modulus_martensite_pa
    p[P_DA] = w.youngs_modulus_austenite_pa
    p[P_ALPHA_A] = w.thermal_expansion_austenite_1_k
    p[P_ALPHA_M] = w.thermal_expansion_martensite_1_k
    p[P_EPS0] = w.max_transformation_strain
    p[P_AS], p[P_AF] = w.austenite_start_c, w.austenite_finish_c
    p[P_MS], p[P_MF] = w.martensite_start_c, w.martensite_finish_c
    p[P_CA], p[P_CM] = w.stress_coefficient_austenite_pa_k, w.stress_coefficient_martensite_pa_k
    p[P_MCP] = mass * w.specific_heat_j_kg_k
    p[P_LAMBDA_K] = latent / w.specific_heat_j_kg_k  # temperature change per unit of xi [K]
    p[P_DH_M] = latent * mass  # latent heat of the whole wire [J per unit xi]
    p[P_H0] = c.h0_w_m2_k * h_scale
    p[P_H1] = values["h1_w_m2_k2"] * h_scale if effect == "convection_change" else 0.0
    p[P_H2] = c.h2_w_m2_k3 * h_scale
    p[P_TAMB] = c.ambient_temperature_c
    p[P_SURF] = math.pi * w.diameter_m * w.length_m
    p[P_V] = d.supply_voltage_v
    p[P_RS] = values["series_resistance_ohm"] if effect == "supply_sag" else 0.0
    p[P_RHOM], p[P_RHOA] = w.resistivity_martensite_ohm_m, w.resistivity_austenite_ohm_m
    p[P_TCRM], p[P_TCRA] = w.resistivity_tcr_martensite_1_k, w.resistivity_tcr_austenite_1_k
    p[P_TREF] = w.resistivity_reference_c
    p[P_EOT] = d.end_of_travel_m if math.isfinite(d.end_of_travel_m) else 1e9
    p[P_EOT_REL] = d.end_of_travel_release_m
    p[P_TAU_F] = 0.0 if s.position_filter_cutoff_hz == 0.0 else 1.0 / (2.0 * math.pi * s.position_filter_cutoff_hz)
    p[P_TAU_LAG] = values["time_constant_s"] if effect == "sensor_lag" else 0.0
    p[P_ABBE] = values["offset_m"] if effect == "abbe_offset" else 0.0
    p[P_FC] = values["force_n"] if effect == "coulomb_friction" else 0.0
    p[P_PWM_PERIOD] = 1.0 / d.pwm_frequency_hz
    p[P_SETTLE] = d.settling_time_s
    p[P_DEAD_BAND] = DEAD_BAND_FULL_K * values["min_width_share"] if effect == "minor_loop_width" else 0.0
    for name, index in (("sensor filter", P_TAU_F), ("sensor_lag", P_TAU_LAG)):
        if 0.0 < p[index] < 4.0 * INTEGRATOR_STEP_S:
            raise ValueError(f"{name} time constant {p[index]:g} s is below 4 RK4 steps; too fast to integrate")
    # Variances add: the wire's own spread and the hidden extra spread are independent.
    spread = w.transformation_spread_k
    if effect == "transformation_spread":
        spread = math.hypot(spread, values["spread_k"])
    return Physics(p, spread_nodes(spread), effect, values)


def spread_nodes(std_k: float, n: int = SPREAD_NODES) -> np.ndarray:
    """Temperature shifts [K] at the equal-probability midpoints of a logistic distribution
    with standard deviation ``std_k`` (logistic scale b = std sqrt(3) / pi).

    The mean of the cosine branch over these shifts is the branch of a wire whose local
    transformation temperatures are spread logistically (heavier tails than the kernel's
    Gaussian: a deliberately different form)."""
    if std_k <= 0.0:
        return np.zeros(1)
    prob = (np.arange(n) + 0.5) / n
    nodes = std_k * math.sqrt(3.0) / math.pi * np.log(prob / (1.0 - prob))
    return nodes - nodes.mean()  # exactly centred (it is by symmetry, up to rounding)


# ------------------------------------------------------------------------------------------
# The ODE
# ------------------------------------------------------------------------------------------


@numba.njit(cache=True)
def branch(t_eff_c: float, start_c: float, width_k: float, nodes: np.ndarray) -> tuple[float, float]:
    """Martensite fraction on a (spread-smoothed) cosine branch and its slope d/dT_eff [1/K].

    F(u) = (1 + cos(pi clip(u, 0, 1))) / 2 with u = (T_eff - start - shift) / width, averaged
    over the spread's shifts: 1 when cold, 0 when hot."""
    value = 0.0
    slope = 0.0
    for shift in nodes:
        u = (t_eff_c - start_c - shift) / width_k
        if u <= 0.0:
            value += 1.0
        elif u < 1.0:
            value += 0.5 * (1.0 + math.cos(math.pi * u))
            slope -= 0.5 * math.pi / width_k * math.sin(math.pi * u)
    return value / nodes.size, slope / nodes.size


@numba.njit(cache=True)
def wire_resistance(x: float, xi: float, temp_c: float, p: np.ndarray) -> float:
    """R = rho(xi, T) L^2 / (A0 l0): resistivities mixed by xi, each with its temperature
    coefficient; the wire's length is l0 - x at constant volume (so its area grows)."""
    dt = temp_c - p[P_TREF]
    rho = xi * p[P_RHOM] * (1.0 + p[P_TCRM] * dt) + (1.0 - xi) * p[P_RHOA] * (1.0 + p[P_TCRA] * dt)
    length = p[P_L0] - x
    return rho * length * length / (p[P_AREA] * p[P_L0])


@numba.njit(cache=True)
def wire_power(duty: float, resistance: float, p: np.ndarray) -> float:
    """PWM-averaged power into the wire [W], behind the series resistance of a sagging supply."""
    if duty <= 0.0:
        return 0.0
    current = p[P_V] / (resistance + p[P_RS])
    return duty * current * current * resistance


@numba.njit(cache=True)
def rhs(
    y: np.ndarray, duty: float, heating: bool, scale: float, p: np.ndarray, nodes: np.ndarray, dy: np.ndarray
) -> None:
    """dy/dt for the state y, with the duty (0 while the end-of-travel cut is open) and the
    branch memory (heating or cooling, and its proportional scale q or p) held fixed."""
    x, v, temp, sigma, xi = y[X], y[V], y[TEMP], y[SIGMA], y[XI]
    resistance = wire_resistance(x, xi, temp, p)
    power = wire_power(duty, resistance, p)
    h = p[P_H0] + p[P_H1] * (temp - p[P_TAMB]) + p[P_H2] * temp * temp
    convected = h * p[P_SURF] * (temp - p[P_TAMB])
    # Temperature rate without the latent heat, and the latent heat's K per unit of xi.
    a = (power - convected) / p[P_MCP]
    lam = p[P_LAMBDA_K]
    modulus = xi * p[P_DM] + (1.0 - xi) * p[P_DA]
    strain_rate = -v / p[P_L0]
    # Branch slope K = dxi/dT_eff on the active branch, with T_eff = T - sigma / C.
    if heating:
        c_shift = p[P_CA]
        _, dg = branch(temp - sigma / c_shift, p[P_AS], p[P_AF] - p[P_AS], nodes)
        slope = scale * dg
    else:
        c_shift = p[P_CM]
        _, dg = branch(temp - sigma / c_shift, p[P_MF], p[P_MS] - p[P_MF], nodes)
        slope = scale * dg
    # The algebraic loop, linear in xi':
    #   T' = a + lam xi'
    #   sigma' = D eps' - D alpha T' - D eps0 xi'
    #   xi' = K (T' - sigma' / C)
    # => xi' [1 - K lam (1 + D alpha / C) - K D eps0 / C] = K [a (1 + D alpha / C) - D eps' / C].
    # K <= 0 and lam, D eps0 / C >= 0, so the bracket is >= 1: always solvable (the recovery
    # stress raises the transformation temperature, i.e. negative feedback).
    # Rate form with the mixture's expansion (our kernel integrates alpha(xi) (T - T_amb) in
    # closed form instead, so the two differ by the xi' alpha' T term).
    alpha = xi * p[P_ALPHA_M] + (1.0 - xi) * p[P_ALPHA_A]
    thermo = 1.0 + modulus * alpha / c_shift
    denominator = 1.0 - slope * lam * thermo - slope * modulus * p[P_EPS0] / c_shift
    xi_rate = slope * (a * thermo - modulus * strain_rate / c_shift) / denominator
    temp_rate = a + lam * xi_rate
    sigma_rate = modulus * strain_rate - modulus * alpha * temp_rate - modulus * p[P_EPS0] * xi_rate
    friction = p[P_FC] * math.tanh(v / FRICTION_SMOOTHING_M_S)
    force = sigma * p[P_AREA]
    dy[X] = v
    dy[V] = (force - p[P_K] * x - p[P_FPRE] - p[P_DAMP] * v - friction) / p[P_MASS]
    dy[TEMP] = temp_rate
    dy[SIGMA] = sigma_rate
    dy[XI] = xi_rate
    # Sensor chain: the 100 Hz filter of the position sensor, then the hidden extra lag.
    dy[FILT] = v if p[P_TAU_F] == 0.0 else (x - y[FILT]) / p[P_TAU_F]
    filt_rate = dy[FILT]
    dy[LAG] = filt_rate if p[P_TAU_LAG] == 0.0 else (y[FILT] - y[LAG]) / p[P_TAU_LAG]
    # Abbe backlash: the tilt turns from -1 (extending) to +1 (contracting) over 2 ABBE_TURN_M.
    turn = v / ABBE_TURN_M
    if (y[ABBE] >= 1.0 and turn > 0.0) or (y[ABBE] <= -1.0 and turn < 0.0) or p[P_ABBE] == 0.0:
        turn = 0.0
    dy[ABBE] = turn
    # Energy accounts [J]: electrical in, convected out, latent absorbed, work done by the wire.
    dy[E_EL] = power
    dy[E_CONV] = convected
    dy[E_LAT] = -p[P_DH_M] * xi_rate
    dy[W_MECH] = force * v


@numba.njit(cache=True)
def _run(
    p: np.ndarray,
    nodes: np.ndarray,
    duty_cmd: np.ndarray,
    reference: np.ndarray,
    kp: float,
    duty_min: float,
    rest_steps: int,
    update_every: int,
    substeps: int,
    control_period_s: float,
    noise: np.ndarray,
    position_noise_m: float,
    position_resolution_m: float,
    resistance_noise_ohm: float,
    out: np.ndarray,
) -> None:
    """Advance control step by control step; ``out[k]`` is recorded at the end of step k.

    Closed loop when ``kp > 0`` (duty from the reference and the last position reading,
    updated every ``update_every`` control steps and held in between), open loop from
    ``duty_cmd`` otherwise. Columns of ``out``: 0 duty, 1 x, 2 v, 3 T,
    4 sigma, 5 xi, 6 position reading, 7 R true, 8 R reading, 9 I reading, 10 V reading,
    11 E_el, 12 E_conv, 13 E_latent, 14 W_mech, 15 heating mode, 16 cut, 17 power.
    """
    h = control_period_s / substeps
    y = np.zeros(N_Y)
    y[TEMP] = p[P_TAMB]
    y[SIGMA] = p[P_FPRE] / p[P_AREA]
    y[XI] = 1.0
    y[ABBE] = -1.0  # at rest the actuator last moved extending
    y[FILT] = 0.0
    y[LAG] = 0.0
    k1, k2, k3, k4, tmp = np.zeros(N_Y), np.zeros(N_Y), np.zeros(N_Y), np.zeros(N_Y), np.zeros(N_Y)
    heating = False
    scale = 0.0  # cooling from xi = 1: 1 - xi = 0 * (1 - G_c), nothing moves
    extreme = y[TEMP] - y[SIGMA] / p[P_CM]
    # Dead band after a reversal (minor_loop_width): xi holds while the effective temperature
    # has come back less than the band from the reversal point (hold_dir +1: after a top
    # reversal, waiting to cool; -1: after a bottom one, waiting to heat).
    dead_band = p[P_DEAD_BAND]
    hold_dir = 0
    hold_ref = 0.0
    cut = False
    reading = 0.5 * p[P_ABBE] * y[ABBE]
    duty = 0.0
    for k in range(duty_cmd.size):
        if kp > 0.0:
            if k % update_every == 0:
                duty = 0.0 if k < rest_steps else min(1.0, max(duty_min, kp * (reference[k] - reading)))
        else:
            duty = min(1.0, max(0.0, duty_cmd[k]))
        power_sum = 0.0
        for _ in range(substeps):
            applied = 0.0 if cut else duty
            scale_now = 0.0 if hold_dir != 0 else scale  # a zero branch slope: xi holds
            rhs(y, applied, heating, scale_now, p, nodes, k1)
            for i in range(N_Y):
                tmp[i] = y[i] + 0.5 * h * k1[i]
            rhs(tmp, applied, heating, scale_now, p, nodes, k2)
            for i in range(N_Y):
                tmp[i] = y[i] + 0.5 * h * k2[i]
            rhs(tmp, applied, heating, scale_now, p, nodes, k3)
            for i in range(N_Y):
                tmp[i] = y[i] + h * k3[i]
            rhs(tmp, applied, heating, scale_now, p, nodes, k4)
            for i in range(N_Y):
                y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
            power_sum += (k1[E_EL] + 2.0 * k2[E_EL] + 2.0 * k3[E_EL] + k4[E_EL]) / 6.0
            # Truncation error of the rate form may not carry xi out of [0, 1].
            y[XI] = min(1.0, max(0.0, y[XI]))
            y[ABBE] = min(1.0, max(-1.0, y[ABBE]))
            # Branch switching on the effective temperature, with a small band against chatter.
            if hold_dir != 0:
                t_h = y[TEMP] - y[SIGMA] / p[P_CA]
                t_c = y[TEMP] - y[SIGMA] / p[P_CM]
                if (hold_dir > 0 and t_c < hold_ref - dead_band) or (hold_dir < 0 and t_c < hold_ref):
                    # Through the band (or back below a bottom reversal): cooling from here.
                    hold_dir = 0
                    heating = False
                    g, _ = branch(t_c, p[P_MF], p[P_MS] - p[P_MF], nodes)
                    scale = (1.0 - y[XI]) / max(1.0 - g, 1e-9)
                    extreme = t_c
                elif (hold_dir < 0 and t_h > hold_ref + dead_band) or (hold_dir > 0 and t_h > hold_ref):
                    hold_dir = 0
                    heating = True
                    g, _ = branch(t_h, p[P_AS], p[P_AF] - p[P_AS], nodes)
                    scale = y[XI] / max(g, 1e-9)
                    extreme = t_h
            elif heating:
                t_eff = y[TEMP] - y[SIGMA] / p[P_CA]
                extreme = max(extreme, t_eff)
                if t_eff < extreme - SWITCH_BAND_K and dead_band > 0.0:
                    hold_dir = 1
                    hold_ref = extreme
                elif t_eff < extreme - SWITCH_BAND_K:
                    heating = False
                    t_c = y[TEMP] - y[SIGMA] / p[P_CM]
                    g, _ = branch(t_c, p[P_MF], p[P_MS] - p[P_MF], nodes)
                    # 1 - xi = s (1 - G_c) passes through the reversal point: no jump.
                    scale = (1.0 - y[XI]) / max(1.0 - g, 1e-9)
                    extreme = t_c
            else:
                t_eff = y[TEMP] - y[SIGMA] / p[P_CM]
                extreme = min(extreme, t_eff)
                if t_eff > extreme + SWITCH_BAND_K and dead_band > 0.0:
                    hold_dir = -1
                    hold_ref = extreme
                elif t_eff > extreme + SWITCH_BAND_K:
                    heating = True
                    t_h = y[TEMP] - y[SIGMA] / p[P_CA]
                    g, _ = branch(t_h, p[P_AS], p[P_AF] - p[P_AS], nodes)
                    # xi = s G_h passes through the reversal point: no jump.
                    scale = y[XI] / max(g, 1e-9)
                    extreme = t_h
            # The driver's end-of-travel switch, with its release hysteresis.
            if not cut and y[X] >= p[P_EOT]:
                cut = True
            elif cut and y[X] <= p[P_EOT] - p[P_EOT_REL]:
                cut = False
        true_reading = y[LAG] + 0.5 * p[P_ABBE] * y[ABBE]
        reading = true_reading + position_noise_m * noise[k, 0]
        if position_resolution_m > 0.0:
            reading = position_resolution_m * math.floor(reading / position_resolution_m + 0.5)
        resistance = wire_resistance(y[X], y[XI], y[TEMP], p)
        r_read = math.nan
        i_read = math.nan
        v_read = math.nan
        # V/I needs a pulse that outlasts the electrical settling time (§4.1), and power on.
        if duty * p[P_PWM_PERIOD] >= p[P_SETTLE] and duty > 0.0 and not cut:
            # The divider reads the wire's voltage: the supply less the drop across the sag's
            # series resistance (exactly the supply without one).
            v_wire = p[P_V] if p[P_RS] == 0.0 else p[P_V] * resistance / (resistance + p[P_RS])
            r_read = resistance + resistance_noise_ohm * noise[k, 1]
            i_read = v_wire / resistance + 0.5 * resistance_noise_ohm * noise[k, 2]
            v_read = v_wire + 2.0 * resistance_noise_ohm * noise[k, 3]
        out[k, 0] = duty
        out[k, 1] = y[X]
        out[k, 2] = y[V]
        out[k, 3] = y[TEMP]
        out[k, 4] = y[SIGMA]
        out[k, 5] = y[XI]
        out[k, 6] = reading
        out[k, 7] = resistance
        out[k, 8] = r_read
        out[k, 9] = i_read
        out[k, 10] = v_read
        out[k, 11] = y[E_EL]
        out[k, 12] = y[E_CONV]
        out[k, 13] = y[E_LAT]
        out[k, 14] = y[W_MECH]
        out[k, 15] = 1.0 if heating else 0.0
        out[k, 16] = 1.0 if cut else 0.0
        out[k, 17] = power_sum / substeps


RECORD_COLUMNS = (
    "duty",
    "position_m",
    "velocity_m_s",
    "temperature_c",
    "stress_pa",
    "martensite_fraction",
    "position_measured_m",
    "resistance_ohm",
    "resistance_measured_ohm",
    "current_measured_a",
    "voltage_measured_v",
    "electrical_energy_j",
    "convected_energy_j",
    "latent_absorbed_j",
    "mechanical_work_j",
    "heating",
    "cut",
    "power_w",
)


def reference_signal(kind: str, duration_s: float, stroke_m: float, rng: np.random.Generator) -> np.ndarray:
    """Position reference [m] per 1 ms control step for the excitation ``kind``.

    The same five kinds as ``sma-gym synth`` over the same 10-85 % of the stroke, drawn
    differently (our own segment lengths, frequencies and smoothing)."""
    n = int(round(duration_s / CONTROL_PERIOD_S))
    t = np.arange(n) * CONTROL_PERIOD_S
    lo, hi = 0.1 * stroke_m, 0.85 * stroke_m
    mid, amp = 0.5 * (lo + hi), 0.5 * (hi - lo)
    active = t >= REST_S
    tt = np.clip(t - REST_S, 0.0, None)
    if kind == "steps":
        edges = np.cumsum(rng.uniform(1.5, 4.5, size=int(duration_s) + 2))
        levels = rng.uniform(lo, hi, size=edges.size + 1)
        ref = levels[np.searchsorted(edges, tt, side="right")]
    elif kind == "ramps":
        corners_t = np.r_[0.0, np.cumsum(rng.uniform(1.0, 4.0, size=int(duration_s) + 2))]
        corners_x = np.r_[0.0, rng.uniform(lo, hi, size=corners_t.size - 1)]
        ref = np.interp(tt, corners_t, corners_x)
    elif kind == "sine":
        f_hz = rng.uniform(0.07, 0.2)
        ref = mid - amp * np.cos(2.0 * math.pi * f_hz * tt)
    elif kind == "chirp":
        # Exponential (not linear) sweep 0.03 -> 0.5 Hz over the run.
        f0, f1 = 0.03, 0.5
        span = max(duration_s - REST_S, 1e-9)
        rate = math.log(f1 / f0) / span
        phase = 2.0 * math.pi * f0 * (np.exp(rate * tt) - 1.0) / rate
        ref = mid - amp * np.cos(phase)
    elif kind == "random":
        # Band-limited noise: white noise through two 0.4 s first-order filters, rescaled.
        white = rng.standard_normal(n)
        alpha = CONTROL_PERIOD_S / 0.4
        sig = np.zeros(n)
        s1 = s2 = 0.0
        for i in range(n):
            s1 += alpha * (white[i] - s1)
            s2 += alpha * (s1 - s2)
            sig[i] = s2
        sig = (sig - sig[active].mean()) / max(sig[active].std(), 1e-12)
        ref = np.clip(mid + 0.45 * amp * sig, lo, hi)
    else:
        raise ValueError(f"excitation = {kind!r}: expected one of {', '.join(EXCITATIONS)}")
    return np.where(active, ref, 0.0)


def simulate(
    params: ActuatorParams | str = "standard",
    *,
    duty: np.ndarray | None = None,
    excitation: str | None = None,
    duration_s: float = 40.0,
    effect: str | None = None,
    effect_values: Mapping[str, float] | None = None,
    position_noise_m: float = 0.0,
    position_resolution_m: float = 0.0,
    resistance_noise_ohm: float = 0.0,
    electrical: bool = True,
    seed: int = 0,
    substeps: int | None = None,
    controller_every: int = 1,
) -> dict[str, np.ndarray]:
    """Run the independent model; every quantity of :data:`RECORD_COLUMNS` per 1 ms step.

    Give either ``duty`` (open loop, one value per control step) or ``excitation`` (closed
    loop: a P controller follows that reference, as ``sma-gym synth`` records its data).
    ``time_s`` is the end of each control step. The P controller commands every
    ``controller_every`` control steps (a lab logging at 100 Hz also commands at 100 Hz).
    """
    if isinstance(params, str):
        params = preset(params)
    physics = pack(params, effect, effect_values)
    rng = np.random.default_rng(seed)
    if (duty is None) == (excitation is None):
        raise ValueError("give exactly one of duty (open loop) or excitation (closed loop)")
    if excitation is not None:
        stroke = min(params.driver.end_of_travel_m, params.wire.max_stroke_m)
        reference = reference_signal(excitation, duration_s, stroke, rng)
        duty_cmd = np.zeros(reference.size)
        kp = KP_PER_M
    else:
        duty_cmd = np.ascontiguousarray(duty, dtype=float)
        if duty_cmd.ndim != 1 or not np.all(np.isfinite(duty_cmd)):
            raise ValueError("duty: expected a 1-D array of finite values in [0, 1]")
        reference = np.zeros(duty_cmd.size)
        kp = 0.0
    # Long enough pulses for a V/I reading, with margin (§4.1) - only when R is recorded.
    duty_min = 1.2 * params.driver.settling_time_s * params.driver.pwm_frequency_hz if electrical else 0.0
    if substeps is None:
        substeps = rk4_substeps(physics.vector)
    noise = rng.standard_normal((duty_cmd.size, 4))
    out = np.empty((duty_cmd.size, len(RECORD_COLUMNS)))
    _run(
        physics.vector,
        physics.spread_nodes_k,
        duty_cmd,
        reference,
        kp,
        duty_min,
        int(round(REST_S / CONTROL_PERIOD_S)),
        int(controller_every),
        int(substeps),
        CONTROL_PERIOD_S,
        noise,
        float(position_noise_m),
        float(position_resolution_m),
        float(resistance_noise_ohm),
        out,
    )
    result = {name: out[:, j] for j, name in enumerate(RECORD_COLUMNS)}
    result["time_s"] = (np.arange(duty_cmd.size) + 1) * CONTROL_PERIOD_S
    result["reference_m"] = reference
    result["heat_capacity_j_k"] = np.array(physics.vector[P_MCP])
    # The reading at t = 0 (the actuator at rest, last moved extending: -offset / 2).
    result["initial_reading_m"] = np.array(-0.5 * physics.vector[P_ABBE])
    result["substeps"] = np.array(substeps)
    return result


def rk4_substeps(p: np.ndarray) -> int:
    """RK4 steps per control period: h <= INTEGRATOR_STEP_S and h (omega + c_eq / M_t) <= 1.

    omega is the austenitic wire-mass mode, c_eq the viscous damping plus the tanh
    friction's slope F_c / v_s at v = 0 (the stiffest terms of the ODE)."""
    omega = math.sqrt((p[P_DA] * p[P_AREA] / p[P_L0] + p[P_K]) / p[P_MASS])
    damping = (p[P_DAMP] + p[P_FC] / FRICTION_SMOOTHING_M_S) / p[P_MASS]
    h = min(INTEGRATOR_STEP_S, 1.0 / (omega + damping))
    return int(math.ceil(CONTROL_PERIOD_S / h - 1e-9))


def generate(
    params: ActuatorParams | str = "standard",
    *,
    duty: np.ndarray | None = None,
    excitation: str | None = "steps",
    duration_s: float = 40.0,
    effect: str | None = None,
    effect_values: Mapping[str, float] | None = None,
    sample_period_s: float = 1e-3,
    position_noise_m: float = 5e-6,
    position_resolution_m: float = 1e-6,
    resistance_noise_ohm: float = 2e-3,
    electrical: bool = True,
    seed: int = 0,
) -> tuple[MeasuredTrace, dict[str, Any]]:
    """A measured trace in the project's format and its labels (the hidden truth).

    The counterpart of ``sma_gym.diagnosis.synth.generate``: rows at t = 0, Ts, 2 Ts, ...;
    row j holds the readings taken at t_j and the duty commanded from t_j on; row 0 is the
    recording's start (the rest reading, no electrical reading). ``duty`` (open loop) overrides
    ``excitation``. ``electrical=False`` writes a position-only file.
    """
    if isinstance(params, str):
        params = preset(params)
    every = int(round(sample_period_s / CONTROL_PERIOD_S))
    if every < 1 or abs(every * CONTROL_PERIOD_S - sample_period_s) > 1e-9:
        raise ValueError(f"sample_period_s = {sample_period_s!r}: expected a whole multiple of {CONTROL_PERIOD_S:g} s")
    if duty is not None:
        excitation = None
    run = simulate(
        params,
        duty=duty,
        excitation=excitation,
        duration_s=duration_s,
        effect=effect,
        effect_values=effect_values,
        position_noise_m=position_noise_m,
        position_resolution_m=position_resolution_m,
        resistance_noise_ohm=resistance_noise_ohm,
        electrical=electrical,
        seed=seed,
        controller_every=every,
    )
    n = run["duty"].size
    t = np.r_[0.0, run["time_s"]][::every]
    # The duty held over each sample interval is the one commanded at its start.
    duty_col = np.r_[run["duty"], run["duty"][-1]][::every]

    def take(name: str, first: float) -> np.ndarray:
        return np.r_[first, run[name]][::every]

    trace = MeasuredTrace(
        path="independent-synthetic",
        t=t,
        duty=duty_col,
        position=take("position_measured_m", float(run["initial_reading_m"])),
        resistance=take("resistance_measured_ohm", math.nan) if electrical else None,
        current=take("current_measured_a", math.nan) if electrical else None,
        wire_voltage=take("voltage_measured_v", math.nan) if electrical else None,
        conditions={
            "supply_voltage_v": params.driver.supply_voltage_v,
            "pwm_frequency_hz": params.driver.pwm_frequency_hz,
        },
    )
    labels = {
        "generator": "independent",
        "effect": None if effect in (None, "none") else effect,
        "effect_values": {}
        if effect in (None, "none")
        else {**INDEPENDENT_EFFECTS[effect], **dict(effect_values or {})},
        "excitation": "open-loop duty" if excitation is None else excitation,
        "duration_s": n * CONTROL_PERIOD_S,
        "sample_period_s": sample_period_s,
        "position_noise_m": position_noise_m,
        "resistance_noise_ohm": resistance_noise_ohm,
        "electrical": electrical,
        "seed": seed,
        "model": params.name,
    }
    return trace, labels

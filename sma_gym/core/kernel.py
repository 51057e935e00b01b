"""The compiled simulator core: advances n actuators by whole control steps.

One function, :func:`advance`, serves every user: a single env (n = 1, one step per call),
the multiplexer (n actuators with phase-shifted PWM), a vector env of thousands, and the
batched parameter sweeps of model fitting (many steps per call, outputs recorded). Each
actuator has its own row of parameters, so actuators in one call may differ in every
respect. It is compiled with numba: the per-actuator logic (hysteresis, root finding,
PWM edges, friction sticking) branches too much for whole-array numpy to be fast, and an
env step has to cost about as much as a Gymnasium classic-control step.

Integration scheme (one sub-step of length h)
---------------------------------------------
1. Electrical energy of the sub-step from the PWM (averaged or resolved, see
   ``electrical.pwm``) using the resistance at the start of the sub-step.
2. Heat balance: exponential Euler for heating and convection, the convection coefficient
   at the sub-step's mid temperature (stable for any h).
3. Mechanics and transformation: implicit (the theta-method, trapezoidal where the step
   resolves the 250 Hz wire-mass mode and backward Euler where it cannot), solved together
   (``physics.mechanics.solve_step``), unconditionally stable; latent heat inside it.
4. Mechanical work taken from the heat (energy is conserved to rounding in the thermal
   bookkeeping), sensors and the end-of-travel cut updated.

Sub-step length. Nothing here needs a small step for stability, so h is chosen for
accuracy, per actuator and per sub-step: the net heat flow (electrical in, convection out)
may change the temperature by at most ``DT_MAX`` (0.5 K, about 1/70 of the transformation
range; the position moves by at most ~0.25 mm), and h never exceeds ``H_MAX`` (10 ms by
default). A wire heating at full power takes ~2 ms steps, a holding or cooling wire one
step per control period. Within 2 mm of the end-of-travel cut the position may move by at
most ``DX_MAX`` (10 um) per sub-step, and in the cut's switching band (from 0.1 mm below its
release point up to the cut) both bounds tighten to ``DT_BAND`` and ``DX_BAND`` (0.01 K
while the wire conducts, 1 um, widened up to 4x for a wire that heats more slowly than the
report's at 20 V: ``simulator.band_widening``): there the cut's relay cycle times its
switching on fractions of a micrometre of position. The cut
and its release switch where the position crosses them inside a sub-step. With the Stribeck
form of friction, a breakaway and a re-stick are located inside the sub-step too, and a
sliding sleigh takes sub-steps of at most ``SLIP_OMEGA_H`` of the wire-mass mode. PWM-resolved
mode additionally cuts sub-steps at every switching edge. The test suite checks that
refining every bound converges at first order and that the default is within a stated
error of a fine reference.
"""

from __future__ import annotations

import math

import numpy as np

from sma_gym._jit import njit
from sma_gym.core.layout import (
    MAX_SPREAD_NODES,
    P_A_F,
    P_A_S,
    P_ABBE,
    P_ABBE_FORM,
    P_ALPHA_TH_A,
    P_ALPHA_TH_M,
    P_AREA,
    P_C_A,
    P_C_M,
    P_CONV_FORM,
    P_CONV_POWER_SCALE,
    P_D_A,
    P_D_M,
    P_DAMPING,
    P_DT_BAND,
    P_DT_MAX,
    P_DUTY_MAX,
    P_DX_BAND,
    P_DX_MAX,
    P_EOT,
    P_EOT_RELEASE,
    P_EPS0,
    P_F_COULOMB,
    P_F_PRE,
    P_FRICTION_FORM,
    P_H0,
    P_H1,
    P_H2,
    P_H_MAX,
    P_HEAT_CAP,
    P_I_NOISE,
    P_K_SPRING,
    P_LAG_ORDER,
    P_LATENT,
    P_LATENT_COOL,
    P_LENGTH,
    P_M_F,
    P_M_S,
    P_MASS,
    P_N_NODES,
    P_NODE_COOL0,
    P_NODE_HEAT0,
    P_NODE_WEIGHT0,
    P_POS_NOISE,
    P_POS_RESOLUTION,
    P_PWM_PERIOD,
    P_R_NOISE,
    P_R_SERIES,
    P_RESOLVED,
    P_RHO_A,
    P_RHO_M,
    P_RISE_FORM,
    P_SAG_FORM,
    P_SAG_I_REF,
    P_SIGMA0,
    P_SURFACE,
    P_SURR_FORM,
    P_SURR_GAIN,
    P_SURR_TAU,
    P_T_AMB,
    P_T_REF_R,
    P_T_SETTLE,
    P_TAU_FILTER,
    P_TAU_LAG,
    P_TAU_RISE,
    P_TCR_A,
    P_TCR_M,
    P_V_NOISE,
    P_V_SUPPLY,
    S_DIRECTION,
    S_DUTY_CMD,
    S_DUTY_LATCHED,
    S_E_CONVECTED,
    S_E_DISSIPATED,
    S_E_ELECTRIC,
    S_E_LATENT,
    S_EOT_CUT,
    S_FILTER,
    S_FORCE,
    S_I_MEAS,
    S_LAG1,
    S_LAG2,
    S_POS_MEAS,
    S_POWER,
    S_PULSE_START,
    S_PULSE_START_CMD,
    S_PWM_TAU,
    S_R_MEAS,
    S_R_TRUE,
    S_SIGMA,
    S_T,
    S_T_SURR,
    S_TIME,
    S_TRAVEL,
    S_V,
    S_V_MEAS,
    S_W_MECHANICAL,
    S_X,
    S_XI,
    S_XI_NODE0,
)
from sma_gym.electrical.pwm import on_current, pulse_integral
from sma_gym.electrical.sensors import (
    DIRECTION_THRESHOLD_M_S,
    abbe_reading_offset,
    first_order,
    first_order_decay,
    first_order_decayed,
    quantise,
)
from sma_gym.physics.mechanics import (
    FRICTION_STRIBECK,
    WireConstants,
    kinetic_friction,
    solve_step,
    static_friction,
)
from sma_gym.physics.resistance import wire_resistance
from sma_gym.physics.thermal import (
    SURROUNDINGS_ELECTRICAL,
    convection_coefficient,
    exponential_euler,
    surroundings_temperature,
)
from sma_gym.physics.transformation import H_XI_NEW, HYSTERON_ROWS, NODE_COOL, NODE_ROWS, NODE_WEIGHT

NOISE_POSITION, NOISE_RESISTANCE, NOISE_CURRENT, NOISE_VOLTAGE = 0, 1, 2, 3
"""Rows of ``advance``'s ``noise`` (and of one reading's ``noise4``)."""

MIN_SUBSTEP_S = 1e-9
"""Slivers shorter than this (rounding at PWM edges) advance the clock without a step."""

MAX_SUBSTEPS = 4096
"""Most accuracy-driven sub-steps per control step: bounds the work of one step for any
parameters (PWM edges in resolved mode come on top, two per PWM period)."""

CUT_WATCH_M = 2e-3
"""Within this distance below x_eot a powered sub-step is checked for crossing the cut."""

CUT_BAND_MARGIN_M = 0.1e-3
"""The switching band runs from this far below the cut's release point up to the cut."""


_NODES_END = P_NODE_HEAT0 + NODE_ROWS * MAX_SPREAD_NODES
"""An actuator's hysterons are its parameters P_NODE_HEAT0 up to this, read in place: row r of
the transformation's NODE_* rows starts at r * MAX_SPREAD_NODES of that slice."""
if (P_NODE_COOL0, P_NODE_WEIGHT0) != (
    P_NODE_HEAT0 + NODE_COOL * MAX_SPREAD_NODES,
    P_NODE_HEAT0 + NODE_WEIGHT * MAX_SPREAD_NODES,
):  # pragma: no cover - a layout edit that breaks the in-place view
    raise ImportError("core.layout: the hysteron parameters must follow transformation.NODE_* row order")

SUBSTEP_LOCATE, SUBSTEP_ENDS_STUCK, SUBSTEP_ENDS_AT_REST, SUBSTEP_PLAIN = 0, 1, 2, 3
"""Modes of ``_substep``: locate friction events, the step retaken up to a breakaway (ends
stuck) or a re-stick (ends at rest), a step shortened for another reason."""

SLIP_OMEGA_H = 0.05
"""A sleigh sliding with Stribeck friction takes sub-steps of at most this many radians of
the wire-mass mode (omega h, 32 us on the report's wire): a slip lasts about half its period,
and its size depends on the speed reached. Measured (``benchmarks/bench_friction.py``): 0.05
is within 1.9 um of 1 us sub-steps (before the wire reaches the cut) at 1.9-6.8x the Coulomb
form's time, 0.02 within 1.3 um at 3-14x, 0.1 up to 13 um off."""


@njit(cache=True, inline="always", error_model="numpy")
def _mode_stiffness(params, i):
    """Stiffness [N/m] of actuator i's wire-mass mode: the austenitic wire and the spring."""
    return params[i, P_D_A] * params[i, P_AREA] / params[i, P_LENGTH] + params[i, P_K_SPRING]


@njit(cache=True, inline="always", error_model="numpy")
def _has_stribeck(params, i):
    """Whether actuator i has friction in the Stribeck form."""
    return params[i, P_F_COULOMB] > 0.0 and int(params[i, P_FRICTION_FORM]) == FRICTION_STRIBECK


@njit(cache=True, inline="always", error_model="numpy")
def slip_substep(params, i):
    """Longest sub-step [s] while actuator i's sleigh slides with Stribeck friction."""
    return SLIP_OMEGA_H * math.sqrt(params[i, P_MASS] / _mode_stiffness(params, i))


@njit(cache=True, inline="always", error_model="numpy")
def _resistance(state, params, i, x, xi, t_c):
    return wire_resistance(
        x,
        xi,
        t_c,
        params[i, P_RHO_M],
        params[i, P_RHO_A],
        params[i, P_TCR_M],
        params[i, P_TCR_A],
        params[i, P_T_REF_R],
        params[i, P_LENGTH],
        params[i, P_AREA],
    )


@njit(cache=True, inline="always", error_model="numpy")
def _on_current(state, params, i):
    return on_current(
        params[i, P_V_SUPPLY],
        state[i, S_R_TRUE],
        params[i, P_R_SERIES],
        int(params[i, P_SAG_FORM]),
        params[i, P_SAG_I_REF],
    )


@njit(cache=True, inline="always", error_model="numpy")
def sensor_output(state, params, i):
    """Current output of the position-sensor chain (before sampling, noise, quantisation)."""
    if params[i, P_TAU_LAG] > 0.0:
        if params[i, P_LAG_ORDER] >= 2.0:
            return state[i, S_LAG2]
        return state[i, S_LAG1]
    return state[i, S_FILTER]


@njit(cache=True, inline="always", error_model="numpy")
def _convection(state, params, i, t_c):
    """Actuator i's convection coefficient [W/(m^2 K)] at wire temperature ``t_c``."""
    return convection_coefficient(
        t_c,
        params[i, P_H0],
        params[i, P_H1],
        params[i, P_H2],
        state[i, S_T_SURR],
        int(params[i, P_CONV_FORM]),
        params[i, P_CONV_POWER_SCALE],
    )


MEMO_H, MEMO_TAU, MEMO_DECAY = 0, 1, 2
"""Slots of the position filter's memo (see ``_filter_decay``)."""


@njit(cache=True, inline="always", error_model="numpy")
def _filter_decay(memo, h, tau):
    """exp(-h / tau) of the position filter (0 for tau = 0), remembered for the last (h, tau):
    actuators of one model share tau, and a step that is not split has h = the control
    period, so the exponential is taken about once per call instead of once per actuator
    (the same number either way)."""
    if h != memo[MEMO_H] or tau != memo[MEMO_TAU]:
        memo[MEMO_H] = h
        memo[MEMO_TAU] = tau
        memo[MEMO_DECAY] = first_order_decay(h, tau)
    return memo[MEMO_DECAY]


@njit(cache=True, error_model="numpy", _nrt=False)  # called from _advance: see there
def _stribeck_slide(
    state, params, i, h, theta, x0, v0, t_pred, z0, k_ext, b_ext, wire, nodes, xi_old, hyst, n_nodes, mode
):
    """The mechanics of one sub-step with Stribeck friction (see ``_substep``): returns
    (xi, x1, sigma1, t1, friction force, event fraction or 1.0, mode of the retake). Its own
    compiled function, so the common path (no friction, or the Coulomb form) stays lean."""
    f_c = params[i, P_F_COULOMB]
    form = FRICTION_STRIBECK
    area = params[i, P_AREA]
    k_spring = params[i, P_K_SPRING]
    f_pre = params[i, P_F_PRE]
    moving = v0 != 0.0
    stick = not moving
    friction = 0.0
    direction = 0.0
    if moving:
        direction = 1.0 if v0 > 0.0 else -1.0
        friction = direction * kinetic_friction(f_c, v0, form)
    event = 1.0
    next_mode = SUBSTEP_PLAIN
    z = z0
    x1 = x0
    s1 = 0.0
    t1 = t_pred
    corrected = False
    for attempt in range(4):
        # The friction acts over the whole step, constant: theta of it at the step's end
        # and 1 - theta at its start, which b_ext (divided by theta) does not carry.
        z, x1, s1, t1 = solve_step(
            stick, x0, t_pred, z0, k_ext, b_ext - friction / theta, wire, nodes, MAX_SPREAD_NODES, xi_old, hyst, n_nodes
        )
        if stick and attempt > 0:
            break
        if moving or attempt > 0:
            # Sliding (Stribeck): the friction at the step's mean speed (predicted, then
            # corrected: the drop from static to kinetic takes ~60 us after a breakaway,
            # about one slip sub-step), and a velocity that would cross zero is located.
            v_end = direction * (x1 - x0 - h * (1.0 - theta) * v0) / (theta * h)
            if not corrected and v_end > 0.0:
                friction = direction * 0.5 * (kinetic_friction(f_c, v0, form) + kinetic_friction(f_c, v_end, form))
                corrected = True
                continue
            if v_end >= 0.0:
                break
            fraction = abs(v0) / (abs(v0) - v_end)
            if mode == SUBSTEP_LOCATE and fraction * h > MIN_SUBSTEP_S:
                event = fraction
                next_mode = SUBSTEP_ENDS_AT_REST
                break
            if mode == SUBSTEP_ENDS_AT_REST:
                break  # the caller sets the velocity to zero
            friction = 0.0
            stick = True
        else:
            # At rest: held if static friction suffices.
            needed = area * s1 - k_spring * x0 - f_pre
            if abs(needed) <= static_friction(f_c, form):
                break
            direction = 1.0 if needed > 0.0 else -1.0
            friction = direction * kinetic_friction(f_c, v0, form)
            stick = False
            if mode != SUBSTEP_PLAIN:
                if mode == SUBSTEP_ENDS_STUCK:
                    friction = 0.0
                    stick = True
                    break
                # Breakaway (Stribeck, from rest): where the holding force reaches static
                # friction (linear in time within the step), and a slide that starts in a
                # step longer than the slip bound is taken again shorter.
                needed0 = direction * (area * state[i, S_SIGMA] - k_spring * x0 - f_pre)
                limit = static_friction(f_c, form)
                fraction = (limit - needed0) / (direction * needed - needed0) if needed0 < limit else 0.0
                if fraction * h > MIN_SUBSTEP_S:
                    event = fraction
                    next_mode = SUBSTEP_ENDS_STUCK
                    break
                h_slip = slip_substep(params, i)
                if h > h_slip:
                    event = h_slip / h
                    break
    return z, x1, s1, t1, friction, event, next_mode


@njit(cache=True, inline="always", error_model="numpy")
def _substep(state, params, i, h, energy_j, h_conv0, nodes, hyst, n_nodes, memo, mode):
    """One sub-step of length h; returns (1.0, mode), or (fraction, mode of the retake).

    ``h_conv0``: the convection coefficient at the state's temperature (the caller has it
    from the sub-step's length bound). ``memo``: the workspace of :func:`_filter_decay`.

    ``mode`` (``SUBSTEP_*``) only matters for the Stribeck form of friction: ``LOCATE``
    returns the fraction at which the sleigh breaks away or comes to rest inside the step
    (the caller restores the state and takes the step again up to it); ``ENDS_STUCK`` and
    ``ENDS_AT_REST`` are those retaken steps, ``PLAIN`` a step shortened for another reason.
    """
    x0 = state[i, S_X]
    v0 = state[i, S_V]
    t0 = state[i, S_T]
    z0 = state[i, S_XI]
    heat_cap = params[i, P_HEAT_CAP]
    t_amb = params[i, P_T_AMB]
    t_surr = state[i, S_T_SURR]  # = t_amb unless the warm_surroundings effect is on
    area = params[i, P_AREA]
    length = params[i, P_LENGTH]

    # Heat in and convection out to the surroundings: exponential Euler with the coefficient
    # at the sub-step's mid temperature (predicted with the coefficient at T0). Frozen at T0
    # it was first-order, and a wire latched at the cut at 20 V carried 0.07 K of that error
    # into the relay's next release (2.1 K from the 30 us reference, 0.49 K now).
    surface = params[i, P_SURFACE]
    t_pred = exponential_euler(t0, energy_j / h, h_conv0 * surface, heat_cap, t_surr, h)
    h_conv = _convection(state, params, i, 0.5 * (t0 + t_pred))
    t_pred = exponential_euler(t0, energy_j / h, h_conv * surface, heat_cap, t_surr, h)
    e_conv = energy_j - heat_cap * (t_pred - t0)
    gain = params[i, P_SURR_GAIN]
    if gain > 0.0:
        source = energy_j if params[i, P_SURR_FORM] == SURROUNDINGS_ELECTRICAL else e_conv
        state[i, S_T_SURR] = surroundings_temperature(t_surr, t_amb, gain, params[i, P_SURR_TAU], source, h)

    # Mechanics by the theta-method, M (v1 - v0) / h = (1 - theta) F0 + theta F1 and
    # (x1 - x0) / h = (1 - theta) v0 + theta v1, as k_ext x1 = b_ext + A sigma(x1, z).
    # theta = 1 (backward Euler) damps the 250 Hz wire-mass mode numerically by a factor
    # 1 / sqrt(1 + (omega h)^2) per step: about 0.5 over one period at 0.15 ms steps, against
    # the physical 0.32, so the overshoot at the cut depended on the step and the 30 us and
    # 10 us references parted by 0.33 mm / 7.7 K at 20 V. theta -> 1/2 (trapezoidal, no
    # numerical damping) where the step resolves the mode (omega h << 1), 1 where it cannot
    # (omega h >= 1: holding and cooling steps, which must not ring). Friction sticks by
    # backward Euler (theta = 1): a stuck trapezoidal step would reverse the velocity. A
    # sleigh sliding with the Stribeck form steps by the theta-method as without friction:
    # its re-stick is located (below), and backward Euler's damping of the slip (0.86 of
    # its amplitude over half a period at omega h = 0.1) set each jump's size.
    mass = params[i, P_MASS]
    damping = params[i, P_DAMPING]
    k_spring = params[i, P_K_SPRING]
    f_pre = params[i, P_F_PRE]
    f_c = params[i, P_F_COULOMB]
    form = int(params[i, P_FRICTION_FORM])
    stribeck = _has_stribeck(params, i)
    moving = stribeck and v0 != 0.0
    theta = 1.0
    if f_c <= 0.0 or moving:
        omega_h_sq = _mode_stiffness(params, i) * h * h / mass
        theta = 0.5 + 0.5 * min(omega_h_sq, 1.0)
    f0 = area * state[i, S_SIGMA] - damping * v0 - k_spring * x0 - f_pre
    th2 = theta * theta * h * h
    k_ext = mass / th2 + damping / (theta * h) + k_spring
    b_ext = (
        (mass + h * theta * damping) * (x0 / th2 + (1.0 - theta) * v0 / (theta * theta * h))
        + mass * v0 / (h * theta)
        + (1.0 - theta) * f0 / theta
        - f_pre
    )

    wire = WireConstants(
        area,
        length,
        params[i, P_D_A],
        params[i, P_D_M],
        params[i, P_EPS0],
        params[i, P_ALPHA_TH_A],
        params[i, P_ALPHA_TH_M],
        t_amb,
        params[i, P_SIGMA0],
        params[i, P_C_A],
        params[i, P_C_M],
        params[i, P_A_S],
        params[i, P_A_F],
        params[i, P_M_S],
        params[i, P_M_F],
        params[i, P_LATENT],
        params[i, P_LATENT_COOL],
    )
    # The hysterons' fractions at the start of the step, read in place (written only below).
    xi_old = state[i, S_XI_NODE0 : S_XI_NODE0 + MAX_SPREAD_NODES]

    # Friction (coulomb_friction effect, set-valued at rest): try the stuck step first; if
    # holding needs more than static friction, slide with the kinetic force against the
    # motion; if that would reverse the motion within the step, the mass sticks after all.
    # Without friction a single free step. (One solve_step call site, inlined once.)
    # The Stribeck form (static friction above the kinetic) differs in two ways: a sleigh
    # that moves slides until its velocity crosses zero (never stopped by a stuck trial
    # step, whose stopping force mass v0 / h depends on h), and the breakaway and the
    # re-stick are located inside the step (returned as a fraction): the drop from static to
    # kinetic friction makes each slip a jump whose size depends on where it starts, and at
    # sub-step boundaries the trajectory followed the sub-step grid (1 ppm of mass moved it
    # by 16.8 um).
    event = 1.0
    next_mode = SUBSTEP_PLAIN
    friction = 0.0
    if stribeck:
        z, x1, s1, t1, friction, event, next_mode = _stribeck_slide(
            state, params, i, h, theta, x0, v0, t_pred, z0, k_ext, b_ext, wire, nodes, xi_old, hyst, n_nodes, mode
        )
    else:
        stick = f_c > 0.0
        direction = 0.0
        z = z0
        x1 = x0
        s1 = 0.0
        t1 = t_pred
        for attempt in range(3):
            z, x1, s1, t1 = solve_step(
                stick, x0, t_pred, z0, k_ext, b_ext - friction, wire, nodes, MAX_SPREAD_NODES, xi_old, hyst, n_nodes
            )
            if f_c <= 0.0:
                break
            if attempt == 0:
                needed = area * s1 - k_spring * x0 - f_pre + mass * v0 / h
                if abs(needed) <= static_friction(f_c, form):
                    break
                direction = 1.0 if needed > 0.0 else -1.0
                friction = direction * kinetic_friction(f_c, v0, form)
                stick = False
            elif attempt == 1:
                if (x1 - x0) * direction >= 0.0:
                    break
                friction = 0.0
                stick = True
            else:
                break
    if event < 1.0:
        return event, next_mode  # the caller restores the state and takes the step again

    dx = x1 - x0
    v1 = (dx - h * (1.0 - theta) * v0) / (theta * h)
    work = area * (theta * s1 + (1.0 - theta) * state[i, S_SIGMA]) * dx
    # The wire's mechanical work comes out of its heat: keeps the energy balance closed.
    t1 -= work / heat_cap

    state[i, S_X] = x1
    state[i, S_V] = v1
    state[i, S_T] = t1
    state[i, S_SIGMA] = s1
    state[i, S_XI] = z
    for k in range(n_nodes):
        state[i, S_XI_NODE0 + k] = hyst[H_XI_NEW, k]
    state[i, S_E_ELECTRIC] += energy_j
    state[i, S_E_CONVECTED] += e_conv
    state[i, S_W_MECHANICAL] += work
    v_mean = dx / h
    state[i, S_E_DISSIPATED] += damping * v_mean * v_mean * h + friction * dx
    state[i, S_E_LATENT] += heat_cap * (wire.latent_heat if z < z0 else wire.latent_cool) * (z - z0)
    state[i, S_FORCE] = k_spring * x1 + f_pre
    state[i, S_R_TRUE] = _resistance(state, params, i, x1, z, t1)

    # Sensor chain: Abbe offset -> low-pass filter -> extra lag.
    if v1 > DIRECTION_THRESHOLD_M_S:
        state[i, S_DIRECTION] = 1.0
    elif v1 < -DIRECTION_THRESHOLD_M_S:
        state[i, S_DIRECTION] = -1.0
    state[i, S_TRAVEL] += abs(dx)
    raw = x1 + abbe_reading_offset(
        params[i, P_ABBE], state[i, S_DIRECTION], state[i, S_TRAVEL], int(params[i, P_ABBE_FORM])
    )
    filtered = first_order_decayed(state[i, S_FILTER], raw, _filter_decay(memo, h, params[i, P_TAU_FILTER]))
    state[i, S_FILTER] = filtered
    tau_lag = params[i, P_TAU_LAG]
    if tau_lag > 0.0:
        if params[i, P_LAG_ORDER] >= 2.0:
            stage1 = first_order(state[i, S_LAG1], filtered, h, 0.5 * tau_lag)
            state[i, S_LAG1] = stage1
            state[i, S_LAG2] = first_order(state[i, S_LAG2], stage1, h, 0.5 * tau_lag)
        else:
            state[i, S_LAG1] = first_order(state[i, S_LAG1], filtered, h, tau_lag)

    # Driver's end-of-travel cut (a limit switch on the true position, with hysteresis).
    if x1 >= params[i, P_EOT]:
        state[i, S_EOT_CUT] = 1.0
    elif state[i, S_EOT_CUT] > 0.5 and x1 < params[i, P_EOT] - params[i, P_EOT_RELEASE]:
        state[i, S_EOT_CUT] = 0.0
    return 1.0, next_mode


@njit(cache=True, inline="always", error_model="numpy")
def _located_substep(
    state, params, i, seg, power, h_conv0, switched_on, tau, t_on, drive, stribeck, saved, nodes, hyst, n_nodes, memo
):
    """Take one sub-step of at most ``seg`` seconds, ending it early at a located event.

    ``drive``: power would flow if the cut released (it is watched for then). Returns the
    length taken.
    """
    resolved = params[i, P_RESOLVED] != 0.0
    # The end-of-travel cut switches the power off where the position crosses x_eot (and
    # back on where it falls below the release point), not at the end of the sub-step
    # that crosses it: if a sub-step ends past the switching point, it is taken again up
    # to the crossing (interpolated in position: the mechanics are stiff, so x is nearly
    # linear in time within a sub-step) and the rest of the step runs switched.
    eot = params[i, P_EOT]
    x_now = state[i, S_X]
    if state[i, S_EOT_CUT] < 0.5:
        threshold = eot
        watch = power > 0.0 and x_now > eot - CUT_WATCH_M
    else:
        # Release: where power would flow (averaged: any duty; resolved: inside a pulse).
        threshold = eot - params[i, P_EOT_RELEASE]
        watch = drive and x_now < threshold + CUT_WATCH_M
    if watch or stribeck:
        for r in range(saved.shape[0]):
            saved[r] = state[i, r]
    # A step is taken again, shorter, up to a friction event it locates (Stribeck form)
    # and then up to the cut's crossing: at most three tries.
    mode = SUBSTEP_LOCATE if stribeck else SUBSTEP_PLAIN
    cut_located = False
    for _ in range(3):
        energy = power * seg
        if resolved:
            if switched_on:
                # The rise of the current is timed from the switch-on edge.
                energy = power * pulse_integral(t_on, t_on + seg, params[i, P_TAU_RISE], int(params[i, P_RISE_FORM]))
            state[i, S_PWM_TAU] = tau + seg
        event, next_mode = _substep(state, params, i, seg, energy, h_conv0, nodes, hyst, n_nodes, memo, mode)
        if event < 1.0:
            for r in range(saved.shape[0]):
                state[i, r] = saved[r]
            seg = event * seg
            mode = next_mode
            continue
        if mode == SUBSTEP_ENDS_AT_REST:
            state[i, S_V] = 0.0  # the located re-stick
        if not watch or cut_located:
            break
        x_start = saved[S_X]
        x_end = state[i, S_X]
        if saved[S_EOT_CUT] < 0.5:
            crossed = x_end >= threshold
            switched = 1.0
        else:
            crossed = x_end < threshold
            switched = 0.0
        if not crossed:
            break
        fraction = (threshold - x_start) / (x_end - x_start) if x_end != x_start else 0.0
        fraction = min(max(fraction, 0.0), 1.0)
        for r in range(saved.shape[0]):
            state[i, r] = saved[r]
        state[i, S_EOT_CUT] = switched
        seg = fraction * seg
        mode = SUBSTEP_PLAIN
        cut_located = True
        if seg < MIN_SUBSTEP_S:
            break
    return seg


# Inlined: a call that passes three arrays cost about a tenth of a PWM-averaged step.
@njit(cache=True, inline="always", error_model="numpy")
def _take_readings(state, params, i, on_time, t_settle, noise4):
    """Sample position (always) and V, I, R (only if this pulse lasts past the settling).

    ``noise4``: this reading's standard normals, in the order of ``advance``'s ``noise``."""
    value = sensor_output(state, params, i) + params[i, P_POS_NOISE] * noise4[NOISE_POSITION]
    state[i, S_POS_MEAS] = quantise(value, params[i, P_POS_RESOLUTION])
    if on_time > 0.0 and on_time >= t_settle and state[i, S_EOT_CUT] < 0.5:
        current = _on_current(state, params, i)
        current_meas = current + params[i, P_I_NOISE] * noise4[NOISE_CURRENT]
        voltage_meas = current * state[i, S_R_TRUE] + params[i, P_V_NOISE] * noise4[NOISE_VOLTAGE]
        state[i, S_I_MEAS] = current_meas
        state[i, S_V_MEAS] = voltage_meas
        state[i, S_R_MEAS] = voltage_meas / current_meas + params[i, P_R_NOISE] * noise4[NOISE_RESISTANCE]
    else:
        state[i, S_I_MEAS] = np.nan
        state[i, S_V_MEAS] = np.nan
        state[i, S_R_MEAS] = np.nan


@njit(cache=True, inline="always", error_model="numpy")
def _control_step(state, params, i, duty_cmd, dt, noise4, nodes, hyst, n_nodes, saved, memo):
    duty = duty_cmd
    if duty < 0.0:
        duty = 0.0
    duty_max = params[i, P_DUTY_MAX]
    if duty > duty_max:
        duty = duty_max
    state[i, S_DUTY_CMD] = duty
    e_start = state[i, S_E_ELECTRIC]
    period = params[i, P_PWM_PERIOD]
    tau_rise = params[i, P_TAU_RISE]
    rise_form = int(params[i, P_RISE_FORM])
    t_settle = params[i, P_T_SETTLE]
    h_max = params[i, P_H_MAX]

    resolved = params[i, P_RESOLVED] != 0.0
    stribeck = _has_stribeck(params, i)
    dt_max_k = params[i, P_DT_MAX]
    heat_cap = params[i, P_HEAT_CAP]
    # PWM-averaged: each sub-step gets the mean energy of the pulses it spans.
    mean_fraction = pulse_integral(0.0, duty * period, tau_rise, rise_form) / period
    # PWM-resolved: sub-steps are also cut at every switching edge.
    edge_tol = 1e-12 * period
    remaining = dt
    while remaining > MIN_SUBSTEP_S:
        switched_on = False
        cut_in_pulse = False  # resolved: latched by the cut inside this period's pulse
        if resolved:
            tau = state[i, S_PWM_TAU]
            if tau >= period - edge_tol:
                # A new PWM period starts: sample the sensors at the end of the old one and
                # latch the duty commanded now (the FPGA computes the ticks per period).
                tau -= period
                if tau < 0.0:
                    tau = 0.0
                state[i, S_PWM_TAU] = tau
                state[i, S_DUTY_LATCHED] = duty
                state[i, S_PULSE_START] = state[i, S_PULSE_START_CMD] * period
                _take_readings(state, params, i, duty * period, t_settle, noise4)
            # The pulse is [pulse_start, pulse_start + on_time) of the period: pulse_start is 0
            # on fixed slots (the slot is the phase-shifted period) and where the previous
            # actuators' pulses end on a shared budget. 0.0 + x == x, so fixed slots are
            # bit for bit what they were.
            pulse_start = state[i, S_PULSE_START]
            on_time = state[i, S_DUTY_LATCHED] * period
            pulse_end = pulse_start + on_time
            if tau < pulse_start - edge_tol:
                switched_on = False
                edge = pulse_start
            else:
                in_pulse = tau < pulse_end - edge_tol
                switched_on = in_pulse and state[i, S_EOT_CUT] < 0.5
                # A wire latched by the cut during the pulse conducts again from where its
                # position falls below the release point (located below), for the rest of
                # the pulse: the sub-step still ends at the pulse's end.
                cut_in_pulse = in_pulse and not switched_on
                edge = pulse_end if in_pulse else period
            seg = edge - tau
            if seg < MIN_SUBSTEP_S:
                # Rounding sliver just before an edge: move the clock past it, no integration.
                state[i, S_PWM_TAU] = edge
                remaining -= edge - tau
                continue
            power = 0.0
            if switched_on:
                current = _on_current(state, params, i)
                power = current * current * state[i, S_R_TRUE]
        else:
            seg = remaining
            power = 0.0
            if state[i, S_EOT_CUT] < 0.5 and mean_fraction > 0.0:
                current = _on_current(state, params, i)
                power = current * current * state[i, S_R_TRUE] * mean_fraction
        if seg > remaining:
            seg = remaining
        if seg > h_max:
            seg = h_max
        seg_edge = seg
        # Accuracy: the temperature may change by at most dt_max_k per sub-step.
        t_now = state[i, S_T]
        h_conv = _convection(state, params, i, t_now)
        rate = abs(power - h_conv * params[i, P_SURFACE] * (t_now - state[i, S_T_SURR])) / heat_cap
        # In the switching band (from just below the release point up to the cut) both
        # bounds tighten: the cut's relay cycle times its switching on the position. The
        # temperature bound only while the wire conducts: the fast re-heat after a release is
        # what it resolves. Measured: the same accuracy against the fine reference, and envs
        # driven by random actions, whose wires sit latched open at the cut much of the time,
        # ran 0.60 -> 0.72x Pendulum-v1 (benchmarks/bench_integration.py, bench_envs.py).
        in_band = state[i, S_X] > params[i, P_EOT] - params[i, P_EOT_RELEASE] - CUT_BAND_MARGIN_M
        dt_lim = min(dt_max_k, params[i, P_DT_BAND]) if in_band and power > 0.0 else dt_max_k
        if rate * seg > dt_lim:
            seg = dt_lim / rate
        # ... and, approaching the end-of-travel cut, the position by at most P_DX_MAX: there
        # the wire stops abruptly, and the stress transient of that stop moves hysterons
        # irreversibly, so it must be resolved. Elsewhere the motion follows the temperature
        # quasi-statically and the temperature bound suffices.
        speed = abs(state[i, S_V])
        dx_lim = min(params[i, P_DX_MAX], params[i, P_DX_BAND]) if in_band else params[i, P_DX_MAX]
        if speed * seg > dx_lim and state[i, S_X] > params[i, P_EOT] - CUT_WATCH_M:
            seg = dx_lim / speed
        # ... and a sleigh sliding with Stribeck friction resolves its slip (see _substep).
        if stribeck and state[i, S_V] != 0.0:
            seg = min(seg, slip_substep(params, i))
        # Bounded work whatever the parameters: never more than MAX_SUBSTEPS per control step
        # (a physically meaningless model then integrates inaccurately, but it returns).
        if seg < dt / MAX_SUBSTEPS:
            seg = min(dt / MAX_SUBSTEPS, seg_edge)
        if not resolved:
            # Split what is left evenly rather than leaving a sliver at the end.
            pieces = math.ceil(remaining / seg - 1e-9)
            seg = remaining / pieces
        t_on = max(tau - pulse_start, 0.0) if resolved and switched_on else 0.0
        drive = cut_in_pulse if resolved else mean_fraction > 0.0
        seg = _located_substep(
            state,
            params,
            i,
            seg,
            power,
            h_conv,
            switched_on,
            tau if resolved else 0.0,
            t_on,
            drive,
            stribeck,
            saved,
            nodes,
            hyst,
            n_nodes,
            memo,
        )
        remaining -= seg
    if resolved:
        if remaining > 0.0:
            state[i, S_PWM_TAU] += remaining  # keep the PWM clock exact
    else:
        _take_readings(state, params, i, duty * period, t_settle, noise4)

    state[i, S_POWER] = (state[i, S_E_ELECTRIC] - e_start) / dt
    state[i, S_TIME] += dt


@njit(cache=True, error_model="numpy", nogil=True)
def advance(state, params, duty, dt, noise, record, record_fields):
    """Advance every actuator by ``duty.shape[0]`` control steps of ``dt`` seconds.

    Parameters
    ----------
    state : (n, N_STATE) float64, updated in place (one row per actuator).
    params : (n, N_PARAMS) float64.
    duty : (n_steps, n) float64, commanded duty per step (clipped to [0, DUTY_MAX]).
    noise : (n_steps, 4, n) standard normals for the position, resistance, current and
        voltage readings, or an array with n_steps = 0 for noise-free sensors.
    record : (n_steps, len(record_fields), n) filled with the state fields after each step, or
        an array with n_steps = 0 to record nothing.
    record_fields : int64 array of state fields (layout indices) to record.
    """
    hyst = np.empty((HYSTERON_ROWS, MAX_SPREAD_NODES))
    noise4 = np.zeros(4)
    saved = np.empty(state.shape[1])
    memo = np.full(3, np.nan)
    _advance(state, params, duty, dt, noise, record, record_fields, hyst, noise4, saved, memo)


# Compiled without numba's reference counting (``_nrt=False``, as numba's own hot helpers
# are): with it, every array handed to an inlined function and every view was a pair of
# atomic updates, about 45 per actuator and step and a fifth of the simulator's time. Nothing
# here allocates (``advance`` passes the workspaces in) or outlives the call, so nothing
# needs counting; an allocation added here fails to compile rather than leak.
@njit(cache=True, error_model="numpy", nogil=True, _nrt=False)
def _advance(state, params, duty, dt, noise, record, record_fields, hyst, noise4, saved, memo):
    n = state.shape[0]
    n_steps = duty.shape[0]
    have_noise = noise.shape[0] > 0
    have_record = record.shape[0] > 0
    n_rec = record_fields.shape[0]
    # Each actuator's state and parameters are contiguous (actuator-major), so the loop streams
    # through memory once per step however many actuators there are.
    for s in range(n_steps):
        for i in range(n):
            n_nodes = int(params[i, P_N_NODES])
            nodes = params[i, P_NODE_HEAT0:_NODES_END]
            if have_noise:
                for r in range(4):
                    noise4[r] = noise[s, r, i]
            _control_step(state, params, i, duty[s, i], dt, noise4, nodes, hyst, n_nodes, saved, memo)
            if have_record:
                for j in range(n_rec):
                    record[s, j, i] = state[i, record_fields[j]]

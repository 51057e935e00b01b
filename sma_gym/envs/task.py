"""The tracking task on top of the simulator: observations, reward, termination.

One compiled function computes them for n columns of a :class:`~sma_gym.Simulator`, so the
single env (n = 1), the multiplexed env (n actuators in one env) and the native vector env
(one column per sub-env) share the same code.

Observation features (float32, each scaled to order one and clipped to the Box bounds):

================== ===================================================== ============
feature            definition                                            bounds
================== ===================================================== ============
position           measured position / stroke                            [-0.5, 1.5]
resistance         10 * (R / R_cold - 1), last valid reading held        [-3, 3]
resistance_valid   1 if R could be read in this step (pulse >= 50 us)    [0, 1]
current            10 * (I / I_cold - 1), last valid reading held        [-3, 3]
voltage            10 * (V / V_supply - 1), last valid reading held      [-3, 3]
reference          r(t) / stroke                                         [-0.5, 1.5]
reference_rate     r'(t) * 1 s / stroke                                  [-10, 10]
preview_0.2s       r(t + 0.2 s) / stroke                                 [-0.5, 1.5]
preview_0.5s       r(t + 0.5 s) / stroke                                 [-0.5, 1.5]
preview_1s         r(t + 1 s) / stroke (a reversal must be anticipated by  [-0.5, 1.5]
                   about the time it takes to cool through the hysteresis)
last_duty          duty applied in the last step                         [0, 1]
error              (r(t) - measured position) / stroke                   [-2, 2]
================== ===================================================== ============

``stroke`` is the usable stroke: the driver's end-of-travel position if it has one, else
eps0 * l0. ``R_cold``, ``I_cold`` are the cold extended wire's resistance and current.

Reward (per actuator, per step)::

    reward = -|x_true - r(t)| / stroke  -  energy_weight * P_el / P_full

with ``P_el`` the mean electrical power of the step and ``P_full = V^2 / R_cold`` the power
at duty 1, so the energy term is at most ``energy_weight`` per step.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from sma_gym._jit import njit
from sma_gym.core import layout as L
from sma_gym.envs.references import evaluate

if TYPE_CHECKING:
    from sma_gym.params import ActuatorParams

TRACKING = 0
SELF_SENSING = 1

FEATURES = {
    TRACKING: (
        "position",
        "resistance",
        "resistance_valid",
        "reference",
        "reference_rate",
        "preview_0.2s",
        "preview_0.5s",
        "preview_1s",
        "last_duty",
        "error",
    ),
    SELF_SENSING: (
        "resistance",
        "resistance_valid",
        "current",
        "voltage",
        "reference",
        "reference_rate",
        "preview_0.2s",
        "preview_0.5s",
        "preview_1s",
        "last_duty",
    ),
}
_BOUNDS = {
    "position": (-0.5, 1.5),
    "resistance": (-3.0, 3.0),
    "resistance_valid": (0.0, 1.0),
    "current": (-3.0, 3.0),
    "voltage": (-3.0, 3.0),
    "reference": (-0.5, 1.5),
    "reference_rate": (-10.0, 10.0),
    "preview_0.2s": (-0.5, 1.5),
    "preview_0.5s": (-0.5, 1.5),
    "preview_1s": (-0.5, 1.5),
    "last_duty": (0.0, 1.0),
    "error": (-2.0, 2.0),
}
PREVIEW_1_S = 0.2
PREVIEW_2_S = 0.5
PREVIEW_3_S = 1.0


def bounds(mode: int) -> tuple[np.ndarray, np.ndarray]:
    names = FEATURES[mode]
    low = np.array([_BOUNDS[n][0] for n in names], dtype=np.float32)
    high = np.array([_BOUNDS[n][1] for n in names], dtype=np.float32)
    return low, high


def stroke_of(params_row: np.ndarray) -> float:
    eot = params_row[L.P_EOT]
    return float(eot) if math.isfinite(eot) else float(params_row[L.P_EPS0] * params_row[L.P_LENGTH])


def stroke_of_actuator(params: ActuatorParams) -> float:
    """:func:`stroke_of` for parameters not yet packed (to check make kwargs)."""
    eot = params.driver.end_of_travel_m
    return float(eot) if math.isfinite(eot) else float(params.wire.max_stroke_m)


class TaskState:
    """Per-column task data: the reference, held sensor readings, last duty."""

    def __init__(self, n: int):
        from sma_gym.envs.references import N_PARAMS, N_WAYPOINTS

        self.n = n
        self.kind = np.zeros(n, dtype=np.int64)
        self.params = np.zeros((n, N_PARAMS))
        self.wp_t = np.full((n, N_WAYPOINTS), np.inf)
        self.wp_x = np.zeros((n, N_WAYPOINTS))
        self.held = np.zeros((n, 3))  # last valid R, I, V
        self.last_duty = np.zeros(n)
        self.reference_now = np.zeros(n)
        self.references: list = [None] * n

    def set_reference(self, i: int, ref) -> None:
        self.kind[i] = ref.kind
        self.params[i] = ref.params
        self.wp_t[i] = ref.waypoint_t
        self.wp_x[i] = ref.waypoint_x
        self.references[i] = ref

    def reset_column(self, i: int, params_row: np.ndarray) -> None:
        r_cold = params_row[L.P_RHO_M] * params_row[L.P_LENGTH] / params_row[L.P_AREA]
        v = params_row[L.P_V_SUPPLY]
        self.held[i] = (r_cold, v / r_cold, v)
        self.last_duty[i] = 0.0


@njit(cache=True, error_model="numpy")
def task_outputs(
    state,
    params,
    mode,
    kind,
    ref_p,
    wp_t,
    wp_x,
    held,
    last_duty,
    energy_weight,
    overheat_c,
    obs_out,
    reward_out,
    term_out,
    ref_out,
    columns,
):
    """Fill observation rows, rewards, termination flags and references for ``columns``."""
    for j in range(columns.shape[0]):
        i = columns[j]
        p = params[i]
        s = state[i]
        eot = p[L.P_EOT]
        stroke = eot if eot < 1e9 else p[L.P_EPS0] * p[L.P_LENGTH]
        r_cold = p[L.P_RHO_M] * p[L.P_LENGTH] / p[L.P_AREA]
        v_supply = p[L.P_V_SUPPLY]
        i_cold = v_supply / r_cold
        t = s[L.S_TIME]
        r, rate = evaluate(kind[i], ref_p[i], wp_t[i], wp_x[i], t)
        r1 = evaluate(kind[i], ref_p[i], wp_t[i], wp_x[i], t + PREVIEW_1_S)[0]
        r2 = evaluate(kind[i], ref_p[i], wp_t[i], wp_x[i], t + PREVIEW_2_S)[0]
        r3 = evaluate(kind[i], ref_p[i], wp_t[i], wp_x[i], t + PREVIEW_3_S)[0]
        valid = 0.0
        if s[L.S_R_MEAS] == s[L.S_R_MEAS]:  # not NaN: a reading was taken
            valid = 1.0
            held[i, 0] = s[L.S_R_MEAS]
            held[i, 1] = s[L.S_I_MEAS]
            held[i, 2] = s[L.S_V_MEAS]
        x_meas = s[L.S_POS_MEAS] / stroke
        rn = r / stroke
        res = 10.0 * (held[i, 0] / r_cold - 1.0)
        if mode == TRACKING:
            feats = (
                x_meas,
                res,
                valid,
                rn,
                rate / stroke,
                r1 / stroke,
                r2 / stroke,
                r3 / stroke,
                last_duty[i],
                rn - x_meas,
            )
            lows = (-0.5, -3.0, 0.0, -0.5, -10.0, -0.5, -0.5, -0.5, 0.0, -2.0)
            highs = (1.5, 3.0, 1.0, 1.5, 10.0, 1.5, 1.5, 1.5, 1.0, 2.0)
        else:
            feats = (
                res,
                valid,
                10.0 * (held[i, 1] / i_cold - 1.0),
                10.0 * (held[i, 2] / v_supply - 1.0),
                rn,
                rate / stroke,
                r1 / stroke,
                r2 / stroke,
                r3 / stroke,
                last_duty[i],
            )
            lows = (-3.0, 0.0, -3.0, -3.0, -0.5, -10.0, -0.5, -0.5, -0.5, 0.0)
            highs = (3.0, 1.0, 3.0, 3.0, 1.5, 10.0, 1.5, 1.5, 1.5, 1.0)
        for k in range(len(feats)):
            value = feats[k]
            if value < lows[k]:
                value = lows[k]
            elif value > highs[k]:
                value = highs[k]
            obs_out[j, k] = value
        p_full = v_supply * v_supply / r_cold
        reward_out[j] = -abs(s[L.S_X] - r) / stroke - energy_weight * s[L.S_POWER] / p_full
        term_out[j] = s[L.S_T] > overheat_c
        ref_out[j] = r

"""Sensors (report §3.1, §3.4, §4.1).

Position: an Alps resistive sensor, low-pass filtered against switching noise (first
order, ``Sensors.position_filter_cutoff_hz``), sampled near the end of each PWM period
(PWM-resolved mode) or at the end of each control step (PWM-averaged mode), plus optional
white noise and quantisation. The ``abbe_offset`` and ``sensor_lag`` effects act on this
chain (offset before the filter, extra lag after it).

Resistance, current and voltage: measured as V / I during the on-time of a pulse, once
the ~50 us electrical transient has settled (§4.1). A period whose pulse is shorter than
the settling time (or a period with the end-of-travel cut active) gives no reading: the
simulator then reports NaN for the resistance, current and voltage readings, and the envs
expose a validity flag and hold the last valid value.
"""

from __future__ import annotations

import math

from sma_gym._jit import njit

ABBE_STEP = 0
ABBE_WEAR = 1
"""Synthetic-data form of ``abbe_offset``: the offset grows linearly with accumulated travel,
from 30 % of its value to all of it over the first 50 mm."""
ABBE_FORMS = {"default": ABBE_STEP, "wear": ABBE_WEAR}
"""Code of each form of the ``abbe_offset`` effect."""

LAG_ORDERS = {"default": 1, "second-order": 2}
"""Order of the lag of each form of the ``sensor_lag`` effect."""

DIRECTION_THRESHOLD_M_S = 1e-4
"""Speed above which a new direction of motion is registered (Abbe offset switching)."""


@njit(cache=True, inline="always", error_model="numpy")
def first_order_decay(h, tau):
    """exp(-h / tau): the share of its old value a first-order lag keeps over h (0 for tau = 0)."""
    return math.exp(-h / tau) if tau > 0.0 else 0.0


@njit(cache=True, inline="always", error_model="numpy")
def first_order_decayed(y, u, decay):
    """The step of :func:`first_order` with its :func:`first_order_decay` given (0: y = u)."""
    if decay == 0.0:
        return u
    return u + (y - u) * decay


@njit(cache=True, inline="always", error_model="numpy")
def first_order(y, u, h, tau):
    """Exact step of y' = (u - y) / tau over h with u held (tau = 0: y = u)."""
    return first_order_decayed(y, u, first_order_decay(h, tau))


@njit(cache=True, inline="always", error_model="numpy")
def abbe_reading_offset(offset_m, direction, travel_m, form):
    """Offset added to the true position by the Abbe error [m]."""
    if offset_m == 0.0:
        return 0.0
    scale = 1.0
    if form == ABBE_WEAR:
        scale = 0.3 + 0.7 * min(1.0, travel_m / 0.05)
    return 0.5 * direction * offset_m * scale


@njit(cache=True, inline="always", error_model="numpy")
def quantise(value, step):
    if step <= 0.0:
        return value
    return step * math.floor(value / step + 0.5)

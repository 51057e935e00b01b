"""Heat balance of the wire (report §5.4)::

    m c_p T' = P_el - h(T) A_c (T - T_amb) - P_mech + Delta_H m xi'

with h(T) = h0 + h2 T^2 (T in degC, eq. 5.10). The last two terms are ours: P_mech, the
power the wire delivers to the mechanism, closes the energy balance (it is ~0.5 % of P_el,
the actuator's efficiency, §8); the latent heat Delta_H is the wire's own (24.2 J/g, the
datasheet's: ``Wire.latent_heat_j_kg``), which the report's model lacks, and the
``latent_heat`` effect changes it.

The convective part is integrated with the exponential (exact-for-constant-coefficient)
Euler step, which is stable for any step length and any h: a thin wire under a strong fan
cannot make it blow up, unlike the explicit Euler step.
"""

from __future__ import annotations

import math

from sma_gym._jit import njit

CONVECTION_LAW = 0
"""h = h0 + h1 (T - T_amb) + h2 T^2 (h1 from the ``convection_change`` effect)."""

CONVECTION_POWER = 1
"""Synthetic-data form of ``convection_change``: nominal h times a natural-convection
power law in the excess temperature, scale * ((T - T_amb) / 80 K) ** 0.25."""

CONVECTION_FORMS = {"default": CONVECTION_LAW, "power": CONVECTION_POWER}
"""Code of each form of the ``convection_change`` effect."""

LATENT_COOLING_FACTORS = {"default": 1.0, "asymmetric": 0.7}
"""Latent heat released while cooling, as a fraction of that absorbed while heating, for
each form of the ``latent_heat`` effect."""

SURROUNDINGS_CONVECTED = 0
"""warm_surroundings 'default': the surroundings take up the heat the wire convects."""
SURROUNDINGS_ELECTRICAL = 1
"""warm_surroundings 'electrical': they are warmed by the electrical power instead (contacts,
clamps and driver heating with the current), a different shape for synthetic data."""
SURROUNDINGS_FORMS = {"default": SURROUNDINGS_CONVECTED, "electrical": SURROUNDINGS_ELECTRICAL}


@njit(cache=True, inline="always", error_model="numpy")
def surroundings_temperature(t_surr, t_amb, gain_k_j, tau_s, source_j, h):
    """Temperature of the surroundings after a sub-step of ``h`` [s] in which they took up
    ``source_j`` [J] (warming ``gain_k_j`` [K/J]) while relaxing to ``t_amb`` with time
    constant ``tau_s``: dT_s/dt = gain P - (T_s - T_amb) / tau, exact for a constant P, so
    any sub-step length is stable."""
    decay = math.exp(-h / tau_s)
    return t_amb + (t_surr - t_amb) * decay + gain_k_j * source_j * tau_s / h * (1.0 - decay)


@njit(cache=True, inline="always", error_model="numpy")
def convection_coefficient(t_c, h0, h1, h2, t_amb, form, power_scale):
    """h(T) [W/(m^2 K)], never negative."""
    h = h0 + h1 * (t_c - t_amb) + h2 * t_c * t_c
    if form == CONVECTION_POWER:
        excess = t_c - t_amb
        if excess < 1.0:
            excess = 1.0
        h = (h0 + h2 * t_c * t_c) * power_scale * (excess / 80.0) ** 0.25
    if h < 0.0:
        h = 0.0
    return h


@njit(cache=True, inline="always", error_model="numpy")
def exponential_euler(t0, power_w, conductance_w_k, heat_capacity_j_k, t_amb, h):
    """Temperature after ``h`` seconds of m c_p T' = P - G (T - T_amb), G frozen at T0."""
    if conductance_w_k <= 0.0:
        return t0 + power_w * h / heat_capacity_j_k
    rate = conductance_w_k / heat_capacity_j_k
    decay = math.exp(-rate * h)
    t_inf = t_amb + power_w / conductance_w_k
    return t_inf + (t0 - t_inf) * decay


def steady_temperature_c(power_w, surface_m2, h0, h2, t_amb, h1=0.0):
    """Temperature at which convection carries away ``power_w`` (numpy, bisection).

    Used for bounds (tests) and the holding-duty calibration.
    """
    import numpy as np

    power = np.asarray(power_w, dtype=float)
    lo = np.full_like(power, t_amb)
    hi = np.full_like(power, t_amb + 5000.0)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        h = np.maximum(h0 + h1 * (mid - t_amb) + h2 * mid * mid, 0.0)
        loss = h * surface_m2 * (mid - t_amb)
        above = loss > power
        hi = np.where(above, mid, hi)
        lo = np.where(above, lo, mid)
    return 0.5 * (lo + hi)

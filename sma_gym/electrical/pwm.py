"""Supply, MOSFET switch and PWM (report §3.1, §3.4, §4.1, §8).

The switch connects the wire to the supply for ``duty * period`` at the start of every PWM
period. Two ways to simulate it, with the same physics:

* PWM-averaged (default): each integration step receives the mean energy of the pulses it
  spans; fast, no ripple.
* PWM-resolved: integration steps are cut at every switching edge and receive the energy of
  the part of the pulse they cover; this gives the temperature ripple, the sampling of the
  sensors at the right instants, and the multiplexer (one PWM swept over n actuators).

Energy of a pulse. While on, the wire carries I = V / (R + R_s) (``supply_sag`` adds the
series resistance R_s) and takes I^2 R. With the ``pulse_settling`` effect the current
rises as 1 - exp(-t / tau) after each switch-on, so a pulse of width w delivers
P * integral_0^w (1 - exp(-s / tau))^2 ds, which for long pulses is P * (w - 1.5 tau).
"""

from __future__ import annotations

import math

from sma_gym._jit import njit

RISE_EXPONENTIAL = 0
RISE_DELAY = 1
"""Synthetic-data form of ``pulse_settling``: no current for 1.5 tau, then full current
(the same energy loss per long pulse as the exponential rise)."""
RISE_FORMS = {"default": RISE_EXPONENTIAL, "delay": RISE_DELAY}
"""Code of each form of the ``pulse_settling`` effect."""

SAG_RESISTOR = 0
SAG_QUADRATIC = 1
"""Synthetic-data form of ``supply_sag``: the sag grows with the square of the current,
equal to the resistor's at the reference current."""
SAG_FORMS = {"default": SAG_RESISTOR, "quadratic": SAG_QUADRATIC}
"""Code of each form of the ``supply_sag`` effect."""


@njit(cache=True, inline="always", error_model="numpy")
def pulse_integral(a, b, tau, form):
    """Integral over [a, b] (time since switch-on, s) of the normalised power (0..1)."""
    if b <= a:
        return 0.0
    if tau <= 0.0:
        return b - a
    if form == RISE_DELAY:
        start = 1.5 * tau
        if a > start:
            start = a
        return b - start if b > start else 0.0
    # From the switch-on edge (a = 0, every PWM-averaged step) exp(-0) = 1 exactly: one
    # exponential fewer per step.
    ea = math.exp(-a / tau) if a != 0.0 else 1.0
    eb = math.exp(-b / tau)
    return (b - a) + 2.0 * tau * (eb - ea) - 0.5 * tau * (eb * eb - ea * ea)


@njit(cache=True, inline="always", error_model="numpy")
def on_current(supply_v, wire_ohm, series_ohm, form, i_ref):
    """Steady current through the wire while the switch is on [A]."""
    if series_ohm <= 0.0:
        return supply_v / wire_ohm
    if form == SAG_QUADRATIC:
        # supply_v = I R + R_s I^2 / i_ref, solved in the form without cancellation (the
        # textbook root loses every digit when R_s is tiny).
        a = series_ohm / i_ref
        return 2.0 * supply_v / (wire_ohm + math.sqrt(wire_ohm * wire_ohm + 4.0 * a * supply_v))
    return supply_v / (wire_ohm + series_ohm)

"""Electrical resistance of the wire (report §4; the report measures it, we model it).

    rho(xi, T) = xi rho_M (1 + alpha_M (T - T_ref)) + (1 - xi) rho_A (1 + alpha_A (T - T_ref))
    R = rho * L^2 / (A0 l0),   L = l0 - x

The wire keeps its volume, so when it shortens to L its cross-section grows to
A0 l0 / L: both effects lower R (about -8 % over the full 4 % stroke). The rest of the
measured drop (3.75 -> 3.25 ohm near 7 mm, §4.2) comes from the loaded martensite's higher
resistivity. Because the heating branch runs hotter than the cooling branch at the same
martensite fraction (7-8 K in the nominal wire, docs/model.md §3) and the phases have
different temperature coefficients, heating and cooling give different R(x) slopes, as in
fig. 4.9.
"""

from __future__ import annotations

from sma_gym._jit import njit


@njit(cache=True, inline="always", error_model="numpy")
def wire_resistance(x, xi, t_c, rho_m, rho_a, tcr_m, tcr_a, t_ref, length, area):
    """R [ohm] of a wire of rest length ``length`` and area ``area`` contracted by ``x``."""
    dt = t_c - t_ref
    rho = xi * rho_m * (1.0 + tcr_m * dt) + (1.0 - xi) * rho_a * (1.0 + tcr_a * dt)
    current_length = length - x
    return rho * current_length * current_length / (area * length)

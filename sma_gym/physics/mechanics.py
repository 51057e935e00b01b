"""Mechanics and phase transformation, solved together implicitly.

Equations (report §5.1-5.3, docs/model.md §2-§3)::

    M x'' + c x' + k x + F_pre + f_friction = A sigma
    sigma = sigma0 + D(xi) (eps0 (1 - xi) - x / l0 - alpha(xi) (T - T_amb))  (*)
    xi    = clip(xi_old, xi_C(T, sigma), xi_H(T, sigma))                    (see transformation.py)

(*) is the report's rate law sigma' = D eps' + theta_T T' + Omega xi' with Omega = -D eps0,
theta_T = -D alpha and eps = eps0 - x / l0 in its secant form, the exact integral while the
modulus is fixed (with Elahinia's D(xi) = xi D_M + (1 - xi) D_A, and each phase's own
expansion, alpha(xi) = xi alpha_M + (1 - xi) alpha_A; a varying D would add D'(xi) xi'
times the elastic strain to the rate form, 1-3 % of Omega xi' on the standard wire). At rest (x = 0, xi = 1, T = T_amb) it gives sigma0 =
F_pre / A, which balances the spring preload.

Why implicit, and why this is at least as robust as the report's §5.5
----------------------------------------------------------------------
The report notes that the sigma <-> xi loop has a loop gain above 1 (here up to ~10), so
evaluating one from the other diverges; it substitutes one into the other (eq. 5.11-5.12)
and smooths sin() by a tanh (eq. 5.13) so that an explicit solver survives. We solve the
two together for each step: one implicit step of the mechanics (the theta-method of
``core.kernel``: trapezoidal where the step resolves the wire-mass mode, backward Euler where
it cannot) is linear in x for a given xi, so x and sigma are closed-form functions of xi,
and the step reduces to one
scalar equation r(z) = z - Z(z) = 0 for the new martensite fraction z. Z is non-increasing
in z (more martensite -> lower stress and, with latent heat, higher temperature -> lower
bounds), so r is strictly increasing with slope >= 1: exactly one root, bracketed before we
start, found by Newton's method with a bisection safeguard (to a residual below 1e-12 or a
bracket narrower than 1e-15). No smoothing is
needed, the cosine law stays exact, and the implicit step is unconditionally stable for the
stiff wire (D_A A / l0 ~ 2e4 N/m against an 8.8 g mass: a 250 Hz mode). The step length is
therefore limited only by accuracy (see ``core.kernel``), not by stability.

A wire cannot push: where (*) gives sigma < 0 the wire is slack (sigma = 0, the sleigh
moves under its own forces; docs/model.md §2).

Coulomb friction (``coulomb_friction`` effect) is set-valued at rest: we first try a step
with the mass stuck; if the force needed to hold it exceeds the static friction, we take a
sliding step with the kinetic force opposing the motion.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from sma_gym._jit import njit
from sma_gym.physics.transformation import (
    H_U_STAR,
    H_XI_NEW,
    NODE_COOL,
    NODE_HEAT,
    NODE_WEIGHT,
    cosine_fraction,
    cosine_fraction_inverse,
    cosine_fraction_slope,
)


class WireConstants(NamedTuple):
    """The wire's constants the implicit step needs, passed as one argument (numba passes a
    named tuple by value, so this costs nothing over seventeen scalars). Units as in
    :mod:`sma_gym.core.layout`; the kernel builds it from the actuator's parameter row."""

    area: float  # A [m^2]
    length: float  # l0 [m]
    d_a: float  # Young's modulus of austenite [Pa]
    d_m: float  # Young's modulus of martensite [Pa]
    eps0: float  # maximum transformation strain [-]
    alpha_a: float  # thermal expansion of austenite [1/K]
    alpha_m: float  # thermal expansion of martensite [1/K]
    t_amb: float  # reference temperature of the thermal strain [degC]
    sigma0: float  # rest stress F_pre / A [Pa]
    c_a: float  # stress coefficient of the heating branch [Pa/K]
    c_m: float  # stress coefficient of the cooling branch [Pa/K]
    a_s: float  # [degC]
    a_f: float  # [degC]
    m_s: float  # [degC]
    m_f: float  # [degC]
    latent_heat: float  # temperature change per unit xi while heating [K]
    latent_cool: float  # the same while cooling [K]


FRICTION_COULOMB = 0
FRICTION_STRIBECK = 1
"""Synthetic-data form: static force 1.5 F_c falling to F_c over a Stribeck velocity of 2 mm/s."""
FRICTION_FORMS = {"default": FRICTION_COULOMB, "stribeck": FRICTION_STRIBECK}
"""Code of each form of the ``coulomb_friction`` effect."""

_STRIBECK_STATIC_RATIO = 1.5
_STRIBECK_VELOCITY = 2e-3


@njit(cache=True, inline="always", error_model="numpy")
def static_friction(f_c, form):
    if form == FRICTION_STRIBECK:
        return _STRIBECK_STATIC_RATIO * f_c
    return f_c


@njit(cache=True, inline="always", error_model="numpy")
def kinetic_friction(f_c, velocity, form):
    if form == FRICTION_STRIBECK:
        r = velocity / _STRIBECK_VELOCITY
        return f_c * (1.0 + (_STRIBECK_STATIC_RATIO - 1.0) * math.exp(-r * r))
    return f_c


@njit(cache=True, inline="always", error_model="numpy")
def _evaluate(z, stick, x0, t_pred, z0, k_ext, b_ext, wire, nodes, stride, xi_old, hyst, n_nodes):
    """Z(z) and dZ/dz for a trial mean martensite fraction z; fills ``hyst[H_XI_NEW]``.

    Returns (Z, dZ, x1, sigma1, t1).
    """
    area, length, d_a, d_m, eps0, alpha_a, alpha_m, t_amb, sigma0 = wire[:9]
    c_a, c_m, a_s, a_f, m_s, m_f, latent_heat, latent_cool = wire[9:]
    lam = latent_heat if z < z0 else latent_cool
    t1 = t_pred + lam * (z - z0)
    d = z * d_m + (1.0 - z) * d_a
    dd = d_m - d_a
    # Each phase expands by its own coefficient: alpha(z) = z alpha_M + (1 - z) alpha_A.
    alpha = z * alpha_m + (1.0 - z) * alpha_a
    sf = eps0 * (1.0 - z) - alpha * (t1 - t_amb)
    dsf = -eps0 - alpha * lam - (alpha_m - alpha_a) * (t1 - t_amb)
    if stick:
        x1 = x0
        dx1 = 0.0
    else:
        num = b_ext + area * (sigma0 + d * sf)
        den = k_ext + area * d / length
        x1 = num / den
        dnum = area * (dd * sf + d * dsf)
        dden = area * dd / length
        dx1 = (dnum * den - num * dden) / (den * den)
    strain = sf - x1 / length
    sigma1 = sigma0 + d * strain
    dsigma = dd * strain + d * (dsf - dx1 / length)
    if sigma1 < 0.0:
        # A wire cannot push (a 0.5 mm wire of 0.96 m buckles under about 1 mN): where the
        # law gives compression the wire is slack, carries nothing, and the sleigh moves
        # under its own forces (k_ext x1 = b_ext). The residual z - Z(z) stays increasing
        # and continuous across the switch. Compression came with a friction above the
        # spring's force: a sleigh held while the wire expanded, or pushed back when the
        # wire cooled (a 3 N friction on the real bench: -14 MPa, the wire pushing 2.8 N).
        sigma1 = 0.0
        dsigma = 0.0
        if not stick:
            x1 = b_ext / k_ext

    inv_h = 1.0 / (a_f - a_s)
    inv_c = 1.0 / (m_s - m_f)
    du_h = (lam - dsigma / c_a) * inv_h
    du_c = (lam - dsigma / c_m) * inv_c
    big_z = 0.0
    dbig_z = 0.0
    for k in range(n_nodes):
        u_h = (t1 - nodes[NODE_HEAT * stride + k] - a_s - sigma1 / c_a) * inv_h
        u_c = (t1 - nodes[NODE_COOL * stride + k] - m_f - sigma1 / c_m) * inv_c
        # F is decreasing, so F(u_h) < old exactly when u_h > u_star = F^-1(old): the
        # comparison needs no cosine, and only a hysteron on a branch evaluates one.
        u_star = hyst[H_U_STAR, k]
        if u_h > u_star:
            xi = cosine_fraction(u_h)
            dxi = cosine_fraction_slope(u_h) * du_h
        elif u_c < u_star:
            xi = cosine_fraction(u_c)
            dxi = cosine_fraction_slope(u_c) * du_c
        else:
            xi = xi_old[k]
            dxi = 0.0
        hyst[H_XI_NEW, k] = xi
        big_z += nodes[NODE_WEIGHT * stride + k] * xi
        dbig_z += nodes[NODE_WEIGHT * stride + k] * dxi
    return big_z, dbig_z, x1, sigma1, t1


@njit(cache=True, inline="always", error_model="numpy")
def solve_step(stick, x0, t_pred, z0, k_ext, b_ext, wire, nodes, stride, xi_old, hyst, n_nodes):
    """One implicit step: returns (z, x1, sigma1, t1) and fills ``hyst[H_XI_NEW]``.

    ``k_ext`` and ``b_ext`` hold the implicit step's mechanics: the new position solves
    k_ext x1 = b_ext + A sigma(x1, z) unless ``stick`` (then x1 = x0). ``wire`` holds the
    wire's constants (:class:`WireConstants`); the hysterons are the first ``n_nodes``
    entries of each row of ``nodes`` (their shifts and weights: row r of the ``NODE_*`` rows of
    :mod:`~sma_gym.physics.transformation` starts at ``r * stride`` of this flat array) and
    of ``xi_old`` (their fractions at the start of the step) and columns of the workspace
    ``hyst`` (:data:`HYSTERON_ROWS`).
    """
    # r(z) = z - Z(z) is increasing with slope >= 1, and r(Z(z0)) has the opposite sign of
    # r(z0): the first evaluation at z0 brackets the root. Newton steps, bisection if a step
    # leaves the bracket. (One evaluation site, so the compiled code inlines it once.)
    for k in range(n_nodes):
        hyst[H_U_STAR, k] = cosine_fraction_inverse(xi_old[k])
    z = z0
    lo = 0.0
    hi = 1.0
    x1 = x0
    sigma1 = 0.0
    t1 = t_pred
    for it in range(80):
        big_z, dbig_z, x1, sigma1, t1 = _evaluate(
            z, stick, x0, t_pred, z0, k_ext, b_ext, wire, nodes, stride, xi_old, hyst, n_nodes
        )
        r = z - big_z
        if it == 0:
            if r == 0.0:
                break
            if r > 0.0:
                lo = big_z
                hi = z0
            else:
                lo = z0
                hi = big_z
        else:
            if r > 0.0:
                hi = z
            else:
                lo = z
            if abs(r) < 1e-12 or hi - lo < 1e-15:
                break
        z_new = z - r / (1.0 - dbig_z)
        if not (lo < z_new < hi):
            z_new = 0.5 * (lo + hi)
        z = z_new
    return z, x1, sigma1, t1

"""Phase transformation: the cosine law with stress-shifted temperatures and hysteresis.

Major loop (report eq. 5.4-5.5, MODEL.md §1)::

    heating  (M -> A):  xi_H(T, sigma) = F((T - A_s - sigma / C_A) / (A_f - A_s))
    cooling  (A -> M):  xi_C(T, sigma) = F((T - M_f - sigma / C_M) / (M_s - M_f))
    F(u) = (1 + cos(pi * clip(u, 0, 1))) / 2

(``b_A sigma = -a_A sigma / C_A`` in the report's notation: stress raises the
transformation temperatures by ``sigma / C``.)

Branch switching and minor loops
--------------------------------
The report keeps xi_M / xi_A (xi at the last reversal) and rescales the cosine from there.
With its own parameters (M_s = 95 > A_s = 75) that rule makes xi *jump* at a reversal
inside the overlap of the two temperature ranges, and small temperature ripple (every PWM
pulse) ratchets xi away. We build the hysteresis from *hysterons* instead, each of which
obeys the rule that its own major loop bounds its state::

    xi_k,new = clip(xi_k,old, xi_C,k(T, sigma), xi_H,k(T, sigma))      xi = sum_k w_k xi_k

While a hysteron lies between its two branches it does not transform; it transforms along a
branch only once it has reached it (a play operator). A hysteron's branches are the
report's cosines shifted in temperature: its heating branch by ``shift_h``, its cooling
branch by ``shift_c``. The set of hysterons is a discrete Preisach density
(:func:`hysteron_nodes`):

* ``preisach`` (the nominal law): the centres (shift_h + shift_c) / 2 are spread over the
  local transformation temperatures of the wire (§5.7: non-uniform heating and composition),
  and the loop widths are spread from the full major-loop width down to nearly zero. The
  narrow hysterons start back almost at once after a reversal, the wide ones later, so a
  reversal is followed by motion within about a kelvin, as in real wires (and in the
  report's own rescaled-cosine law), and the major loop gets rounded corners.
* ``play`` (the model of sma-gym 0.1): every hysteron has the full width, so after a
  reversal the wire crosses the whole 15 K hysteresis before it moves.

Either way (a weighted sum of play operators, i.e. a Prandtl-Ishlinskii / discrete
Preisach model):

* xi is continuous: a reversal part way through a transformation continues from the
  current xi (never jumps);
* minor loops close: heating back to a reversal point returns to the branch left there
  (return-point memory and wiping-out), so PWM ripple cannot make xi drift or ratchet;
* the only memory is the hysterons' xi, so nothing can get out of step.

With the report's parameters A_s - M_f = A_f - M_s = 15 K, so a full-width hysteron is
exactly a backlash of 15 K followed by one cosine.
"""

from __future__ import annotations

import math
from statistics import NormalDist

from sma_gym._jit import njit


@njit(cache=True, inline="always", error_model="numpy")
def cosine_fraction(u: float) -> float:
    """F(u) = (1 + cos(pi u)) / 2 for u in [0, 1]; 1 below, 0 above."""
    if u <= 0.0:
        return 1.0
    if u >= 1.0:
        return 0.0
    return 0.5 * (1.0 + math.cos(math.pi * u))


@njit(cache=True, inline="always", error_model="numpy")
def cosine_fraction_inverse(xi: float) -> float:
    """The u in [0, 1] with F(u) = xi (xi clipped to [0, 1])."""
    if xi >= 1.0:
        return 0.0
    if xi <= 0.0:
        return 1.0
    return math.acos(2.0 * xi - 1.0) / math.pi


@njit(cache=True, inline="always", error_model="numpy")
def cosine_fraction_slope(u: float) -> float:
    """dF/du (zero outside (0, 1))."""
    if u <= 0.0 or u >= 1.0:
        return 0.0
    return -0.5 * math.pi * math.sin(math.pi * u)


MINOR_LOOP_LAWS = ("preisach", "play")
"""Names of the hysteresis laws (see the module docstring)."""

# Probabilists' Gauss-Hermite, 5 nodes: exact for polynomials up to degree 9.
_GH_NODES = (-2.8569700138728056, -1.3556261799742657, 0.0, 1.3556261799742657, 2.8569700138728056)
_GH_WEIGHTS = (0.011257411327720691, 0.2220759220056126, 0.5333333333333334, 0.2220759220056126, 0.011257411327720691)

# Which width quantile each centre gets (Latin-hypercube pairing of 7 hysterons): centre
# and width uncorrelated (rank correlation -0.07), the narrowest hysteron near the middle of
# the transformation, where closed-loop reversals happen.
_WIDTH_RANK_7 = (3, 6, 0, 2, 5, 1, 4)


def hysteron_nodes(
    spread_k: float,
    width_spread: float,
    loop_width_k: float,
    law: str = "preisach",
    centre_form: str = "default",
    max_nodes: int = 7,
) -> tuple[list[float], list[float], list[float]]:
    """Hysterons of the transformation: ``(shift_h, shift_c, weights)``, one entry each.

    ``spread_k`` [K]: standard deviation of the hysterons' centre temperatures (§5.7).
    ``width_spread`` [-]: 0 gives every hysteron the full width ``loop_width_k``; 1 spreads
    the widths uniformly over [0, loop_width_k]. ``loop_width_k`` is the narrowest gap
    between the heating and the cooling branch of the major loop (min(A_s - M_f, A_f - M_s)),
    so no hysteron's heating branch ever lies below its cooling branch. ``centre_form``:
    ``default`` normal centres, ``uniform`` uniformly spread centres (same std).

    The ``play`` law, or no width spread, uses 5-point Gauss-Hermite centres (one node when
    there is no spread either, so the simplest model costs nothing extra). The ``preisach``
    law uses ``max_nodes`` equally weighted hysterons whose centres are the distribution's
    quantiles (rescaled to the exact std) and whose widths are the uniform quantiles,
    paired Latin-hypercube fashion.
    """
    if law not in MINOR_LOOP_LAWS:
        raise ValueError(f"minor-loop law = {law!r}: expected one of {MINOR_LOOP_LAWS}")
    if law == "play" or width_spread == 0.0:
        if spread_k == 0.0:
            return [0.0], [0.0], [1.0]
        if centre_form == "uniform":
            centres = _uniform_centres(spread_k, max_nodes)
            weights = [1.0 / max_nodes] * max_nodes
        else:
            centres = [spread_k * n for n in _GH_NODES]
            weights = list(_GH_WEIGHTS)
        return centres, list(centres), _exact_unit_sum(weights)
    n = max_nodes
    if centre_form == "uniform":
        centres = _uniform_centres(spread_k, n)
    else:
        raw = [NormalDist().inv_cdf((k + 0.5) / n) for k in range(n)]
        std = math.sqrt(sum(r * r for r in raw) / n)
        centres = [spread_k * r / std for r in raw]
    ranks = _WIDTH_RANK_7 if n == 7 else tuple(range(n))
    shift_h, shift_c = [], []
    for k in range(n):
        narrowing = width_spread * loop_width_k * (ranks[k] + 0.5) / n
        shift_h.append(centres[k] - 0.5 * narrowing)
        shift_c.append(centres[k] + 0.5 * narrowing)
    return shift_h, shift_c, _exact_unit_sum([1.0 / n] * n)


def _exact_unit_sum(weights: list[float]) -> list[float]:
    # The core sums w_k xi_k in this order; a fully martensitic wire must give xi = 1.0
    # exactly (else a wire at rest creeps by rounding), so the last weight takes the rest.
    head = 0.0
    for w in weights[:-1]:
        head += w
    return weights[:-1] + [1.0 - head]


def _uniform_centres(spread_k: float, count: int) -> list[float]:
    half_width = math.sqrt(3.0) * spread_k
    centres = [-half_width + (2 * k + 1) * half_width / count for k in range(count)]
    # Midpoints of equal bins have a slightly smaller spread; rescale to the exact std.
    std = math.sqrt(sum(c * c for c in centres) / count)
    return [c * spread_k / std for c in centres]

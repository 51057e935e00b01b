"""Phase transformation: the cosine law with stress-shifted temperatures and hysteresis.

Major loop (report eq. 5.4-5.5, docs/model.md §3)::

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
  report's own rescaled-cosine law), and the major loop gets rounded corners. Widths and
  centres are paired uncorrelated; the ``narrow-cold`` option (``Wire.hysteron_width_pairing``)
  lets the width grow with the centre, so a reversal in the hot, austenite-rich part of
  the loop is followed only after a few kelvin of cooling.
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

WIDTH_PAIRINGS = ("uncorrelated", "narrow-cold")
"""How the hysterons' loop widths are paired with their centres (see :func:`hysteron_nodes`)."""

WIDTH_FORMS = ("default", "mean")
"""How the ``minor_loop_width`` effect narrows the spread of loop widths (see
:func:`hysteron_nodes`): ``default`` floors every width at a share of the mean width,
``mean`` draws every width towards the mean (the major loop unchanged)."""

# "uncorrelated": which width quantile each centre gets, a Latin-hypercube pairing of 7
# hysterons (rank correlation -0.07), the narrowest hysteron near the middle of the
# transformation.
_WIDTH_RANK_7 = (3, 6, 0, 2, 5, 1, 4)


def _width_ranks(n: int, pairing: str) -> tuple[int, ...]:
    """Rank of each hysteron's narrowing (0: the least narrowed, i.e. the widest), coldest first."""
    if pairing == "narrow-cold":
        return tuple(range(n - 1, -1, -1))
    if n == 7:
        return _WIDTH_RANK_7

    # Another count: of the permutations k -> (a k + b) mod n with a stride a other than
    # +-1 (those are a rotated monotone pairing), the one least rank-correlated with the
    # centres' order (a Latin-hypercube pairing).
    def correlation(ranks: tuple[int, ...]) -> float:
        return abs(sum((k - (n - 1) / 2) * (r - (n - 1) / 2) for k, r in enumerate(ranks)))

    strides = [a for a in range(2, n - 1) if math.gcd(a, n) == 1] or list(range(1, max(n, 2)))
    candidates = [tuple((a * k + b) % n for k in range(n)) for a in strides for b in range(n)]
    return min(candidates, key=correlation)


# An actuator's hysterons as the compiled step reads them: one row per quantity, one column
# per hysteron (up to layout.MAX_SPREAD_NODES). It is a view of the actuator's parameter
# row (layout's P_NODE_HEAT0 block, in this order), not a copy: copying it for every
# actuator and step took 5 % of the simulator's time.
NODE_HEAT = 0
"""Row: each hysteron's heating-branch shift (K), from :func:`hysteron_nodes`."""
NODE_COOL = 1
"""Row: each hysteron's cooling-branch shift (K)."""
NODE_WEIGHT = 2
"""Row: each hysteron's weight (they sum to 1)."""
NODE_ROWS = 3
"""Rows of an actuator's hysteron parameters."""

# The hysteron workspace of the compiled step, one column per hysteron: what the solver fills.
# (The fractions at the start of the step are read in place from the state.)
H_XI_NEW = 0
"""Row: each hysteron's martensite fraction at the end of the step (filled by the solver)."""
H_U_STAR = 1
"""Row: scratch, the branch coordinate at which each hysteron's old fraction lies."""
HYSTERON_ROWS = 2
"""Rows of the hysteron workspace."""


def hysteron_nodes(
    spread_k: float,
    width_spread: float,
    loop_width_k: float,
    law: str = "preisach",
    centre_form: str = "default",
    max_nodes: int = 7,
    branch_range_k: float = math.inf,
    pairing: str = "uncorrelated",
    min_width_share: float = 0.0,
    widths_form: str = "default",
) -> tuple[list[float], list[float], list[float], float]:
    """Hysterons of the transformation: ``(shift_h, shift_c, weights, widening_k)``.

    ``spread_k`` [K]: standard deviation of the hysterons' centre temperatures (§5.7).
    ``width_spread`` [-]: 0 gives every hysteron the full width ``loop_width_k``; 1 spreads
    the widths uniformly over [0, loop_width_k]. ``loop_width_k`` is the narrowest gap
    between the heating and the cooling branch of the major loop (min(A_s - M_f, A_f - M_s)),
    so no hysteron's heating branch ever lies below its cooling branch. ``centre_form``:
    ``default`` normal centres, ``uniform`` uniformly spread centres (same std).

    ``max_nodes`` equally weighted hysterons (one when there is neither spread nor width
    spread, so the simplest model costs nothing extra) whose centres are the distribution's
    quantiles (rescaled to the exact std); with the ``preisach`` law their widths are the
    uniform quantiles, with the ``play`` law all are full. ``pairing`` (one of
    :data:`WIDTH_PAIRINGS`) says which centre gets which width: ``uncorrelated`` (nominal)
    pairs them Latin-hypercube fashion; ``narrow-cold`` makes the width grow with the
    centre, so the hysterons that transform coldest have the narrowest loops and the hottest
    the widest. See ``Wire.hysteron_width_pairing`` for what each was measured to do.

    ``branch_range_k`` [K] is the temperature range of one branch's cosine (min(A_f - A_s,
    M_s - M_f)). A few discrete centres further apart than about half that range would turn
    a smooth distribution into a staircase with plateaus (a narrow-range HT wire with a
    10 K spread did exactly that). Then the nodes move closer and every branch's range is
    widened by ``widening_k`` (A_s and M_f lower by half of it, A_f and M_s higher; the loop
    widths A_s - M_f and A_f - M_s are unchanged) so that the transformation keeps the same
    mean and the same variance, the cosine's variance being ``COSINE_VARIANCE`` times its
    range squared. Without spread, or with ranges wide enough (the standard wire), it is 0.

    ``min_width_share`` [-] (the ``minor_loop_width`` effect, 0 = off) makes the narrowest
    loops wider, so that a wire moves back later after a reversal: with ``widths_form``
    ``default`` no hysteron is narrower than that share of the hysterons' mean width (a
    floor; the wide ones are kept, so the major loop widens a little), with ``mean`` every
    width is drawn that share of the way to the mean (the mean, i.e. the major loop, kept;
    1 gives every hysteron the mean width). The centres are not moved.
    """
    if law not in MINOR_LOOP_LAWS:
        raise ValueError(f"minor-loop law = {law!r}: expected one of {MINOR_LOOP_LAWS}")
    if pairing not in WIDTH_PAIRINGS:
        raise ValueError(f"hysteron width pairing = {pairing!r}: expected one of {WIDTH_PAIRINGS}")
    if widths_form not in WIDTH_FORMS:
        raise ValueError(f"minor-loop width form = {widths_form!r}: expected one of {WIDTH_FORMS}")
    if not 0.0 <= min_width_share <= 1.0:
        raise ValueError(f"min_width_share = {min_width_share!r}: expected a share in [0, 1]")
    if spread_k == 0.0 and (law == "play" or width_spread == 0.0):
        return [0.0], [0.0], [1.0], 0.0
    n = max_nodes
    if centre_form == "uniform":
        centres = _uniform_centres(spread_k, n)
    else:
        raw = [NormalDist().inv_cdf((k + 0.5) / n) for k in range(n)]
        std = math.sqrt(sum(r * r for r in raw) / n)
        centres = [spread_k * r / std for r in raw]
    centres, widening_k = _smooth_centres(centres, spread_k, branch_range_k)
    ranks = _width_ranks(n, pairing)
    width = 0.0 if law == "play" else width_spread
    # Each hysteron's loop is loop_width_k - narrowing wide.
    narrowings = [width * loop_width_k * (ranks[k] + 0.5) / n for k in range(n)]
    if min_width_share > 0.0:  # guarded: the effect off leaves the nodes bit for bit
        mean_narrowing = sum(narrowings) / n
        if widths_form == "mean":
            narrowings = [x + min_width_share * (mean_narrowing - x) for x in narrowings]
        else:
            most = loop_width_k - min_width_share * (loop_width_k - mean_narrowing)
            narrowings = [min(x, most) for x in narrowings]
    shift_h, shift_c = [], []
    for k in range(n):
        shift_h.append(centres[k] - 0.5 * narrowings[k])
        shift_c.append(centres[k] + 0.5 * narrowings[k])
    return shift_h, shift_c, _exact_unit_sum([1.0 / n] * n), widening_k


COSINE_VARIANCE = 0.25 - 2.0 / math.pi**2
"""Variance of the cosine law's transition over a unit range: F(u) = (1 + cos(pi u)) / 2 is
the distribution function of a density (pi / 2) sin(pi u) on [0, 1]."""

SMOOTH_GAP_RATIO = 0.5
"""The largest gap between neighbouring hysteron centres, as a fraction of the branch
range, that still sums to a smooth transformation (no plateau between the cosines)."""


def _smooth_centres(centres: list[float], spread_k: float, branch_range_k: float) -> tuple[list[float], float]:
    """Centres moved closer and the range widening that keep mean and variance (see above)."""
    gap = max((b - a for a, b in zip(centres, centres[1:])), default=0.0)
    if spread_k <= 0.0 or gap <= SMOOTH_GAP_RATIO * branch_range_k:
        return centres, 0.0
    # Gaps scale with the node spread s: gap(s) = r s. Ask for W' = r s / SMOOTH_GAP_RATIO and
    # s^2 + c W'^2 = spread^2 + c W^2 (c = COSINE_VARIANCE): solve for s.
    r, c = gap / spread_k, COSINE_VARIANCE
    k = r / SMOOTH_GAP_RATIO
    s = math.sqrt((spread_k**2 + c * branch_range_k**2) / (1.0 + c * k * k))
    return [x * s / spread_k for x in centres], k * s - branch_range_k


def _exact_unit_sum(weights: list[float]) -> list[float]:
    # The core sums w_k xi_k in this order; a fully martensitic wire must give xi = 1.0
    # exactly (else a wire at rest creeps by rounding), so the last weight takes the rest.
    head = 0.0
    for w in weights[:-1]:
        head += w
    return weights[:-1] + [1.0 - head]


def _uniform_centres(spread_k: float, count: int) -> list[float]:
    if spread_k == 0.0:
        return [0.0] * count  # no spread (the effect's off value): no rescaling to do
    # Unit-std centres scaled afterwards: scaling first would underflow the std for a
    # subnormal spread_k (found by the property test: 2e-311 K divided by zero).
    half_width = math.sqrt(3.0)
    unit = [-half_width + (2 * k + 1) * half_width / count for k in range(count)]
    # Midpoints of equal bins have a slightly smaller spread; rescale to the exact std.
    std = math.sqrt(sum(c * c for c in unit) / count)
    return [spread_k * c / std for c in unit]

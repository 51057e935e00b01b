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
pulse) ratchets xi away. We use instead the rule that the major loop bounds every state::

    xi_new = clip(xi_old, xi_C(T, sigma), xi_H(T, sigma))

While the state lies between the two branches nothing transforms; it transforms along a
branch only once it has reached it. This is the limit of the report's own parameters:
A_s - M_f = A_f - M_s = 15 K means the major loop is exactly a backlash (play) of 15 K
followed by one cosine, and the rule above is that backlash. Consequences:

* a reversal part way through a transformation continues from the current xi (never jumps);
* minor loops close: heating back to a reversal point returns to the branch left there
  (return-point memory), so PWM ripple cannot make xi drift;
* the only memory is xi itself, so nothing can get out of step.

The ``transformation_spread`` effect replaces the single element by sub-elements with
offset temperatures, which rounds the start and end of the transformation and the corners
of minor loops (the report's §5.7 observation).
"""

from __future__ import annotations

import math

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
def cosine_fraction_slope(u: float) -> float:
    """dF/du (zero outside (0, 1))."""
    if u <= 0.0 or u >= 1.0:
        return 0.0
    return -0.5 * math.pi * math.sin(math.pi * u)


def major_loop(temperature_c, stress_pa, a_s, a_f, m_s, m_f, c_a, c_m):
    """Both branches of the major loop (numpy-friendly, for plots and tests).

    Returns ``(xi_heating, xi_cooling)``; the hysteresis keeps every state between them.
    """
    import numpy as np

    t = np.asarray(temperature_c, dtype=float)
    s = np.asarray(stress_pa, dtype=float)
    u_h = np.clip((t - a_s - s / c_a) / (a_f - a_s), 0.0, 1.0)
    u_c = np.clip((t - m_f - s / c_m) / (m_s - m_f), 0.0, 1.0)
    return 0.5 * (1.0 + np.cos(np.pi * u_h)), 0.5 * (1.0 + np.cos(np.pi * u_c))

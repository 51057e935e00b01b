"""Minor-loop laws compared, measured (issue 11, item 1).

Issue 11 asks for a minor-loop law that reverses like a real wire (moves back within about a
kelvin of a reversal, as the report's rescaled cosine and another bench's closed-loop sine
do) and still cannot ratchet under PWM ripple or jump at a reversal, and for the
candidates to be compared by measurement. This script drives each candidate law with the
same temperature histories at the same stress and prints, per law:

* **lag at the top / bottom reversal** [K]: how far the temperature must go back after a
  reversal at half transformation (reached by heating from cold, or by cooling from hot)
  before the martensite fraction has moved back by 0.01 (0.1 mm of the standard wire's
  10.9 mm transformation strain);
* **largest jump** [-]: the largest change of the fraction in one 0.01 K sample around
  the reversal (a continuous law moves by its slope times 0.01 K, under 1e-3);
* **drift under ripple** [-]: the fraction's change over 5000 cycles of a 0.5 K peak-to-peak
  triangular ripple about the top reversal's temperature (ten seconds of a 500 Hz PWM; the
  laws are rate-independent, so the number of cycles is what counts), after its first
  cycle;
* **return-point error** [-]: after heating to the reversal point, cooling 5 K and heating
  back, the difference from the fraction at the reversal point (return-point memory), and
  after heating on by 3 K, from the fraction a direct heating reaches there (wiping out).

Candidates, each on the nominal wire's major loop (``preset("standard")``, its packed
parameters: the same branch temperatures and stress shifts the kernel uses):

* ``preisach`` (nominal, the kernel's): hysterons spread in centre and width;
* ``play`` (sma-gym 0.1 and ``Wire.minor_loop_law = "play"``): full-width hysterons with
  spread centres (Ikuta's layered model is this form: layers of their own transformation
  temperatures, each a full-width loop);
* ``rescaled`` (the report's eq. 5.4-5.5): one cosine law rescaled by the fraction at the
  last reversal, xi_M on heating and xi_A on cooling;
* ``proportional`` (the rescaled cosine with continuity restored): after a reversal at
  (T_r, xi_r) heating follows xi_r F_h(T) / F_h(T_r) and cooling 1 - (1 - xi_r)
  (1 - F_c(T)) / (1 - F_c(T_r)), so xi is continuous and moves at once (the law of
  ``tests/independent_sma.py``);
* ``duhem`` (a smooth Duhem-type law): d xi / dT is the slope of the branch ahead times the
  wire's position between the branches (1 on the branch ahead, 0 on the other), so it
  follows a branch it is on and, after a reversal, starts back gradually as the branches
  move apart from it, with no kink. (The ``proportional`` law is itself a Duhem-type law:
  its differential form is d xi / dT = xi F_h' / F_h while heating.)

The two laws of the kernel are also checked against the kernel itself: each is evaluated on
the temperature and stress the simulator recorded in an open-loop run with a partial
contraction and return (one sample per 1 ms control step), and the largest difference from
the simulator's own martensite fraction is printed.

Run: python benchmarks/bench_minor_loops.py
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sma_gym import Simulator, preset
from sma_gym.core import layout as L
from sma_gym.model import ModelConfig
from sma_gym.physics.transformation import cosine_fraction
from sma_gym.simulator import pack_params

LAWS = ("preisach", "play", "rescaled", "proportional", "duhem")
MOVED = 0.01
"""Change of the martensite fraction that counts as moving back after a reversal [-]."""
MOVED_SMALL = 0.001
"""The same, for the first sign of motion (11 um of the standard wire) [-]."""
REVERSAL_FRACTIONS = (0.1, 0.3, 0.5, 0.7, 0.9)
"""Martensite fractions at which the reversals of the jump test happen [-]."""
SAMPLE_K = 0.01
"""Temperature step of the histories [K]."""
RIPPLE_P2P_K = 0.5
"""Peak-to-peak ripple about the reversal temperature [K]: the largest of a 500 Hz PWM at
10 V (the standard wire heats at 254 K/s at full power, for at most 2 ms a period)."""
RIPPLE_CYCLES = 5000
"""Ripple cycles (ten seconds of a 500 Hz PWM)."""
SWITCH_BAND_K = 1e-9
"""Temperature reversal that re-anchors the rescaled laws (any reversal, as written)."""


@dataclass(frozen=True)
class Branches:
    """The major loop as the kernel packs it: temperatures [degC], stress coefficients [Pa/K]
    and the hysterons' branch shifts [K] and weights."""

    a_s: float
    a_f: float
    m_s: float
    m_f: float
    c_a: float
    c_m: float
    shift_h: tuple[float, ...]
    shift_c: tuple[float, ...]
    weights: tuple[float, ...]

    @classmethod
    def of(cls, model: ModelConfig) -> Branches:
        row = pack_params(model)
        n = int(row[L.P_N_NODES])
        nodes = slice(0, n)
        return cls(
            a_s=float(row[L.P_A_S]),
            a_f=float(row[L.P_A_F]),
            m_s=float(row[L.P_M_S]),
            m_f=float(row[L.P_M_F]),
            c_a=float(row[L.P_C_A]),
            c_m=float(row[L.P_C_M]),
            shift_h=tuple(row[L.P_NODE_HEAT0 : L.P_NODE_HEAT0 + L.MAX_SPREAD_NODES][nodes]),
            shift_c=tuple(row[L.P_NODE_COOL0 : L.P_NODE_COOL0 + L.MAX_SPREAD_NODES][nodes]),
            weights=tuple(row[L.P_NODE_WEIGHT0 : L.P_NODE_WEIGHT0 + L.MAX_SPREAD_NODES][nodes]),
        )

    def heating(self, t_c: float, sigma_pa: float, shift_k: float = 0.0) -> float:
        """Fraction on the heating branch (M -> A), shifted by ``shift_k``."""
        return cosine_fraction((t_c - shift_k - self.a_s - sigma_pa / self.c_a) / (self.a_f - self.a_s))

    def cooling(self, t_c: float, sigma_pa: float, shift_k: float = 0.0) -> float:
        """Fraction on the cooling branch (A -> M), shifted by ``shift_k``."""
        return cosine_fraction((t_c - shift_k - self.m_f - sigma_pa / self.c_m) / (self.m_s - self.m_f))


def hysterons(b: Branches, temp_c: np.ndarray, sigma_pa: np.ndarray, xi0: float = 1.0) -> np.ndarray:
    """Sum of play operators (the kernel's laws), each clipped between its two branches.

    A temperature-driven restatement for the comparison only (the kernel solves the law
    inside its implicit step and cannot be driven by a temperature history);
    :func:`kernel_check` holds it to the simulator's own martensite fraction."""
    nodes = np.full(len(b.weights), xi0)
    out = np.empty(temp_c.size)
    for j, (t, s) in enumerate(zip(temp_c, sigma_pa)):
        for k in range(nodes.size):
            nodes[k] = min(max(nodes[k], b.cooling(t, s, b.shift_c[k])), b.heating(t, s, b.shift_h[k]))
        out[j] = float(np.dot(b.weights, nodes))
    return out


def rescaled(
    b: Branches, temp_c: np.ndarray, sigma_pa: np.ndarray, xi0: float = 1.0, fixed: bool = False
) -> np.ndarray:
    """The report's rescaled cosine (``fixed=False``) or its continuity-fixed form."""
    xi, heating = xi0, True
    anchor_xi, anchor_f = xi0, b.heating(temp_c[0], sigma_pa[0])
    out = np.empty(temp_c.size)
    for j in range(temp_c.size):
        t, s = temp_c[j], sigma_pa[j]
        if j:
            d = t - temp_c[j - 1]
            if (heating and d < -SWITCH_BAND_K) or (not heating and d > SWITCH_BAND_K):
                heating = not heating
                anchor_xi = xi
                anchor_f = b.heating(t, s) if heating else b.cooling(t, s)
        if heating:
            f = b.heating(t, s)
            if not fixed:
                xi = anchor_xi * f  # xi_M F_h
            elif anchor_f > 0.0:
                xi = min(anchor_xi, anchor_xi * f / anchor_f)
        else:
            f = b.cooling(t, s)
            if not fixed:
                xi = anchor_xi + (1.0 - anchor_xi) * f  # xi_A + (1 - xi_A) F_c
            elif anchor_f < 1.0:
                xi = max(anchor_xi, 1.0 - (1.0 - anchor_xi) * (1.0 - f) / (1.0 - anchor_f))
        out[j] = xi
    return out


def duhem(b: Branches, temp_c: np.ndarray, sigma_pa: np.ndarray, xi0: float = 1.0) -> np.ndarray:
    """A smooth Duhem-type law: d xi / dT = F'(T) w, w the position between the branches.

    Heating follows the heating branch's slope times w = (xi - F_c) / (F_h - F_c), cooling
    the cooling branch's slope times 1 - w: on the branch ahead the wire follows it, and
    after a reversal it starts back gradually as the branches move apart from it, with no
    kink (explicit Euler over the 0.01 K samples, clipped between the branches).
    """
    xi = xi0
    out = np.empty(temp_c.size)
    out[0] = xi
    for j in range(1, temp_c.size):
        t0, t, s = temp_c[j - 1], temp_c[j], sigma_pa[j]
        f_h, f_c = b.heating(t0, s), b.cooling(t0, s)
        gap = f_h - f_c
        w = min(max((xi - f_c) / gap, 0.0), 1.0) if gap > 1e-12 else 1.0
        if t > t0:
            xi += (b.heating(t, s) - f_h) * w
        elif t < t0:
            xi += (b.cooling(t, s) - f_c) * (1.0 - w)
        xi = min(max(xi, b.cooling(t, s)), b.heating(t, s))
        out[j] = xi
    return out


def law_function(name: str, model: ModelConfig) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """``f(temperature_c, stress_pa) -> martensite fraction``, starting fully martensitic."""
    if name == "preisach":
        b = Branches.of(model)
        return lambda t, s: hysterons(b, t, s)
    if name == "play":
        b = Branches.of(model.with_actuator(**{"wire.minor_loop_law": "play"}))
        return lambda t, s: hysterons(b, t, s)
    # One cosine law on the nominal wire's major loop, without the hysterons.
    single = model.with_actuator(**{"wire.transformation_spread_k": 0.0, "wire.hysteron_width_spread": 0.0})
    b = Branches.of(single)
    if name == "rescaled":
        return lambda t, s: rescaled(b, t, s)
    if name == "proportional":
        return lambda t, s: rescaled(b, t, s, fixed=True)
    if name == "duhem":
        return lambda t, s: duhem(b, t, s)
    raise ValueError(f"law = {name!r}: expected one of {LAWS}")


def ramp(start_c: float, end_c: float) -> np.ndarray:
    """Temperatures from ``start_c`` to ``end_c`` in steps of about ``SAMPLE_K``."""
    n = max(2, int(round(abs(end_c - start_c) / SAMPLE_K)) + 1)
    return np.linspace(start_c, end_c, n)


def measure(law: Callable[[np.ndarray, np.ndarray], np.ndarray], sigma_pa: float) -> dict[str, float]:
    """The law's reversal lags, jumps, ripple drift and return-point errors."""
    cold, hot = 20.0, 160.0

    def run(*legs: np.ndarray) -> np.ndarray:
        t = np.concatenate(legs)
        return law(t, np.full(t.size, sigma_pa))

    # Temperatures at which the first heating / the first cooling reaches each fraction.
    up = ramp(cold, hot)
    down = ramp(hot, cold)
    xi_up = run(up)
    xi_down = run(up, down[1:])[up.size - 1 :]

    def heated_to(fraction: float) -> float:
        return float(up[np.argmax(xi_up <= fraction)])

    def cooled_to(fraction: float) -> float:
        return float(down[np.argmax(xi_down >= fraction)])

    def lag(t: np.ndarray, xi: np.ndarray, start: int, moved: float) -> float:
        k = np.flatnonzero(np.abs(xi[start:] - xi[start]) >= moved)
        return abs(float(t[start + k[0]] - t[start])) if k.size else math.inf

    result: dict[str, float] = {"t_half_heating_c": heated_to(0.5), "t_half_cooling_c": cooled_to(0.5), "jump": 0.0}
    for fraction in REVERSAL_FRACTIONS:
        # Top reversal: heat from cold to the fraction, cool back. Bottom: heat to fully
        # austenitic, cool to the fraction, heat back.
        t_top, t_bottom = heated_to(fraction), cooled_to(fraction)
        legs_top = (ramp(cold, t_top), ramp(t_top, cold)[1:])
        legs_bottom = (up, ramp(hot, t_bottom)[1:], ramp(t_bottom, hot)[1:])
        for name, legs in (("top", legs_top), ("bottom", legs_bottom)):
            t = np.concatenate(legs)
            xi = run(*legs)
            k = sum(leg.size for leg in legs[:-1]) - 1  # the reversal sample
            window = np.abs(np.diff(xi[max(k - 50, 0) : k + 50]))
            result["jump"] = max(result["jump"], float(window.max()))
            if fraction == 0.5:
                result[f"lag_{name}_k"] = lag(t, xi, k, MOVED)
                result[f"lag_{name}_small_k"] = lag(t, xi, k, MOVED_SMALL)
    # Ripple about the top reversal at half transformation.
    t_half = result["t_half_heating_c"]
    half = 0.5 * RIPPLE_P2P_K
    cycle = np.concatenate(
        [
            np.linspace(t_half, t_half - half, 6)[1:],
            np.linspace(t_half - half, t_half + half, 11)[1:],
            np.linspace(t_half + half, t_half, 6)[1:],
        ]
    )
    heat = ramp(cold, t_half)
    xi3 = run(heat, np.tile(cycle, RIPPLE_CYCLES))
    first = heat.size - 1 + cycle.size
    result["ripple_drift"] = float(xi3[-1] - xi3[first])
    # Return point: heat to the top, cool 5 K, heat back; then on by 3 K.
    legs = (heat, ramp(t_half, t_half - 5.0)[1:], ramp(t_half - 5.0, t_half)[1:], ramp(t_half, t_half + 3.0)[1:])
    xi4 = run(*legs)
    k_top, k_back = heat.size - 1, heat.size + legs[1].size + legs[2].size - 1
    xi_direct = run(ramp(cold, t_half + 3.0))
    result["return_point"] = float(abs(xi4[k_back] - xi4[k_top]))
    result["wiping_out"] = float(abs(xi4[-1] - xi_direct[-1]))
    return result


def kernel_check(law: str, model: ModelConfig) -> float:
    """Largest |xi| difference between the law evaluated here and the simulator's run."""
    m = model if law == "preisach" else model.with_actuator(**{"wire.minor_loop_law": "play"})
    # Heat part way, hold, cool part way back, heat again, cool to rest: partial loops.
    duty = np.concatenate([np.full(900, 0.55), np.full(1500, 0.05), np.full(600, 0.5), np.full(3000, 0.0)])
    out = Simulator(m).run(duty, record=("temperature_c", "stress_pa", "martensite_fraction"))
    xi = law_function(law, model)(out["temperature_c"][:, 0], out["stress_pa"][:, 0])
    return float(np.max(np.abs(xi - out["martensite_fraction"][:, 0])))


def operating_stress_pa(model: ModelConfig) -> float:
    """Wire stress at half the usable stroke, held (the stress the reversals happen at)."""
    out = Simulator(model).run(np.full(3000, 1.0), record=("position_m", "stress_pa"))
    k = int(np.argmax(out["position_m"][:, 0] >= 0.5 * model.actuator.usable_stroke_m))
    return float(out["stress_pa"][k, 0])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--laws", default=",".join(LAWS), help=f"comma-separated, of {LAWS}")
    args = parser.parse_args()
    laws = args.laws.split(",")
    for name in laws:
        if name not in LAWS:
            parser.error(f"law {name!r}: expected one of {LAWS}")
    model = ModelConfig(preset("standard"))
    sigma = operating_stress_pa(model)
    stroke_mm = model.actuator.wire.max_transformation_strain * model.actuator.wire.length_m * 1e3
    print(f"standard wire, stress {sigma / 1e6:.1f} MPa; 1e-2 of xi = {stroke_mm * 1e-2:.2f} mm")
    print(
        "| law | half on heating / cooling [degC] | lag to 1e-3 of xi, top / bottom [K] | lag to 1e-2 [K] "
        "| largest jump | drift under ripple (5000 cycles) | return point / wiping out |"
    )
    print("|---|---|---|---|---|---|---|")
    for name in laws:
        r = measure(law_function(name, model), sigma)
        print(
            f"| {name} | {r['t_half_heating_c']:.1f} / {r['t_half_cooling_c']:.1f} "
            f"| {r['lag_top_small_k']:.2f} / {r['lag_bottom_small_k']:.2f} | {r['lag_top_k']:.2f} / {r['lag_bottom_k']:.2f} "
            f"| {r['jump']:.2e} | {r['ripple_drift']:+.2e} | {r['return_point']:.1e} / {r['wiping_out']:.1e} |"
        )
    for name in ("preisach", "play"):
        if name in laws:
            print(f"{name}: largest |xi| difference from the simulator on its own run: {kernel_check(name, model):.2e}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

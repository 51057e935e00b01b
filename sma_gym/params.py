"""Parameters of an SMA wire actuator, as frozen dataclasses.

An :class:`ActuatorParams` describes one Flexinol-type actuator completely:
the wire (:class:`Wire`), the mechanism it pulls (:class:`Mechanism`), the
heat transfer to the surroundings (:class:`Convection`), the PWM driver and
supply (:class:`Driver`) and the sensors (:class:`Sensors`).

Every field's docstring gives the symbol used in ``docs/model.md`` / the report,
the unit, the value and where it comes from: a section of the report
(Lunenburg 2009, cited as "§5.6"), a datasheet, or our own calibration
(``sma-gym fidelity`` shows the calibration targets it meets). Where the
report contradicts itself, measured behaviour wins; each such choice is
written next to the parameter it affects.

Presets for the report's conditions and for the real bench of
``shared/data/real`` are available through :func:`preset`.

Adding a parameter or an effect: the steps are listed in one place, the docstring of
:mod:`sma_gym.core.layout`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field, replace
from typing import Any, ClassVar

import numpy as np

from sma_gym._validation import Bound, check_bounds, require_choice, require_range
from sma_gym.core.layout import MAX_SPREAD_NODES
from sma_gym.physics.transformation import MINOR_LOOP_LAWS, WIDTH_PAIRINGS, hysteron_nodes


@dataclass(frozen=True)
class Wire:
    """The NiTi wire: geometry, thermal, elastic, transformation and electrical data.

    Defaults are the report's 0.3 mm two-way Flexinol wire of the MigaOne (Table 5.1).
    """

    diameter_m: float = 0.3e-3
    """d [m] = 0.3e-3. Table 3.1 / 5.1. Area, mass, surface and resistance follow from it."""

    length_m: float = 0.273
    """l0 [m] = 0.273: total length of the five segments (Table 3.1); strokes add."""

    density_kg_m3: float = 6500.0
    """rho [kg/m^3] = 6500 (Table 5.1; the Flexinol datasheet gives 6450)."""

    specific_heat_j_kg_k: float = 837.4
    """c_p [J/(kg K)] = 837.4. Erratum: Table 5.1 prints 0.8374, which is J/(g K)."""

    youngs_modulus_austenite_pa: float = 83e9
    """D_A [Pa] = 83e9 (Table 5.1)."""

    youngs_modulus_martensite_pa: float = 34e9
    """D_M [Pa] = 34e9 (Table 5.1). We use Elahinia's D(xi) = xi D_M + (1 - xi) D_A
    rather than the report's fixed mean, so a fully contracted wire is as stiff as austenite."""

    austenite_start_c: float = 75.0
    """A_s [degC] = 75 at zero stress (Table 5.1; §5.6 says it was tuned to the experiments)."""

    austenite_finish_c: float = 110.0
    """A_f [degC] = 110 at zero stress (Table 5.1, §3.1)."""

    martensite_start_c: float = 95.0
    """M_s [degC] = 95 at zero stress (Table 5.1). Unusually above A_s; kept because with it
    A_s - M_f = A_f - M_s = 15 K, i.e. the report's major loop is a constant 15 K hysteresis
    (each hysteron's at most; the nominal wire's, spread by ``hysteron_width_spread``, 7-8 K)."""

    martensite_finish_c: float = 60.0
    """M_f [degC] = 60 at zero stress (Table 5.1, §3.1)."""

    stress_coefficient_austenite_pa_k: float = 10.3e6
    """C_A [Pa/K] = 10.3e6: transformation temperatures rise by sigma / C_A (Table 5.1, Elahinia)."""

    stress_coefficient_martensite_pa_k: float = 10.3e6
    """C_M [Pa/K] = 10.3e6 (Table 5.1)."""

    max_transformation_strain: float = 0.040
    """eps0 [-] = 0.040: strain recovered by a full M -> A transformation; eps0*l0 = 10.9 mm
    is the largest possible stroke (Table 5.1, tuned by the report to its experiments)."""

    thermal_expansion_austenite_1_k: float = 11.0e-6
    """alpha_A [1/K] = 11.0e-6: thermal expansion of austenite (NiTi/Flexinol data:
    6.6e-6 martensite, 11.0e-6 austenite). Table 5.1 lists a single theta_T = -8.8e-6
    'N/(K m^2)' as a 'thermal expansion coefficient': as a stress coefficient it would be
    negligible, so we read it as an expansion coefficient, and 8.8e-6 is exactly the mean of
    the two phases' values. We keep the two: the expansion the position shows is that of the
    hot, fully contracted wire (austenite). With them the real bench's runs that cool, each
    predicted from the other three, went from 0.97 to 0.88 mm RMS (full contraction) and
    0.41 to 0.30 mm (partial) (docs/model.md §2, docs/diagnosis.md). The thermal
    strain is alpha(xi) (T - T_amb) with alpha(xi) = xi alpha_M + (1 - xi) alpha_A and
    theta_T = -D(xi) alpha(xi): heating at fixed position lowers the wire stress, at fixed
    force it lengthens the wire, i.e. lowers the contraction x (eps = eps0 - x/l0)."""

    thermal_expansion_martensite_1_k: float = 6.6e-6
    """alpha_M [1/K] = 6.6e-6: thermal expansion of martensite (NiTi/Flexinol data; see
    ``thermal_expansion_austenite_1_k``)."""

    transformation_spread_k: float = 8.0
    """s_T [K] = 8.0: standard deviation of the local transformation temperatures (the
    centres of the hysterons, see ``physics.transformation``). §5.7: the real wire "starts to
    move immediately after applying a voltage" because resistive heating is not uniform and
    the transition temperatures are a range; the report's own tanh-smoothed model fits
    better for the same reason. Chosen by measurement against the report's rows (``sma-gym
    fidelity``, h0 and rho_A recalibrated for each value). Re-measured on 2026-11-25 (the
    report's loop in the harness, latent heat, each phase's expansion), rows passed of 113:
    79 at 6 K, 81 at 8 K, 82 at 9 and 10 K, 80 at 11 K, 79 at 12 K. The wider spread is what
    makes the 0.1 Hz sine lag longer after its top reversal than after its bottom one, as
    the report's does (PID +0.061 / -0.097 mm): +0.058 / -0.053 mm at 6 K, +0.059 / -0.071
    at 8 K, +0.060 / -0.099 at 10 K; from 6 to 8 K PID + FF's and VSC2 + FF's cooling
    errors, Q8 and Q9 pass, VSC3 + FF's cooling sign and the fan statement 7e (VSC4's
    heating error x1.23 against 1.25) fail. 9 and 10 K also pass A9 (full return below
    60 degC), but the relay at the end-of-travel cut becomes ill-conditioned (issue 11's
    integration goal, ``benchmarks/bench_integration.py --seeds 5``): at 9 K 20 V with 1 s
    blocks is within 0.5 K of the 30 us reference in 1 of 5 sequences (up to 5.8 K), at 10 K
    10 V with 0.25 s blocks in 2 of 3 (1.0 K, the references agreeing within 0.02 K); 8 K
    keeps every row 6 K had there. The price is energy: every step efficiency falls by about
    5 % (15 V: 0.394 against 0.415 %; 5 of the 7 efficiencies of Tables 8.1/8.2 within
    30 % at either spread). Wider still is worse (measured on an older model): 16 K makes the
    wire too slow to extend in the sine (cooling errors of -0.5 mm). Symmetric on purpose:
    a cooling branch spread 1.5-2x wider than the heating one (or narrower, or a lower
    M_f), each with h0 and rho_A recalibrated, was measured against the same rows (at 6 K)
    and every variant lost 3-12 of them."""

    hysteron_width_spread: float = 1.0
    """w [-] = 1.0: spread of the hysterons' loop widths, as a fraction of the major-loop
    width min(A_s - M_f, A_f - M_s) = 15 K: 1 spreads them uniformly over [0, 15 K], 0 gives
    every hysteron the full width (``minor_loop_law="play"`` behaviour). Real wires move
    back within about a kelvin after a reversal (the report's rescaled-cosine law does too,
    and Table 6.1's small sine errors while cooling need it); only narrow hysterons do that.
    The wire's major loop is the hysterons' mean width, 15 (1 - w / 2) K: 7-8 K at w = 1
    (docs/model.md §3; spreading the widths about the full 15 K instead keeps the report's
    loop but lost 8 fidelity rows, measured 2026-11-29)."""

    hysteron_width_pairing: str = "uncorrelated"
    """Which hysteron gets which loop width (``physics.transformation.WIDTH_PAIRINGS``):
    ``"uncorrelated"`` (nominal) pairs widths and centres Latin-hypercube fashion;
    ``"narrow-cold"`` lets the width grow with the centre temperature (the coldest
    hysteron 1.1 K wide, the hottest 13.9 K), so a reversal in the hot, austenite-rich part
    of the loop lags a few kelvin longer than one in the cold part. Measured as the nominal
    model (2026-11-25, with the 6 K spread of then, h0 recalibrated to 81.42): the report's
    0.1 Hz sine then lags about twice as long after its top reversal as after its bottom
    one, as the report's does (PID +0.057 / -0.096 mm against +0.061 / -0.097; uncorrelated
    +0.058 / -0.053), and ``sma-gym
    fidelity`` passes 82 rows instead of 79. Not adopted, because everything measured
    outside the report's rows went the other way: the real bench's twin re-identified with
    it fitted all four runs worse (0.54-0.86 against 0.39-0.72 mm RMS); the latched relay at
    the end-of-travel cut became ill-conditioned (10 V, 0.25 s blocks: 0.55 K and up to 8 K
    from the 30 us reference, whose own 10 us check parts by up to 0.9 K; issue 11's
    integration goal, met with uncorrelated widths); and the default agent over five seeds
    lost its step goal (0.858 [0.788, 1.453] mm, one seed 1.750, against the best baseline's
    1.061; sine 0.045 [0.038, 0.052]), though over ten seeds the nominal model misses it
    too (7/10; docs/training.md). Kept as a named option for a wire that reverses
    asymmetrically (docs/model.md §3)."""

    minor_loop_law: str = "preisach"
    """Hysteresis law: ``"preisach"`` (hysterons spread in centre and width, the nominal
    model) or ``"play"`` (sma-gym 0.1: one full-width play operator per centre; after a
    reversal the wire crosses the whole 15 K hysteresis before it moves). See
    ``physics.transformation``."""

    latent_heat_j_kg: float = 24200.0
    """Delta_H [J/kg] = 24200: latent heat of the M <-> A transformation (Flexinol datasheet,
    24.2 J/g), absorbed while heating and released while cooling. The report left it out
    (§5.8: "tried without gain"), but without it every efficiency of Tables 8.1/8.2 comes out
    1.5-1.9x too high: the energy a contraction costs is part of a faithful model."""

    resistivity_martensite_ohm_m: float = 9.7096e-7
    """rho_M [ohm m] = 97.1e-6 ohm cm at the reference temperature: loaded (detwinned)
    martensite. Calibrated to §4.2 / Table 3.1: 3.75 ohm for the cold, extended 273 mm wire.
    Higher than the datasheet's unloaded 80 uohm cm: the measured resistance *falls* as the
    wire contracts (§4.2), which a datasheet-only mix cannot give."""

    resistivity_austenite_ohm_m: float = 7.78249e-7
    """rho_A [ohm m] = 77.8e-6 ohm cm at the reference temperature. Calibrated so that R falls
    to 3.25 ohm near 7 mm while heating in the §4.2 experiment (figs. 4.8-4.9); see
    ``python -m sma_gym.calibration``."""

    resistivity_tcr_martensite_1_k: float = 2.0e-4
    """alpha_R,M [1/K] = 2e-4: relative temperature coefficient of the martensite resistivity.
    Bounded by the report: the extended wire never reads much above 3.8 ohm while it heats to
    A_s (figs. 4.4-4.9), so alpha_R,M <~ 2e-4. It gives the near-vertical R(x) segment below
    1 mm, where R(x) is not linear (§4.2)."""

    resistivity_tcr_austenite_1_k: float = 1.0e-3
    """alpha_R,A [1/K] = 1e-3: relative temperature coefficient of the austenite resistivity
    (metallic, positive). With alpha_R,M it makes the heating and cooling R(x) branches, which
    lie 7-8 K apart in the nominal wire (15 K in the report's), differ in slope (§4.2, fig. 4.9)."""

    resistivity_reference_c: float = 20.0
    """T_ref [degC] = 20: temperature at which rho_M and rho_A are given (our choice: the
    room temperature the report's resistances were measured at, §4.2, and the datasheet's)."""

    # Bounds are what a NiTi-type actuator wire can physically be, wide enough for every
    # alloy and wire sold, narrow enough to catch unit slips (mm for m, GPa for Pa, J/(g K)
    # for J/(kg K)) and the degenerate wires that make the simulation meaningless.
    _BOUNDS: ClassVar[tuple[Bound, ...]] = (
        Bound(
            ("diameter_m",),
            25e-6,
            2e-3,
            unit="m",
            why="actuator wires are drawn from 25 um (the thinnest Flexinol) to about 2 mm",
        ),
        Bound(
            ("length_m",),
            0.01,
            5.0,
            unit="m",
            why="shorter than 1 cm strokes only micrometres (and heats in microseconds); "
            "longer than 5 m is not a single actuator wire",
        ),
        Bound(
            ("density_kg_m3",),
            5000.0,
            9000.0,
            unit="kg/m^3",
            why="NiTi is 6450-6500 kg/m^3, copper-based shape-memory alloys up to about 8000",
        ),
        Bound(
            ("specific_heat_j_kg_k",),
            200.0,
            2000.0,
            unit="J/(kg K)",
            why="metals lie in 100-1000 J/(kg K), NiTi 320-840; 0.84 would be J/(g K)",
        ),
        Bound(
            ("youngs_modulus_austenite_pa", "youngs_modulus_martensite_pa"),
            1e9,
            300e9,
            unit="Pa",
            why="NiTi is 20-90 GPa, no metal exceeds 300 GPa; 83 would be GPa",
        ),
        Bound(
            ("stress_coefficient_austenite_pa_k", "stress_coefficient_martensite_pa_k"),
            1e6,
            50e6,
            unit="Pa/K",
            why="Clausius-Clapeyron slopes of shape-memory alloys are 2-20 MPa/K",
        ),
        Bound(
            ("max_transformation_strain",),
            0.0,
            0.1,
            why="a fraction (not percent); NiTi recovers at most about 8 %",
            lower_open=True,
        ),
        Bound(
            ("austenite_start_c", "austenite_finish_c", "martensite_start_c", "martensite_finish_c"),
            -150.0,
            300.0,
            unit="degC",
            why="shape-memory alloys transform between about -150 degC and 300 degC (NiTiHf)",
        ),
        Bound(("resistivity_reference_c",), -100.0, 300.0, unit="degC", why="a laboratory reference temperature"),
        Bound(
            ("resistivity_martensite_ohm_m", "resistivity_austenite_ohm_m"),
            1e-7,
            1e-5,
            unit="ohm m",
            why="NiTi is 0.7-1.0e-6 ohm m (70-100 uohm cm), metals 1e-8 to 1e-5",
        ),
        Bound(
            ("transformation_spread_k",),
            0.0,
            30.0,
            unit="K",
            why="wider than 30 K the transformation would span more than its own hysteresis",
        ),
        Bound(("hysteron_width_spread",), 0.0, 1.0, why="a fraction of the major-loop width"),
        Bound(
            ("latent_heat_j_kg",),
            0.0,
            60000.0,
            unit="J/kg",
            why="NiTi releases 15-30 J/g (Flexinol 24.2 J/g); no alloy exceeds about 60 J/g",
        ),
        Bound(
            ("thermal_expansion_austenite_1_k", "thermal_expansion_martensite_1_k"),
            -1e-4,
            1e-4,
            unit="1/K",
            why="metals expand by about 1e-5 per kelvin",
        ),
        Bound(
            ("resistivity_tcr_martensite_1_k", "resistivity_tcr_austenite_1_k"),
            -5e-3,
            5e-3,
            unit="1/K",
            why="metal resistivities change by at most about 0.5 % per kelvin",
        ),
    )
    """The physical range of each numeric field (checked by :meth:`validate`)."""

    def __post_init__(self) -> None:
        # Checked when built, not only inside ActuatorParams: a Wire(diameter_m=-1) gave
        # derived values (area, resistance) without a word.
        self.validate()

    def validate(self) -> None:
        """Raise ``ValueError`` naming the first invalid field, its value and the physical range."""
        check_bounds(self, self._BOUNDS)
        require_choice("Wire.minor_loop_law", self.minor_loop_law, MINOR_LOOP_LAWS)
        require_choice("Wire.hysteron_width_pairing", self.hysteron_width_pairing, WIDTH_PAIRINGS)
        if self.austenite_finish_c <= self.austenite_start_c:
            raise ValueError(
                f"Wire.austenite_finish_c = {self.austenite_finish_c!r}: expected a value > "
                f"Wire.austenite_start_c = {self.austenite_start_c!r} (A_f > A_s)"
            )
        if self.martensite_start_c <= self.martensite_finish_c:
            raise ValueError(
                f"Wire.martensite_start_c = {self.martensite_start_c!r}: expected a value > "
                f"Wire.martensite_finish_c = {self.martensite_finish_c!r} (M_s > M_f)"
            )
        # The heating branch must lie at higher temperature than the cooling branch
        # everywhere, otherwise the 'hysteresis loop' would have negative width.
        if self.austenite_start_c < self.martensite_finish_c:
            raise ValueError(
                f"Wire.austenite_start_c = {self.austenite_start_c!r}: expected a value >= "
                f"Wire.martensite_finish_c = {self.martensite_finish_c!r} (heating branch above cooling branch)"
            )
        if self.austenite_finish_c < self.martensite_start_c:
            raise ValueError(
                f"Wire.austenite_finish_c = {self.austenite_finish_c!r}: expected a value >= "
                f"Wire.martensite_start_c = {self.martensite_start_c!r} (heating branch above cooling branch)"
            )

    # Derived geometry ------------------------------------------------------------------
    @property
    def area_m2(self) -> float:
        """Cross-section A = pi d^2 / 4 [m^2]."""
        return math.pi * self.diameter_m**2 / 4.0

    @property
    def surface_m2(self) -> float:
        """Convective surface A_c = pi d l0 [m^2]."""
        return math.pi * self.diameter_m * self.length_m

    @property
    def mass_kg(self) -> float:
        """m = rho A l0 [kg]. Erratum: Table 5.1 prints d*A*rho."""
        return self.density_kg_m3 * self.area_m2 * self.length_m

    @property
    def heat_capacity_j_k(self) -> float:
        """m c_p [J/K]."""
        return self.mass_kg * self.specific_heat_j_kg_k

    @property
    def max_stroke_m(self) -> float:
        """eps0 * l0 [m]: contraction of a fully transformed, unloaded wire."""
        return self.max_transformation_strain * self.length_m

    @property
    def cold_resistance_ohm(self) -> float:
        """Resistance of the extended martensitic wire at the reference temperature [ohm]."""
        return self.resistivity_martensite_ohm_m * self.length_m / self.area_m2

    def hysterons(
        self,
        extra_spread_k: float = 0.0,
        centre_form: str = "default",
        min_width_share: float = 0.0,
        widths_form: str = "default",
    ) -> tuple[list[float], list[float], list[float], float]:
        """The wire's hysterons, ``(shift_h, shift_c, weights, widening_k)`` of
        :func:`sma_gym.physics.transformation.hysteron_nodes`: hysteron k heats from
        ``A_s - widening_k / 2 + shift_h[k]`` (plus sigma / C_A) and cools from
        ``M_s + widening_k / 2 + shift_c[k]``. The effects that reshape them enter as
        arguments (``extra_spread_k`` adds to the wire's spread in quadrature); the one
        derivation the simulator packs and the rest limit reads."""
        return hysteron_nodes(
            math.hypot(self.transformation_spread_k, extra_spread_k),
            self.hysteron_width_spread,
            min(self.austenite_start_c - self.martensite_finish_c, self.austenite_finish_c - self.martensite_start_c),
            self.minor_loop_law,
            centre_form,
            MAX_SPREAD_NODES,
            min(self.austenite_finish_c - self.austenite_start_c, self.martensite_start_c - self.martensite_finish_c),
            self.hysteron_width_pairing,
            min_width_share,
            widths_form,
        )

    @property
    def coldest_heating_start_c(self) -> float:
        """A_s - widening / 2 + min_k shift_h[k] [degC], stress-free: where the coldest
        hysteron's heating branch starts, i.e. where a spread wire starts to contract (about
        16.6 K below A_s for the standard wire's 8 K spread; A_s itself without spread)."""
        shift_h, _, _, widening_k = self.hysterons()
        return self.austenite_start_c - 0.5 * widening_k + min(shift_h)


@dataclass(frozen=True)
class Mechanism:
    """What the wire pulls: a moving mass against a preloaded linear bias spring (§5.1)."""

    moving_mass_kg: float = 0.0088
    """M_t [kg] = 0.0088. Table 5.1 gives 4 g per segment; the five segments of the MigaOne
    move 1/5 ... 5/5 of the stroke, so their kinetic-energy-equivalent mass at the output is
    0.004 * (1 + 4 + 9 + 16 + 25) / 25 = 8.8 g."""

    damping_n_s_m: float = 5.0
    """c [N s/m] = 5: viscous friction (§5.1 names it, gives no value). Our choice: damping
    ratio 0.18 (austenite, 250 Hz) to 0.28 (martensite, 160 Hz) of the wire/mass resonance
    with the 8.8 g mass; it hardly matters below 100 Hz because the wire is much stiffer than
    the spring."""

    spring_stiffness_n_m: float = 250.0
    """k [N/m] = 250: bias spring (Table 5.1)."""

    spring_preload_n: float = 2.0
    """F_pre [N] = 2.0: bias force at rest. Erratum: Table 5.1's sigma0 = 6.3 MPa would be
    0.45 N on a 0.3 mm wire, but the force transducer of §8 (fig. 8.1) measures about 2 N at
    rest; measured behaviour wins. The report's tuner applies the same initial force to every
    wire (§3.2), so 2 N holds for the 0.2 and 0.5 mm wires as well. The wire's stress at rest
    is sigma0 = F_pre / A."""

    _BOUNDS: ClassVar[tuple[Bound, ...]] = (
        Bound(
            ("moving_mass_kg",),
            1e-4,
            10.0,
            unit="kg",
            why="from a 0.1 g pointer to 10 kg, more than any wire actuator lifts",
        ),
        Bound(
            ("damping_n_s_m",),
            0.0,
            1e4,
            unit="N s/m",
            why="viscous friction of a small mechanism (1e4 N s/m would hold 10 kN at 1 m/s)",
        ),
        Bound(
            ("spring_stiffness_n_m",),
            0.0,
            1e5,
            unit="N/m",
            why="bias springs of wire actuators are 10-1e4 N/m; 1e5 N/m is already stiffer than most wires",
        ),
        Bound(
            ("spring_preload_n",),
            0.0,
            1000.0,
            unit="N",
            why="the thickest wires are loaded with tens of newtons and break below 1000 N",
        ),
    )
    """The physical range of each numeric field (checked by :meth:`validate`)."""

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Raise ``ValueError`` naming the first invalid field, its value and the physical range."""
        check_bounds(self, self._BOUNDS)


@dataclass(frozen=True)
class Convection:
    """Heat loss to the surroundings, h(T) = h0 + h2 T^2 with T in degC (§5.4, eq. 5.10).

    h0 and h2 are given for a wire of ``reference_diameter_m``; for another diameter both are
    multiplied by (d / d_ref) ** ``diameter_exponent``, the thin-cylinder natural-convection
    correlation (Morgan 1975, Nu = 1.02 Ra^0.148 for 1e-2 < Ra < 1e2 gives h ~ d^-0.556).
    """

    h0_w_m2_k: float = 81.197
    """h0 [W/(m^2 K)] = 81.20 (natural convection; the report gives no value). Calibrated so
    that holding 5 mm at 10 V needs a duty of 0.06 on the heating branch (T4, fig. 6.4); see
    ``python -m sma_gym.calibration`` (81.205 on the code of 2026-12-07: 1e-4 apart, which
    moves the holding duty by about as much, so the value and every figure measured with it
    were kept). Thin-wire natural convection plus radiation predicts about 76 at 0.3 mm and
    96 degC (Morgan 1975), in line."""

    h2_w_m2_k3: float = 1.5e-3
    """h2 [W/(m^2 K^3)] = 1.5e-3: sets the growth of h with temperature to about +20 % from
    60 to 120 degC, as thin-wire natural convection plus radiation (emissivity ~0.5) gives.
    Published fits of the same law: 1e-3 (Elahinia & Ashrafiuon 2002; Jayender 2008)."""

    ambient_temperature_c: float = 20.0
    """T_amb [degC] = 20 (Table 5.1)."""

    reference_diameter_m: float = 0.3e-3
    """d_ref [m] = 0.3e-3: diameter at which h0 and h2 are given (the report's wire, on which
    h0 is calibrated)."""

    diameter_exponent: float = -0.556
    """n [-] = -0.556: h scales as (d/d_ref)^n (Morgan correlation, see class docstring)."""

    _BOUNDS: ClassVar[tuple[Bound, ...]] = (
        Bound(
            ("h0_w_m2_k",),
            0.0,
            2e4,
            unit="W/(m^2 K)",
            why="from still air (about 10) to water cooling (about 1e4) of a thin wire",
        ),
        Bound(
            ("h2_w_m2_k3",),
            0.0,
            0.1,
            unit="W/(m^2 K^3)",
            why="the growth of h with temperature; 0.1 already adds 1000 W/(m^2 K) at 100 degC",
        ),
        Bound(("ambient_temperature_c",), -60.0, 200.0, unit="degC", why="an ambient a wire actuator works in"),
        Bound(
            ("reference_diameter_m",),
            25e-6,
            2e-3,
            unit="m",
            why="the diameter of a wire h0 and h2 were measured on (25 um to 2 mm, as Wire.diameter_m)",
        ),
        Bound(
            ("diameter_exponent",),
            -2.0,
            2.0,
            why="convection correlations scale h with d to a power between about -1 and 0",
        ),
    )
    """The physical range of each numeric field (checked by :meth:`validate`)."""

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Raise ``ValueError`` naming the first invalid field, its value and the physical range."""
        check_bounds(self, self._BOUNDS)
        if self.h0_w_m2_k == 0.0 and self.h2_w_m2_k3 == 0.0:
            raise ValueError("Convection.h0_w_m2_k = 0.0: expected h0 > 0 or h2 > 0 (a wire must lose heat)")

    def scale_for(self, diameter_m: float) -> float:
        """Multiplier on h0 and h2 for a wire of ``diameter_m``."""
        return (diameter_m / self.reference_diameter_m) ** self.diameter_exponent


@dataclass(frozen=True)
class Driver:
    """Supply, MOSFET PWM switch and the driver's end-of-travel cut (§3.1, §3.4, §4.1)."""

    supply_voltage_v: float = 10.0
    """V [V] = 10: standard condition (§6.1, §7). The report's range is 5-20 V; up to 30 V
    is feasible (§6.1)."""

    pwm_frequency_hz: float = 500.0
    """f_PWM [Hz] = 500: standard condition (§7). §4.1 lowered it from 1 kHz so that the
    minimum duty for a resistance reading halves."""

    settling_time_s: float = 50e-6
    """t_settle [s] = 50e-6: voltage and current need about 50 us after switch-on before
    V/I is a valid resistance reading (§4.1, fig. 4.1). Readings are taken then."""

    @property
    def min_readable_duty(self) -> float:
        """D_min [-] = t_settle * f_PWM: the smallest duty whose pulse lasts the settling time,
        the shortest that gives a V/I reading (§4.1; 0.025 at the standard 500 Hz)."""
        return self.settling_time_s * self.pwm_frequency_hz

    end_of_travel_m: float = 9.5e-3
    """x_eot [m] = 9.5e-3: the driver cuts the power when the actuator reaches its end of
    travel (§3.1), which is why the stroke is about 9.5 mm (Table 3.1) and not eps0*l0.
    ``math.inf`` disables the cut."""

    end_of_travel_release_m: float = 0.2e-3
    """Delta x_eot [m] = 0.2e-3: power returns once the position has fallen this far below x_eot (our
    choice: an end-of-travel switch has some hysteresis, and without it the cut would chatter
    at the PWM rate)."""

    _BOUNDS: ClassVar[tuple[Bound, ...]] = (
        Bound(
            ("supply_voltage_v",),
            0.0,
            60.0,
            unit="V",
            why="wire actuators run from a few volts; above 60 V is no longer a safety extra-low voltage",
            lower_open=True,
        ),
        Bound(
            ("pwm_frequency_hz",), 1.0, 100e3, unit="Hz", why="a MOSFET PWM driver switches between 1 Hz and 100 kHz"
        ),
        Bound(
            ("settling_time_s",),
            0.0,
            1e-3,
            unit="s",
            why="voltage and current settle within microseconds to a millisecond after switch-on",
        ),
        Bound(("end_of_travel_release_m",), 0.0, 1.0, unit="m", why="the hysteresis of the end-of-travel switch"),
    )
    """The physical range of each numeric field (checked by :meth:`validate`)."""

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Raise ``ValueError`` naming the first invalid field, its value and the physical range."""
        check_bounds(self, self._BOUNDS)
        if not (self.end_of_travel_m == math.inf):
            require_range(
                "Driver.end_of_travel_m",
                self.end_of_travel_m,
                0.0,
                1.0,
                "m",
                lower_open=True,
                why="an end-of-travel cut within the stroke of a wire actuator, or inf for none",
            )


@dataclass(frozen=True)
class Sensors:
    """Position sensor, current transducer and voltage divider (§3.1, §3.4)."""

    position_filter_cutoff_hz: float = 100.0
    """f_c [Hz] = 100: first-order low-pass filter of the Alps resistive position sensor
    (§3.1 says it is low-pass filtered against PWM noise, not how much; our choice keeps the
    500 Hz switching out while adding only 1.6 ms of lag). 0 disables it."""

    position_noise_std_m: float = 0.0
    """sigma_x [m] = 0: standard deviation of white noise on each position sample (off by
    default; our choice: the report gives none; the evaluation harness uses 2 um)."""

    position_resolution_m: float = 0.0
    """q_x [m] = 0: quantisation step of the position reading (0 = none; our choice). The
    report's 16-bit ADC over a ~10 mm sensor range would give ~0.3 um."""

    resistance_noise_std_ohm: float = 0.0
    """sigma_R [ohm] = 0: standard deviation of noise on each resistance reading (our choice:
    the report gives none)."""

    current_noise_std_a: float = 0.0
    """sigma_I [A] = 0: standard deviation of noise on each current reading (our choice: the
    report gives none)."""

    voltage_noise_std_v: float = 0.0
    """sigma_V [V] = 0: standard deviation of noise on each voltage reading (our choice: the
    report gives none)."""

    _BOUNDS: ClassVar[tuple[Bound, ...]] = (
        Bound(
            ("position_filter_cutoff_hz",),
            0.0,
            1e6,
            unit="Hz",
            why="0 disables the filter; a sensor filter is below 1 MHz",
        ),
        Bound(
            ("position_noise_std_m",),
            0.0,
            0.01,
            unit="m",
            why="noise beyond 1 cm exceeds a wire actuator's whole stroke (mm for m?)",
        ),
        Bound(
            ("position_resolution_m",),
            0.0,
            0.01,
            unit="m",
            why="a quantisation step beyond 1 cm exceeds a wire actuator's whole stroke",
        ),
        Bound(("resistance_noise_std_ohm",), 0.0, 100.0, unit="ohm", why="wires are ohms to about 100 ohm"),
        Bound(("current_noise_std_a",), 0.0, 10.0, unit="A", why="wire currents are tens of mA to a few A"),
        Bound(("voltage_noise_std_v",), 0.0, 60.0, unit="V", why="the supply is at most 60 V"),
    )
    """The physical range of each numeric field (checked by :meth:`validate`)."""

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Raise ``ValueError`` naming the first invalid field, its value and the physical range."""
        check_bounds(self, self._BOUNDS)


@dataclass(frozen=True)
class ActuatorParams:
    """A complete actuator: wire, mechanism, convection, driver and sensors."""

    wire: Wire = field(default_factory=Wire)
    """The SMA wire: geometry, phases, transformation, resistivity (:class:`Wire`)."""
    mechanism: Mechanism = field(default_factory=Mechanism)
    """The sleigh and the bias spring it pulls against (:class:`Mechanism`)."""
    convection: Convection = field(default_factory=Convection)
    """How the wire loses heat to its surroundings (:class:`Convection`)."""
    driver: Driver = field(default_factory=Driver)
    """Supply, PWM and the end-of-travel cut (:class:`Driver`)."""
    sensors: Sensors = field(default_factory=Sensors)
    """Position filter and the sensors' noise and resolution (:class:`Sensors`)."""
    name: str = "standard"
    """The name tables, plots, saved files and messages show (a preset's own name unless
    :meth:`with_changes` is given another)."""
    description: str = "The report's actuator under standard conditions (0.3 mm, 10 V, natural convection, 500 Hz)."
    """One line on what this actuator is (shown with the name)."""

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Check every field; raise ``ValueError`` naming the first bad one."""
        for key in ("name", "description"):
            # Saved files, reports and messages carry both; a model file refuses anything else.
            if not isinstance(getattr(self, key), str) or (key == "name" and not self.name):
                raise ValueError(
                    f"ActuatorParams.{key} = {getattr(self, key)!r}: expected a {'non-empty ' * (key == 'name')}string"
                )
        for part, cls in (
            ("wire", Wire),
            ("mechanism", Mechanism),
            ("convection", Convection),
            ("driver", Driver),
            ("sensors", Sensors),
        ):
            value = getattr(self, part)
            if not isinstance(value, cls):
                raise ValueError(f"ActuatorParams.{part} = {value!r}: expected a {cls.__name__}")
            value.validate()
        if self.driver.end_of_travel_release_m >= self.driver.end_of_travel_m:
            raise ValueError(
                f"Driver.end_of_travel_release_m = {self.driver.end_of_travel_release_m!r}: expected a "
                f"value < Driver.end_of_travel_m = {self.driver.end_of_travel_m!r}"
            )
        # The bias spring's preload on the wire's cross-section: NiTi breaks at 1-1.5 GPa, so a
        # rest stress above 2 GPa (e.g. newtons on a 25 um wire) is not an actuator.
        stress = self.mechanism.spring_preload_n / self.wire.area_m2
        if stress > 2e9:
            raise ValueError(
                f"Mechanism.spring_preload_n = {self.mechanism.spring_preload_n!r}: a rest stress of {stress:.3g} Pa on a "
                f"Wire.diameter_m = {self.wire.diameter_m!r} wire; expected at most 2e9 Pa (NiTi breaks at 1-1.5 GPa)"
            )

        # A wire whose surroundings are past its transformation never rests cold and extended
        # (a superelastic wire, or ambient set above A_s): every reset would start it moving.
        if self.convection.ambient_temperature_c >= self.highest_rest_temperature_c:
            raise ValueError(
                f"Convection.ambient_temperature_c = {self.convection.ambient_temperature_c!r}: expected a value "
                f"below the wire's stress-shifted transformation start (its coldest hysteron's, "
                f"ActuatorParams.highest_rest_temperature_c = {self.highest_rest_temperature_c:.1f} degC; "
                f"Wire.austenite_start_c = {self.wire.austenite_start_c!r}, "
                f"Wire.transformation_spread_k = {self.wire.transformation_spread_k!r}), where it rests cold and extended"
            )

        # Convenience -----------------------------------------------------------------------
        # The envs scale positions by the usable stroke: a wire whose thermal expansion up to
        # its transformation eats all of eps0 has none.
        if self.loaded_reach_m <= 0.0:
            raise ValueError(
                f"Wire.max_transformation_strain = {self.wire.max_transformation_strain!r}: the loaded, heated wire "
                "does not contract at all (its thermal expansion up to A_f + sigma / C_A exceeds it, "
                "ActuatorParams.loaded_reach_m); expected a strain that leaves a stroke"
            )

    @property
    def highest_rest_temperature_c(self) -> float:
        """Coldest heating start + sigma0 / C_A [degC]: where the first hysteron starts to
        transform at the rest stress (:attr:`Wire.coldest_heating_start_c`), above which the
        wire cannot rest fully martensitic (the surroundings must be colder). 61.1 degC for
        the standard wire, whose 8 K spread starts it 16.6 K below A_s + sigma0 / C_A = 77.7
        degC (that bound, used until 2026-12-07, let a reset at 77 degC contract 0.56 mm
        unpowered)."""
        return self.wire.coldest_heating_start_c + self.rest_stress_pa / self.wire.stress_coefficient_austenite_pa_k

    @property
    def rest_stress_pa(self) -> float:
        """sigma0 = F_pre / A [Pa]: wire stress at rest (x = 0)."""
        return self.mechanism.spring_preload_n / self.wire.area_m2

    @property
    def loaded_reach_m(self) -> float:
        """x_A [m]: how far the loaded wire contracts once fully austenitic, at the temperature
        its heating branch finishes under the spring's largest load.

        The mechanics' static balance with xi = 0 (docs/model.md §2), k x = A D_A (eps0 - x / l0
        - alpha_A (T - T_amb)), gives x_A = l0 (eps0 - alpha_A (T - T_amb)) / (1 + k l0 / (A D_A)),
        with T = A_f + sigma / C_A at sigma = (F_pre + k eps0 l0) / A. The spring stretches the
        austenite and the hot wire expands, so x_A < eps0 l0: 10.51 mm of the report's wire's
        10.92 (beyond its 9.5 mm cut; the simulator holds 10.45 mm at 135 degC); a 0.25 mm,
        0.2 m wire at 12 V on a 600 N/m spring 7.55 of its 8.0 mm (held: at most 7.4 mm, at
        194 degC); the real bench of ``../shared/data/real`` (twin ``bench-0.5mm-ht``)
        17.16 of 17.96 mm, where its runs reach 16.6-16.8 mm. Hotter, the wire expands and
        holds less (6.8 mm at duty 1, 476 degC).
        """
        w, m = self.wire, self.mechanism
        sigma_pa = (m.spring_preload_n + m.spring_stiffness_n_m * w.max_stroke_m) / w.area_m2
        hot_c = w.austenite_finish_c + sigma_pa / w.stress_coefficient_austenite_pa_k
        strain = w.max_transformation_strain - w.thermal_expansion_austenite_1_k * (
            hot_c - self.convection.ambient_temperature_c
        )
        stretch = m.spring_stiffness_n_m * w.length_m / (w.area_m2 * w.youngs_modulus_austenite_pa)
        return max(0.0, w.length_m * strain / (1.0 + stretch))

    @property
    def usable_stroke_m(self) -> float:
        """The stroke a controller can use [m]: the driver's end-of-travel position or the
        loaded wire's reach (:attr:`loaded_reach_m`), whichever is shorter (a short wire or a
        stiff spring never reaches the standard cut's 9.5 mm). The envs scale positions and
        draw references by it."""
        return min(self.driver.end_of_travel_m, self.loaded_reach_m)

    @property
    def full_power_heating_rate_k_s(self) -> float:
        """V^2 / (R_cold m c_p) [K/s]: how fast the cold wire heats at duty 1 before any
        heat leaves it (1015 K/s for the report's wire at 20 V, 254 K/s at 10 V)."""
        return self.driver.supply_voltage_v**2 / self.wire.cold_resistance_ohm / self.wire.heat_capacity_j_k

    def with_changes(self, **changes: Any) -> ActuatorParams:
        """Return a copy with fields changed, addressed as ``"part.field"`` or ``part=Part(...)``.

        ``name`` and ``description`` stay the original's unless given: name a model of your
        own (``name="my-wire", description=...``), since saved files, reports and messages
        carry them.

        >>> p = standard().with_changes(**{"driver.supply_voltage_v": 15.0})
        """
        parts: dict[str, dict[str, Any]] = {}
        top: dict[str, Any] = {}
        for key, value in changes.items():
            if "." in key:
                part, name = key.split(".", 1)
                if part not in _PARTS:
                    raise ValueError(f"unknown parameter group {part!r} in {key!r}")
                known = {f.name for f in dataclasses.fields(getattr(self, part))}
                if name not in known:
                    raise ValueError(
                        f"unknown parameter {key!r}: {type(getattr(self, part)).__name__} has {sorted(known)}"
                    )
                parts.setdefault(part, {})[name] = value
            else:
                top[key] = value
        for part, fields_ in parts.items():
            top[part] = replace(getattr(self, part), **fields_)
        return replace(self, **top)

    def to_dict(self) -> dict[str, Any]:
        """Plain nested dict (JSON-serialisable: a numpy number given as a value, e.g.
        ``np.float32(12)``, is written as the Python number it stands for)."""

        def plain(tree: Any) -> Any:
            if isinstance(tree, dict):
                return {k: plain(v) for k, v in tree.items()}
            # (a 0-d array too: np.array(15.0) passed every check and then failed json.dumps)
            return tree.item() if isinstance(tree, np.generic | np.ndarray) and np.ndim(tree) == 0 else tree

        return plain(dataclasses.asdict(self))

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> ActuatorParams:
        """Inverse of :meth:`to_dict`; unknown and missing parameters raise ``ValueError``.

        Every parameter must be given: a file that leaves one out would otherwise run with the
        standard actuator's value (a 0.5 mm wire's file without its diameter as the report's
        0.3 mm wire), and a file of an older version without a newer parameter with today's
        default rather than the model it was saved from. ``name`` and ``description`` may be
        left out."""
        if not isinstance(data, dict):
            raise ValueError(f"actuator parameters = {data!r}: expected a JSON object")
        kwargs: dict[str, Any] = {}
        groups = _PARTS
        for key, value in data.items():
            if key in groups:
                known = {f.name for f in dataclasses.fields(groups[key])}
                if not isinstance(value, dict):
                    raise ValueError(f"actuator parameters.{key} = {value!r}: expected a JSON object")
                if key == "wire":
                    value = _one_expansion_for_both_phases(value)
                unknown = set(value) - known
                if unknown:
                    raise ValueError(f"unknown parameter(s) {sorted(unknown)} in group {key!r}; known: {sorted(known)}")
                defaults = {f.name: f.default for f in dataclasses.fields(groups[key])}
                missing = [name for name in defaults if name not in value]
                if missing:
                    shown = ", ".join(f"{name} (the standard actuator's: {defaults[name]!r})" for name in missing)
                    raise ValueError(
                        f"missing parameter(s) in group {key!r}: {shown}; a model file gives every parameter, "
                        "so that none silently takes the standard actuator's value"
                    )
                kwargs[key] = groups[key](
                    **{k: _json_typed(f"{key}.{k}", _json_float(v), defaults[k]) for k, v in value.items()}
                )
            elif key in ("name", "description"):
                if not isinstance(value, str):
                    raise ValueError(f"actuator parameters.{key} = {value!r}: expected a string")
                kwargs[key] = value
            else:
                raise ValueError(f"unknown key {key!r} in actuator parameters")
        missing_groups = [key for key in groups if key not in data]
        if missing_groups:
            raise ValueError(
                f"actuator parameters: missing group(s) {missing_groups}: a model file gives every group "
                f"({', '.join(groups)}) and every parameter in it (ModelConfig.save writes them all)"
            )
        return cls(**kwargs)


def _one_expansion_for_both_phases(wire: dict[str, Any]) -> dict[str, Any]:
    """Files written before the wire had one expansion per phase carry the report's single
    ``thermal_expansion_1_k``: it becomes both phases' value, so such a file still loads as
    the model it was saved from."""
    if "thermal_expansion_1_k" not in wire:
        return wire
    out = dict(wire)
    alpha = out.pop("thermal_expansion_1_k")
    phases = ("thermal_expansion_austenite_1_k", "thermal_expansion_martensite_1_k")
    if all(k in out for k in phases):
        # It would be dropped without a word: which did the file mean?
        raise ValueError(
            f"wire.thermal_expansion_1_k = {alpha!r} beside wire.{phases[0]} and wire.{phases[1]}: expected the one "
            "coefficient of older files, or the per-phase ones (it gives a phase that is not given), not all three"
        )
    for key in phases:
        out.setdefault(key, alpha)
    return out


def _json_typed(name: str, value: Any, default: Any) -> Any:
    """``value`` if it has the JSON type of the field's default: a number where the default
    is a number (``"10"`` or ``true`` for a voltage is an error naming the field, not a
    string that fails deep inside the simulation), a string or a boolean likewise."""
    if isinstance(default, bool):
        expected, ok = "true or false", isinstance(value, bool)
    elif isinstance(default, (int, float)):
        expected, ok = "a number", isinstance(value, (int, float)) and not isinstance(value, bool)
    elif isinstance(default, str):
        expected, ok = "a string", isinstance(value, str)
    else:  # no plain default (a tuple, a factory): the dataclass checks it
        return value
    if not ok:
        raise ValueError(f"{name} = {value!r} (JSON {type(value).__name__}): expected {expected}")
    return value


def _json_float(value: Any) -> Any:
    # JSON has no infinity; we write it as the string "inf".
    if isinstance(value, str) and value in ("inf", "Infinity"):
        return math.inf
    return value


# --------------------------------------------------------------------------------------
# Presets
# --------------------------------------------------------------------------------------

#: Fan cooling (§7.1) multiplies h by this factor. docs/model.md §4 quotes 1.6-3.7 for fans
#: (Doroudchi 2018); the report gives no number. We take 2.5, between the low and the high
#: fan setting.
FORCED_CONVECTION_FACTOR = 2.5


def standard() -> ActuatorParams:
    """Standard conditions (§7): 0.3 mm wire, 10 V, natural convection, 500 Hz PWM."""
    return ActuatorParams()


def _supply(voltage: float) -> ActuatorParams:
    p = standard()
    return replace(
        p.with_changes(**{"driver.supply_voltage_v": voltage}),
        name=f"supply-{voltage:g}v",
        description=f"Standard actuator on a {voltage:g} V supply (§5.7, §7.2, §8, §9).",
    )


def _wire(diameter_mm: float) -> ActuatorParams:
    p = standard()
    return replace(
        p.with_changes(**{"wire.diameter_m": diameter_mm * 1e-3}),
        name=f"wire-{diameter_mm:g}mm",
        description=(
            f"Standard actuator with a {diameter_mm:g} mm wire (§7.3): area, mass, surface and "
            "resistance follow from the diameter; h scales as d^-0.556; same 2 N preload (tuner)."
        ),
    )


def forced_convection() -> ActuatorParams:
    """Standard actuator cooled by a fan (§7.1)."""
    p = standard()
    c = p.convection
    return replace(
        p,
        convection=replace(
            c, h0_w_m2_k=c.h0_w_m2_k * FORCED_CONVECTION_FACTOR, h2_w_m2_k3=c.h2_w_m2_k3 * FORCED_CONVECTION_FACTOR
        ),
        name="forced-convection",
        description=f"Standard actuator with fan cooling (§7.1): h multiplied by {FORCED_CONVECTION_FACTOR}.",
    )


def bench_05mm_ht() -> ActuatorParams:
    """The real bench of ``shared/data/real`` (a university course's Flexinol actuator) as its
    makers describe it: the starting point of its twin, the model ``bench-0.5mm-ht``
    (:mod:`sma_gym.models`), which ``python -m sma_gym.calibration twin`` identifies from it.

    From its README: 0.5 mm HT Flexinol, about 0.96 m, 4.3 ohm/m, A_s/A_f/M_s/M_f =
    88/98/72/62 degC, resistivity 76 (M) / 82 (A) uohm cm, Young's modulus 28-40 / 75-83 GPa,
    24 V through an H-bridge, PWM duty 0..0.2, 35 g sleigh, bias spring 0.07 N/mm.

    Unknown there; starting values (the twin refits convection, temperatures and strain) from
    ``python -m sma_gym.calibration bench``, bounded least squares on the position of
    ``step01.csv`` only (``ramp01.csv`` held out) with sma-gym 0.1's play law, the sensor
    zero read off the rest segment:

    - h0 = 40 W/(m^2 K) at 0.3 mm (30 at 0.5 mm), h2 in the standard wire's ratio of then
      (h2 / h0 = 1.5e-3 / 75.6 per K^2; the standard's h0 is 81.197 today): the lower bound of
      the plausible range; the fit wants the wire to heat even faster;
    - eps0 = 0.0189: a lightly loaded wire detwins only partly (16.5 mm on 0.96 m);
    - preload 0.2 N: also at its lower bound.

    Two parameters at their bounds and a held-out error that barely improves (1.55 -> 1.40 mm
    RMS) say the nominal model lacks something: the real wire starts to move 0.95 s after
    switch-on, at about 46 degC by the energy balance, far below A_s = 88 degC, and
    transforms over ~60 K instead of 10 K. ``sma-gym diagnose`` is the tool for that gap.
    Part of it is the datasheet's reference stress: Dynalloy states these temperatures at
    172 MPa, i.e. 16.7 K above the stress-free ones by the report's 10.3 MPa/K. Entered
    16.7 K lower, the leave-one-run-out predictions got worse (step03 0.88 -> 5.6 mm), so
    the numbers stay as the README gives them and the twin's temperature shift carries the
    difference (docs/diagnosis.md, "The datasheet's temperatures hold at 172 MPa").

    Chosen, not identified: the package's minor-loop law; the report's Flexinol values for the
    stress coefficients, c_p and density; NiTi's expansion of each phase (the standard wire's);
    PWM at 1 kHz (the duty is commanded at 1 kHz); no end-of-travel cut; resistivities from the
    README (the README's 4.3 ohm/m fixes rho_M) with temperature coefficients of 1e-4 /K
    (martensite; the standard wire's bound is 2e-4) and 1e-3 /K (austenite, the standard's);
    the report gives none.
    """
    wire = Wire(
        diameter_m=0.5e-3,
        length_m=0.96,
        density_kg_m3=6450.0,
        specific_heat_j_kg_k=837.0,
        youngs_modulus_austenite_pa=79e9,
        youngs_modulus_martensite_pa=34e9,
        austenite_start_c=88.0,
        austenite_finish_c=98.0,
        martensite_start_c=72.0,
        martensite_finish_c=62.0,
        stress_coefficient_austenite_pa_k=10.3e6,
        stress_coefficient_martensite_pa_k=10.3e6,
        max_transformation_strain=0.0189,
        thermal_expansion_austenite_1_k=11.0e-6,
        thermal_expansion_martensite_1_k=6.6e-6,
        resistivity_martensite_ohm_m=4.3 * math.pi * (0.5e-3) ** 2 / 4.0,
        resistivity_austenite_ohm_m=4.3 * math.pi * (0.5e-3) ** 2 / 4.0 * 82.0 / 76.0,
        resistivity_tcr_martensite_1_k=1.0e-4,
        resistivity_tcr_austenite_1_k=1.0e-3,
        # The package's minor-loop law (hysterons spread in width, Preisach); the spread of
        # transformation temperatures and the latent heat start at zero, so that what the
        # twin carries of them is what `sma-gym diagnose` finds its runs ask for (starting
        # from the then-nominal 6 K and 24.2 J/g instead fitted all four runs worse: 0.60-0.99 mm
        # against 0.26-0.64 mm RMS, the latent heat not supported on this wire).
        transformation_spread_k=0.0,
        latent_heat_j_kg=0.0,
        # Widths paired with the centres uncorrelated (the nominal pairing): re-identified with
        # the "narrow-cold" option, the twin fitted every run worse (0.54-0.86 mm against
        # 0.39-0.72 mm RMS, held out 0.03-0.85 against 0.02-0.74 mm).
        hysteron_width_pairing="uncorrelated",
    )
    return ActuatorParams(
        wire=wire,
        mechanism=Mechanism(moving_mass_kg=0.035, damping_n_s_m=5.0, spring_stiffness_n_m=70.0, spring_preload_n=0.2),
        convection=Convection(h0_w_m2_k=40.0, h2_w_m2_k3=40.0 * 1.5e-3 / 75.6),
        driver=Driver(supply_voltage_v=24.0, pwm_frequency_hz=1000.0, end_of_travel_m=math.inf),
        sensors=Sensors(),
        name="bench-0.5mm-ht-datasheet",
        description=(
            "Real bench of shared/data/real from its makers' description (0.5 mm HT Flexinol, 0.96 m, 24 V, "
            "35 g sleigh, 0.07 N/mm spring), before identification; the twin is the model 'bench-0.5mm-ht'."
        ),
    )


def _standard_named() -> ActuatorParams:
    return standard()


_PRESETS = {
    "standard": _standard_named,
    "forced-convection": forced_convection,
    "supply-5v": lambda: _supply(5.0),
    "supply-7.5v": lambda: _supply(7.5),
    "supply-10v": lambda: _supply(10.0),
    "supply-15v": lambda: _supply(15.0),
    "supply-20v": lambda: _supply(20.0),
    "wire-0.2mm": lambda: _wire(0.2),
    "wire-0.3mm": lambda: _wire(0.3),
    "wire-0.5mm": lambda: _wire(0.5),
    "bench-0.5mm-ht-datasheet": bench_05mm_ht,
}


def preset_names() -> tuple[str, ...]:
    """Names accepted by :func:`preset`."""
    return tuple(_PRESETS)


def preset(name: str) -> ActuatorParams:
    """Return the named condition preset (see :func:`preset_names`)."""
    try:
        factory = _PRESETS[name]
    except KeyError:
        raise ValueError(f"preset = {name!r}: expected one of {', '.join(map(repr, _PRESETS))}") from None
    return factory()


def parameter_bound(path: str) -> Bound:
    """The physical range of the actuator parameter ``"part.field"`` (its class's ``_BOUNDS``
    row), for code that checks a value before it becomes a parameter (a sidecar's supply)."""
    part, _, name = path.partition(".")
    if part not in _PARTS:
        raise ValueError(f"parameter {path!r}: expected 'part.field' with part one of {', '.join(_PARTS)}")
    for bound in _PARTS[part]._BOUNDS:
        if name in bound.fields:
            return bound
    raise ValueError(f"parameter {path!r}: no physical range is defined for it")


_PARTS = {"wire": Wire, "mechanism": Mechanism, "convection": Convection, "driver": Driver, "sensors": Sensors}
"""The parameter groups of :class:`ActuatorParams`, by field name."""

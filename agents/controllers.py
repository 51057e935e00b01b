"""The report's controllers (§6, docs/model.md §10), vectorised over n actuators.

Each controller maps what a real controller reads (the measured position, the reference
and its rate, its own time step) to a duty cycle in [0, 1]. They never see the simulator's
hidden state. All share the report's low-pass filter on the measured position (§6.1) and
bounded integral action (anti-windup).

Choices where the report is ambiguous (each reproduces the character of Table 6.1 in
simulation, see ``sma-gym evaluate``):

* Integral gains (PID's Ki = 0.8, VSC4's lambda_I = 0.00025) are per 1 kHz sample: the
  report's PID removes its steady-state error within seconds ("settling time is quite
  slow", §6.1, Table 6.1), which with Ki = 0.8 per metre-second would take about 20
  minutes; LabVIEW's discrete accumulator sums the error per sample. So the integral is
  Ki * sum(e) = Ki * f_loop * integral(e dt), i.e. Ki = 800 /(m s) at 1 kHz. The sum is
  per control step, so at another step the integral's gain in time scales with the loop
  rate: at the envs' default 10 ms the PID's is 80 /(m s) and VSC4's lambda_I 0.025 /s, ten
  times weaker than in the report's loop (the harness runs the controllers at 1 ms; the
  residual agents' base controllers at their env's step, as they were trained).
* Derivatives (PID's Kd = 10, VSC's lambda = 0.0125) act on de/dt in m/s: per-sample
  differences would make them negligible, but the report's tuning trades overshoot against
  them (§6.1, §6.4).
* Boundary layers: the switching term is sat(s / phi) in [-1, 1] (K = 1 / phi inside the
  layer, which the report leaves unstated, so the duty is continuous at its edge), added to
  the feedforward and clipped to [0, 1]. Without feedforward this is exactly the report's
  law (0 below the layer); with it, feedback can also take the duty below the feedforward,
  without which a VSC with feedforward could not cool (the report's can, Table 6.1).
* VSC3/VSC4 use phi = 0.0011 m, not the printed 0.011: with a continuous boundary law the
  steady-state error is (holding duty) * phi, and the report's 0.046 mm needs phi ~ 0.001
  (0.011 gives 0.7 mm in simulation); the printed value is the typo docs/model.md §10
  suspects.
* Anti-windup: the integral is clamped (§6.1: "the integral action is bounded"), per
  controller since the report tuned each separately and states no bound: PID 0.8 of the
  duty range, VSC4 0.1. Plain clamping, not conditional integration: in this model the
  PID's overshoot comes from its integral winding up during the rise, and these bounds
  reproduce Table 6.1's overshoots (PID 0.757 mm, VSC4 0.057 mm, VSC4 + FF 0.130 mm).
* The position filter (§6.1: "a low-pass filter is applied to prevent the controller from
  amplifying sensor noise. The same filter is used in all controllers"): first order. In
  the report's loop (the evaluation harness) 11 Hz, :data:`REPORT_FILTER_CUTOFF_HZ`,
  identified from Table 6.1 (row B9); the default of :class:`Controller` stays 50 Hz
  (:data:`FILTER_CUTOFF_HZ`), the filter the residual agents were trained on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

FILTER_CUTOFF_HZ = 50.0
"""[Hz] = 50: default cut-off of :class:`Controller`'s position filter (a choice: it passes the
0.1-5 Hz of the experiments and attenuates sensor noise). The residual agents' base
controllers use it, as they were trained with it; the report's loop uses
:data:`REPORT_FILTER_CUTOFF_HZ`."""

REPORT_FILTER_CUTOFF_HZ = 11.0
"""f_c [Hz] = 11 (tau = 14 ms): cut-off of the first-order filter on the measured position
that all the report's controllers share (§6.1; the report gives no number), as the
evaluation harness (:func:`sma_gym_agents.evaluation.baseline`) runs them.

Identified from one number of Table 6.1 (row B9): VSC2, whose proportional band is phi =
1 mm wide (§6.3), overshoots 0.381 mm, which a quasi-static wire can only do through lag
in the loop. With the report's loop timing (§3.3-3.4: 1 kHz loop, the duty latched once per
500 Hz PWM period, the position sampled at the period's end; the envs'
``pwm_mode="resolved"``) and the sensor's 100 Hz filter, 11 Hz gave 0.37 mm when it was
identified (0.317 mm on today's model, ``sma-gym evaluate --experiments 6.1``), and with it
the other nine overshoots of Table 6.1 and VSC1's oscillation (rows B5, B6, B25, B29, Q4,
7k; B26 too then, lost since: VSC1 + FF's step now creeps instead of oscillating). Why here and not in the sensor's hardware filter (§3.1, also without a number):
the report filters that one against the MOSFET's switching noise and still samples late in
the period because the noise sits at the start of each pulse (§3.4), which a 14 ms filter
would smear over the whole period; this one has to tame the derivative terms (Kd = 10,
lambda = 12.5 ms) on 1 kHz differences, and §6.1 notes that more damping "leads to
oscillation at steady state". Until issue 11 the harness used 50 Hz (unidentified): VSC2
stopped without overshoot and VSC1 only chattered (0.03 mm)."""


@dataclass(frozen=True)
class ControllerSpec:
    """Gains of one controller configuration (report §6)."""

    name: str
    law: str  # "pid", "switch", "boundary"
    kp: float = 0.0
    ki_per_sample: float = 0.0
    kd: float = 0.0
    phi: float = 0.0
    lam: float = 0.0
    lam_i_per_sample: float = 0.0
    integral_limit: float = 0.0
    """Largest duty the integral term may contribute (anti-windup)."""
    feedforward: bool = False
    k_pos: float = 7.0
    k_vel: float = 20.0

    @property
    def label(self) -> str:
        return self.name + (" + FF" if self.feedforward else "")


PID = ControllerSpec("PID", "pid", kp=1000.0, ki_per_sample=0.8, kd=10.0, integral_limit=0.8)
VSC1 = ControllerSpec("VSC1", "switch")
VSC2 = ControllerSpec("VSC2", "boundary", phi=0.001)
VSC3 = ControllerSpec("VSC3", "boundary", phi=0.0011, lam=0.0125)
VSC4 = ControllerSpec("VSC4", "boundary", phi=0.0011, lam=0.0125, lam_i_per_sample=0.00025, integral_limit=0.1)
BASE_SPECS = (PID, VSC1, VSC2, VSC3, VSC4)


def with_feedforward(spec: ControllerSpec) -> ControllerSpec:
    from dataclasses import replace

    return replace(spec, feedforward=True)


ALL_SPECS = BASE_SPECS + tuple(with_feedforward(s) for s in BASE_SPECS)


def require_filter_cutoff_hz(value: object) -> float:
    """``value`` as the position filter's cut-off [Hz]: a finite number >= 0 (0: no filter),
    or ValueError naming it (NaN, a negative or an infinite cut-off turned the filter off
    without a word)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"filter_cutoff_hz = {value!r}: expected a number of Hz (0: no filter)")
    if not (math.isfinite(value) and value >= 0.0):
        raise ValueError(f"filter_cutoff_hz = {value!r}: expected a finite cut-off >= 0 Hz (0: no filter)")
    return float(value)


def spec_by_label(label: str) -> ControllerSpec:
    for s in ALL_SPECS:
        if s.label.lower().replace(" ", "") == label.lower().replace(" ", ""):
            return s
    raise ValueError(f"controller = {label!r}: expected one of {[s.label for s in ALL_SPECS]}")


class Controller:
    """A controller of ``spec`` for n actuators, stepping every ``dt`` seconds."""

    def __init__(self, spec: ControllerSpec, n: int = 1, dt: float = 1e-3, filter_cutoff_hz: float = FILTER_CUTOFF_HZ):
        if dt <= 0 or not math.isfinite(dt):
            raise ValueError(f"dt = {dt!r}: expected a positive time step in seconds")
        self.spec = spec
        self.n = n
        self.dt = dt
        filter_cutoff_hz = require_filter_cutoff_hz(filter_cutoff_hz)
        self._alpha = 1.0 - math.exp(-2.0 * math.pi * filter_cutoff_hz * dt) if filter_cutoff_hz > 0 else 1.0
        self._filtered = np.zeros(n)
        self._last_error = np.zeros(n)
        self._integral = np.zeros(n)  # running sum of errors per sample [m]
        self._started = np.zeros(n, dtype=bool)

    def reset(self, mask: np.ndarray | None = None) -> None:
        """Forget filter, derivative and integral state (all, or where ``mask``)."""
        m = slice(None) if mask is None else np.asarray(mask, dtype=bool)
        self._filtered[m] = 0.0
        self._last_error[m] = 0.0
        self._integral[m] = 0.0
        self._started[m] = False

    def __call__(
        self, position_m: np.ndarray, reference_m: np.ndarray, reference_rate_m_s: np.ndarray | None = None
    ) -> np.ndarray:
        """Duty (n,) for measured positions and references (shape (n,) or scalars)."""
        x = self._vector(position_m)
        r = self._vector(reference_m)
        rate = np.zeros(self.n) if reference_rate_m_s is None else self._vector(reference_rate_m_s)
        fresh = ~self._started
        self._filtered = np.where(fresh, x, self._filtered + self._alpha * (x - self._filtered))
        e = r - self._filtered
        de = np.where(fresh, 0.0, (e - self._last_error) / self.dt)
        self._last_error = e
        self._started[:] = True
        s = self.spec
        ff = s.k_pos * r + s.k_vel * np.maximum(rate, 0.0) if s.feedforward else 0.0
        if s.law == "pid":
            self._integrate(e, s.integral_limit / s.ki_per_sample)
            u = s.kp * e + s.ki_per_sample * self._integral + s.kd * de + ff
        elif s.law == "switch":
            # Eq. 6.2: DC = 1 if e > 0 else 0, the feedforward added to it (so with it the
            # duty never falls below the feedforward, which is what makes the report's
            # VSC1 + FF cool more slowly than VSC1: -1.382 against -0.898 mm, Table 6.1).
            u = np.where(e > 0.0, 1.0, 0.0) + ff
        else:
            sliding = e + s.lam * de
            if s.lam_i_per_sample > 0.0:
                self._integrate(e, s.integral_limit * s.phi / s.lam_i_per_sample)
                sliding = sliding + s.lam_i_per_sample * self._integral
            u = np.clip(sliding / s.phi, -1.0, 1.0) + ff
        return np.clip(u, 0.0, 1.0)

    def _vector(self, value) -> np.ndarray:
        a = np.asarray(value, dtype=float)
        return a if a.shape == (self.n,) else np.broadcast_to(a, (self.n,))

    def _integrate(self, e: np.ndarray, limit: float) -> None:
        self._integral += e
        np.clip(self._integral, -limit, limit, out=self._integral)

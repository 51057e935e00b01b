"""One PWM swept over n actuators (report §9.1, Table 9.1), in two schemes.

``"fixed_slots"`` (the report's): during one cycle of the cycling frequency the multiplexer
visits every actuator in turn, so actuator j may be switched on only during its slot
[j/n, (j+1)/n) of the cycle and gets at most 1/n duty. In the simulator this is a PWM of
period 1 / cycling frequency whose period starts at phase j/n, with the duty capped at 1/n;
the sensors of actuator j are read through the same multiplexer at the end of its period.

``"shared_budget"``: the driver still conducts through one actuator at a time, but the
cycle is not cut into equal slots: what the hardware limits is the sum of the duties in a
cycle (at most 1). Every actuator's period starts with the cycle (phase 0, duty cap 1), and
:meth:`Multiplexer.layout` scales the duties down proportionally when their sum exceeds
the cycle and lays the pulses end to end (actuator 0 first); the simulator places each
pulse at its start (:meth:`~sma_gym.simulator.Simulator.set_pulse_start`). All sensors are
read at the end of the cycle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sma_gym._validation import require_choice, require_int_range, require_range

SCHEMES = ("fixed_slots", "shared_budget")
"""Multiplexing schemes: the report's fixed 1/n slots, or one duty budget shared by all."""


@dataclass(frozen=True)
class Multiplexer:
    """n actuators on one PWM swept at ``cycling_frequency_hz``."""

    n_actuators: int
    cycling_frequency_hz: float = 2000.0
    """Default 2 kHz: the report's best compromise at 10 V (§9.2)."""
    scheme: str = "fixed_slots"
    """One of :data:`SCHEMES`; default the report's fixed slots."""

    def __post_init__(self) -> None:
        require_int_range("Multiplexer.n_actuators", self.n_actuators, 1, 4096)
        require_range("Multiplexer.cycling_frequency_hz", self.cycling_frequency_hz, 1.0, 100e3, "Hz")
        require_choice("Multiplexer.scheme", self.scheme, SCHEMES)

    @property
    def duty_max(self) -> float:
        """Largest duty of one actuator: 1/n on fixed slots, the whole cycle on a shared budget."""
        return 1.0 / self.n_actuators if self.scheme == "fixed_slots" else 1.0

    def phase(self, index: int) -> float:
        """Start of actuator ``index``'s period as a fraction of the cycle (0 on a shared budget)."""
        return index / self.n_actuators if self.scheme == "fixed_slots" else 0.0

    @property
    def period_s(self) -> float:
        return 1.0 / self.cycling_frequency_hz

    def layout(self, duties: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The pulse train of one cycle: (duty, pulse start), fractions of the cycle, each of the
        shape of ``duties``: (n,) for one bank, (..., n) for a batch of banks (laid out bank by bank).

        Fixed slots: duties clipped to [0, 1/n], every pulse at the start of its own slot
        (pulse start 0 of its phase-shifted period). Shared budget: duties clipped to [0, 1];
        if their sum exceeds 1 every duty is multiplied by 1 / sum (proportional scaling: each
        keeps its share of what was asked), and the pulses follow one another from the
        cycle's start in actuator order, so pulse j starts where pulse j - 1 ends.
        """
        raw = np.asarray(duties, dtype=float)
        if not np.all(np.isfinite(raw)):
            # One NaN would spread through the budget's sum to every pulse of the bank.
            raise ValueError(f"duties = {duties!r}: expected finite duty cycles")
        duty = np.clip(raw, 0.0, self.duty_max)
        if duty.shape[-1:] != (self.n_actuators,):
            raise ValueError(f"duties have shape {duty.shape}: expected (..., {self.n_actuators})")
        if self.scheme == "fixed_slots":
            return duty, np.zeros_like(duty)
        duty = scale_to_budget(duty)
        start = np.cumsum(duty, axis=-1) - duty
        # Rounding of the running sum must not push a pulse past the cycle's end.
        start = np.clip(np.minimum(start, 1.0 - duty), 0.0, np.nextafter(1.0, 0.0))
        return duty, start


def scale_to_budget(duty: np.ndarray, budget: float = 1.0) -> np.ndarray:
    """The shared budget's rule: duties (last axis: the actuators of one bank) kept as they
    are if they sum to at most ``budget``, else each multiplied by ``budget / sum``.

    Proportional scaling keeps every actuator's share of what was asked, so no actuator is
    starved and none is favoured by its index; it needs no state and no priorities. Batches
    (leading axes) are scaled bank by bank.
    """
    d = np.asarray(duty, dtype=float)
    total = d.sum(axis=-1, keepdims=True)
    return d * np.minimum(1.0, budget / np.maximum(total, np.finfo(float).tiny))


def io_counts(n_actuators: int) -> dict[str, int]:
    """Analog inputs and digital outputs with and without multiplexing (Table 9.1).

    With multiplexing one analog input is shared, and the digital outputs are the PWM line
    plus ceil(log2 n) address lines.
    """
    require_int_range("n_actuators", n_actuators, 1, 1 << 20)
    address_lines = math.ceil(math.log2(n_actuators)) if n_actuators > 1 else 0
    return {
        "analog_inputs_without": n_actuators,
        "analog_inputs_with": 1,
        "digital_outputs_without": n_actuators,
        "digital_outputs_with": address_lines + 1,
    }

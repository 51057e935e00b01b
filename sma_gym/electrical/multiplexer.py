"""One PWM swept over n actuators (report §9.1, Table 9.1).

During one cycle of the cycling frequency the multiplexer visits every actuator in turn, so
actuator j may be switched on only during its slot [j/n, (j+1)/n) of the cycle and gets at
most 1/n duty. In the simulator this is a PWM of period 1 / cycling frequency whose period
starts at phase j/n, with the duty capped at 1/n; the sensors of actuator j are read
through the same multiplexer at the end of its period.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from sma_gym._validation import require_int_range, require_range


@dataclass(frozen=True)
class Multiplexer:
    """n actuators on one PWM swept at ``cycling_frequency_hz``."""

    n_actuators: int
    cycling_frequency_hz: float = 2000.0
    """Default 2 kHz: the report's best compromise at 10 V (§9.2)."""

    def __post_init__(self) -> None:
        require_int_range("Multiplexer.n_actuators", self.n_actuators, 1, 4096)
        require_range("Multiplexer.cycling_frequency_hz", self.cycling_frequency_hz, 1.0, 100e3, "Hz")

    @property
    def duty_max(self) -> float:
        return 1.0 / self.n_actuators

    def phase(self, index: int) -> float:
        """Start of actuator ``index``'s slot as a fraction of the cycle."""
        return index / self.n_actuators

    @property
    def period_s(self) -> float:
        return 1.0 / self.cycling_frequency_hz


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

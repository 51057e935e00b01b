"""The multiplexed env's shared-budget scheme (issue 16): the budget rule, the pulse train the
resolved simulation sees, and fixed slots unchanged bit for bit."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import sma_gym  # noqa: F401  (registers the ids)
from sma_gym import ModelConfig, preset
from sma_gym.electrical.multiplexer import Multiplexer
from sma_gym.simulator import Simulator


def make(**kwargs):
    return gym.make("sma_gym:SMAMultiplexed-v0", **kwargs).unwrapped


RECORDED_MODEL = ModelConfig(
    preset("standard").with_changes(
        **{
            "wire.thermal_expansion_austenite_1_k": 8.8e-6,
            "wire.thermal_expansion_martensite_1_k": 8.8e-6,
            "convection.h0_w_m2_k": 80.36,
            "wire.resistivity_austenite_ohm_m": 7.784e-7,
            "wire.transformation_spread_k": 6.0,
        }
    )
)
"""The standard actuator as it was when the golden values below were recorded: one expansion
coefficient for both phases, the 6 K spread of transformation temperatures, and h0 and rho_A
as calibrated for them."""


def test_fixed_slots_are_bit_for_bit_what_they_were_before_the_shared_budget():
    """Golden values recorded with the code before the pulse-start field existed (commit 7f9aa36),
    on the model of that time (still bit for bit: one coefficient for both phases is the old
    thermal strain exactly), which held through commit 0e20474. Re-recorded on 2026-11-28 when
    the integrator changed (the theta-method mechanics and the mid-temperature convection
    coefficient, docs/model.md §8: positions moved by 0.8-0.9 um, temperatures by 0.001 K): they
    now guard the fixed slots against any later change of the pulse placement."""
    env = make(n_actuators=4, cycling_frequency_hz=1000.0, model=RECORDED_MODEL)
    env.reset(seed=7)
    rng = np.random.default_rng(2)
    for _ in range(150):
        env.step(rng.uniform(0.6, 1, 4).astype(np.float32))
    assert [float(x).hex() for x in env.sim.position_m] == [
        "0x1.64e4e07daed95p-9",
        "0x1.617180be97774p-9",
        "0x1.668ea679aacffp-9",
        "0x1.5968e993aea33p-9",
    ]
    assert float(env.sim.temperature_c[2]).hex() == "0x1.58a1b25f9a5f6p+6"
    assert env.scheme == "fixed_slots"


def test_budget_rule_scales_shares_proportionally_and_lays_pulses_end_to_end():
    mux = Multiplexer(4, 2000.0, "shared_budget")
    duty, start = mux.layout(np.array([0.2, 0.1, 0.3, 0.1]))  # sum 0.7: kept as asked
    np.testing.assert_allclose(duty, [0.2, 0.1, 0.3, 0.1])
    np.testing.assert_allclose(start, [0.0, 0.2, 0.3, 0.6])
    duty, start = mux.layout(np.array([1.0, 0.5, 0.5, 0.0]))  # sum 2: each halved
    np.testing.assert_allclose(duty, [0.5, 0.25, 0.25, 0.0])
    np.testing.assert_allclose(start, [0.0, 0.5, 0.75, 1.0 - 1e-16], atol=1e-12)
    assert np.all(start + duty <= 1.0)
    fixed = Multiplexer(4, 2000.0)
    duty, start = fixed.layout(np.array([1.0, 0.1, 0.0, 0.5]))
    np.testing.assert_allclose(duty, [0.25, 0.1, 0.0, 0.25])
    assert not start.any()
    with pytest.raises(ValueError, match="scheme"):
        Multiplexer(4, 2000.0, "round_robin")
    # One NaN spread through the budget's sum to every pulse of the bank, silently.
    for bad in (np.nan, np.inf):
        with pytest.raises(ValueError, match="expected finite duty cycles"):
            mux.layout(np.array([bad, 0.0, 0.0, 0.0]))


def test_the_resolved_simulation_sees_the_shared_budget_pulse_train():
    """Control steps of 1/20 cycle show when each wire conducts: actuator 0 in the first 30 %
    of the cycle, actuator 1 in the next 50 %, nothing in the last 20 %."""
    mux = Multiplexer(2, 2000.0, "shared_budget")
    sim = Simulator(n=2, control_period_s=mux.period_s / 20, pwm_mode="resolved", multiplexer=mux)
    duty, start = mux.layout(np.array([0.3, 0.5]))
    sim.set_pulse_start(start)
    out = sim.run(np.tile(duty, (60, 1)), record=("power_w",))
    on = out["power_w"][20:40] > 0.0  # the second cycle (the first latched at its start too)
    assert on[:, 0].tolist() == [True] * 6 + [False] * 14
    assert on[:, 1].tolist() == [False] * 6 + [True] * 10 + [False] * 4


def test_shared_budget_lets_one_actuator_take_the_whole_cycle():
    env = make(n_actuators=4, scheme="shared_budget")
    assert env.duty_range.high == 1.0
    env.reset(seed=0)
    for _ in range(20):
        _, _, _, _, info = env.step(np.array([1.0, -1.0, -1.0, -1.0], dtype=np.float32))
    np.testing.assert_allclose(info["duty"], [1.0, 0.0, 0.0, 0.0])
    for _ in range(2):
        _, _, _, _, info = env.step(np.ones(4, dtype=np.float32))
    np.testing.assert_allclose(info["duty"], [0.25] * 4)  # shares of 1 each, scaled by 1 / 4
    duty, start = env.pulse_layout(np.array([0.0, 0.0, -1.0, -1.0]))  # shares 0.5, 0.5
    np.testing.assert_allclose(duty, [0.5, 0.5, 0.0, 0.0])
    np.testing.assert_allclose(start, [0.0, 0.5, 1.0, 1.0], atol=1e-12)


def test_one_actuator_on_a_shared_budget_is_one_actuator_on_fixed_slots():
    """n = 1: both schemes give the actuator the whole cycle from its start; bit for bit."""
    positions = []
    for scheme in ("fixed_slots", "shared_budget"):
        env = make(n_actuators=1, scheme=scheme)
        env.reset(seed=1)
        rng = np.random.default_rng(0)
        for _ in range(50):
            env.step(rng.uniform(-1, 1, 1).astype(np.float32))
        positions.append(env.sim.position_m.copy())
    assert positions[0].tolist() == positions[1].tolist()


def test_scheme_is_validated_and_unknown_kwargs_still_raise():
    with pytest.raises(ValueError, match="scheme = 'budget'"):
        make(scheme="budget")
    with pytest.raises(ValueError, match="pwm_mode"):
        make(pwm_mode="averaged")
    with pytest.raises(ValueError, match="pulse start"):
        Simulator(n=2).set_pulse_start(np.array([0.0, 1.0]))

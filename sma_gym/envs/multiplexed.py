"""``SMAMultiplexed-v0``: n actuators on one PWM swept at a cycling frequency (report §9).

Each actuator tracks its own reference. The multiplexer visits the actuators in turn once
per cycle, so actuator j may conduct only in its slot and gets at most 1/n duty; the
physics is PWM-resolved (each pulse in its slot, sensors read at the end of each cycle).

Kwargs: ``n_actuators`` (1-16, default 4), ``cycling_frequency_hz`` (100-4000, default
2000: the report's best compromise at 10 V), and the tracking env's ``model``,
``control_period_s``, ``reference``, ``energy_weight``, ``overheat_limit_c``, noise levels.

Action: ``Box(-1, 1, (n,), float32)``; actuator j's duty is ``(a_j + 1) / 2 / n`` (affine onto
[0, 1/n]); out-of-range values are clipped, NaN or inf raise ``ValueError``.
Observation: the tracking env's features for each actuator, concatenated (n * 10).
Reward: the mean over actuators of the tracking env's reward. ``terminated`` when any wire
exceeds the overheat limit. ``info`` holds the true state of every actuator as arrays (n,).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from sma_gym._validation import require_action, require_int_range, require_range
from sma_gym.core import layout as L
from sma_gym.electrical.multiplexer import Multiplexer
from sma_gym.envs import references as refs
from sma_gym.envs import task
from sma_gym.envs.render import EpisodeHistory, draw, to_rgb
from sma_gym.envs.single import TRACKING, Settings
from sma_gym.simulator import Simulator


class SMAMultiplexedEnv(gym.Env):
    """n actuators sharing one PWM (see the module docstring)."""

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 100}

    def __init__(
        self,
        n_actuators: int = 4,
        cycling_frequency_hz: float = 2000.0,
        render_mode: str | None = None,
        **kwargs: Any,
    ):
        self.n = require_int_range("n_actuators", n_actuators, 1, 16)
        f = require_range("cycling_frequency_hz", cycling_frequency_hz, 100.0, 4000.0, "Hz")
        if "pwm_mode" in kwargs:
            raise ValueError("pwm_mode: the multiplexed env is always PWM-resolved")
        self.settings = Settings.from_kwargs(TRACKING, **kwargs)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode = {render_mode!r}: expected one of {self.metadata['render_modes']} or None")
        self.render_mode = render_mode
        self.metadata = dict(self.metadata, render_fps=max(1, round(1.0 / self.settings.control_period_s)))
        self.multiplexer = Multiplexer(self.n, f)
        self.sim = Simulator(
            self.settings.model,
            n=self.n,
            control_period_s=self.settings.control_period_s,
            pwm_mode="resolved",
            multiplexer=self.multiplexer,
        )
        self.task = task.TaskState(self.n)
        low, high = task.bounds(task.TRACKING)
        self.features_per_actuator = len(low)
        self.observation_space = spaces.Box(np.tile(low, self.n), np.tile(high, self.n), dtype=np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(self.n,), dtype=np.float32)
        self.feature_names = task.FEATURES[task.TRACKING]
        self.duty_range = (0.0, 1.0 / self.n)
        self.control_period_s = self.settings.control_period_s
        self.position_scale_m = task.stroke_of(self.sim.params[0])
        p0 = self.sim.params[0]
        self.resistance_scale_ohm = float(p0[L.P_RHO_M] * p0[L.P_LENGTH] / p0[L.P_AREA])
        self._columns = np.arange(self.n, dtype=np.int64)
        self._obs = np.zeros((self.n, self.features_per_actuator), dtype=np.float32)
        self._reward = np.zeros(self.n)
        self._term = np.zeros(self.n, dtype=np.bool_)
        self._ref = np.zeros(self.n)
        self._duty = np.zeros((1, self.n))
        self._history = EpisodeHistory()
        self._figure = None

    def duty_for(self, actions: np.ndarray) -> np.ndarray:
        return (np.clip(actions, -1.0, 1.0) + 1.0) * (0.5 / self.n)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self.sim.rng = self.np_random
        options = {} if options is None else options
        unknown = set(options) - {"reference", "references"}
        if unknown:
            raise ValueError(f"reset options {sorted(unknown)}: expected 'reference' or 'references' (one per actuator)")
        specs = options.get("references")
        if specs is None:
            specs = [options.get("reference")] * self.n
        if len(specs) != self.n:
            raise ValueError(f"options['references'] has {len(specs)} entries: expected {self.n}")
        described = []
        for j, spec in enumerate(specs):
            ref = refs.resolve(spec, self.np_random, task.stroke_of(self.sim.params[j]), self.settings.reference)
            self.task.set_reference(j, ref)
            described.append(ref.describe())
        self.sim.reset()
        for j in range(self.n):
            self.task.reset_column(j, self.sim.params[j])
        self._outputs()
        self._history.clear()
        if self.render_mode is not None:
            self._record()
        return self._obs.reshape(-1).copy(), {**self._info(), "references": described}

    def step(self, action):
        a = require_action(action, self.n)
        duty = self.duty_for(a)
        self._duty[0] = duty
        self.sim.step_unchecked(self._duty)
        self.task.last_duty[:] = duty
        self._outputs()
        if self.render_mode is not None:
            self._record()
            if self.render_mode == "human":
                self.render()
        return self._obs.reshape(-1).copy(), float(self._reward.mean()), bool(self._term.any()), False, self._info()

    def _outputs(self) -> None:
        t = self.task
        s = self.settings
        task.task_outputs(
            self.sim.state, self.sim.params, task.TRACKING, t.kind, t.params, t.wp_t, t.wp_x, t.held, t.last_duty,
            s.energy_weight, s.overheat_limit_c, self._obs, self._reward, self._term, self._ref, self._columns,
        )

    def _info(self) -> dict[str, Any]:
        st = self.sim.state
        return {
            "position_m": st[:, L.S_X].copy(),
            "position_measured_m": st[:, L.S_POS_MEAS].copy(),
            "reference_m": self._ref.copy(),
            "temperature_c": st[:, L.S_T].copy(),
            "martensite_fraction": st[:, L.S_XI].copy(),
            "stress_pa": st[:, L.S_SIGMA].copy(),
            "power_w": st[:, L.S_POWER].copy(),
            "electrical_energy_j": st[:, L.S_E_ELECTRIC].copy(),
            "spring_force_n": st[:, L.S_FORCE].copy(),
            "duty": st[:, L.S_DUTY_CMD].copy(),
            "resistance_valid": ~np.isnan(st[:, L.S_R_MEAS]),
            "time_s": float(st[0, L.S_TIME]),
        }

    def _record(self) -> None:
        st = self.sim.state
        self._history.add(
            t=st[0, L.S_TIME],
            position=st[:, L.S_X].copy(),
            reference=self._ref.copy(),
            duty=st[:, L.S_DUTY_CMD].copy(),
            resistance=self.task.held[:, 0].copy(),
            temperature=st[:, L.S_T].copy(),
        )

    def render(self):
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' or 'human' to make()")
            return None
        title = f"{self.n} multiplexed actuators, {self.multiplexer.cycling_frequency_hz:g} Hz"
        labels = [str(j) for j in range(self.n)]
        if self.render_mode == "rgb_array":
            import matplotlib

            matplotlib.use("Agg")
            self._figure = draw(self._history, title, labels, figure=self._figure)
            return to_rgb(self._figure)
        import matplotlib.pyplot as plt

        t = self.sim.state[0, L.S_TIME]
        if self._figure is not None and t - getattr(self, "_last_human_t", -1.0) < 0.1:
            return None
        self._last_human_t = t
        self._figure = draw(self._history, title, labels, figure=self._figure)
        plt.pause(0.001)
        return None

    def close(self) -> None:
        if self._figure is not None:
            import matplotlib.pyplot as plt

            plt.close(self._figure)
            self._figure = None

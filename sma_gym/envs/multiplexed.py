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
exceeds the overheat limit.

``info`` (the same keys at reset and at every step): the single env's keys (see
:mod:`sma_gym.envs.single`), per actuator as float (bool for ``resistance_valid``, int for
``reference_kind``) arrays of fixed shape (n,), and ``time_s`` as a float. For a JSON log,
``{k: np.asarray(v).tolist() for k, v in info.items()}``. Each actuator's full reference
description is ``env.unwrapped.reference_description()`` (a list, one dict per actuator).

Version history: 0.2: the reset ``info["references"]`` list of dicts is gone (use
``reference_description()``); ``reference_kind`` added; unknown kwargs raise
``ValueError``; ``env.spec.id`` carries the ``sma_gym:`` prefix; ``render()`` no longer
switches matplotlib's global backend. 0.1: first release.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from sma_gym._validation import require_action, require_int_range, require_range
from sma_gym.core import layout as L
from sma_gym.electrical.multiplexer import Multiplexer
from sma_gym.envs import ImportableSpec, task
from sma_gym.envs import references as refs
from sma_gym.envs.render import Renderer
from sma_gym.envs.single import STATE_INFO, TRACKING, Settings
from sma_gym.simulator import Simulator


class SMAMultiplexedEnv(ImportableSpec, gym.Env):
    """n actuators sharing one PWM.

    Spaces, reward, episode end, ``info``, kwargs and version history: see the module
    docstring. Besides the Gymnasium API: :meth:`reference_description`, ``multiplexer``,
    ``position_scale_m``, ``resistance_scale_ohm``, ``duty_range``, ``control_period_s``.
    """

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
        self._renderer = Renderer(render_mode, self.metadata["render_modes"])
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
        for j, spec in enumerate(specs):
            ref = refs.resolve(spec, self.np_random, task.stroke_of(self.sim.params[j]), self.settings.reference)
            self.task.set_reference(j, ref)
        self.sim.reset()
        for j in range(self.n):
            self.task.reset_column(j, self.sim.params[j])
        self._outputs()
        self._renderer.reset()
        self._record()
        return self._obs.reshape(-1).copy(), self._info()

    def reference_description(self) -> list[dict[str, Any]]:
        """Each actuator's reference (kind, name, parameters; keys depend on the kind)."""
        return [ref.describe() for ref in self.task.references]

    def step(self, action):
        a = require_action(action, self.n)
        duty = self.duty_for(a)
        self._duty[0] = duty
        self.sim.step_unchecked(self._duty)
        self.task.last_duty[:] = duty
        self._outputs()
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
        # Per-actuator entries are float arrays of fixed shape (n,) so vector envs and batched
        # clients can stack them; time is one Python float.
        info: dict[str, Any] = {key: st[:, row].copy() for key, row in STATE_INFO}
        info["reference_m"] = self._ref.copy()
        info["reference_kind"] = self.task.kind.copy()
        info["resistance_valid"] = ~np.isnan(st[:, L.S_R_MEAS])
        info["time_s"] = float(st[0, L.S_TIME])
        return info

    def _record(self) -> None:
        if self.render_mode is None:
            return  # nothing is drawn: skip building the sample (it is on every step's path)
        st = self.sim.state
        self._renderer.record(
            t=st[0, L.S_TIME],
            position=st[:, L.S_X],
            reference=self._ref,
            duty=st[:, L.S_DUTY_CMD],
            resistance=self.task.held[:, 0],
            temperature=st[:, L.S_T],
        )

    def render(self) -> np.ndarray | None:
        """``rgb_array``: the episode so far as a (640, 640, 3) uint8 frame; ``human``: show it."""
        title = f"{self.n} multiplexed actuators, {self.multiplexer.cycling_frequency_hz:g} Hz"
        return self._renderer.render(title, [str(j) for j in range(self.n)])

    def close(self) -> None:
        self._renderer.close()

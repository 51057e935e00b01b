"""``SMAMultiplexed-v0``: n actuators on one PWM swept at a cycling frequency (report §9).

The contract (spaces, reward, episode end, ``info``, arguments, version history) is the
docstring of :class:`SMAMultiplexedEnv`.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from sma_gym._validation import require_action, require_choice, require_int_range, require_range
from sma_gym.electrical.multiplexer import SCHEMES, Multiplexer
from sma_gym.envs import ImportableSpec, docs, task
from sma_gym.envs import references as refs
from sma_gym.envs.render import EpisodeRendering
from sma_gym.envs.single import TRACKING, Settings, SMAEnv, keyword_settings, spell_out_settings, with_settings
from sma_gym.simulator import Simulator

DEFAULT_N_ACTUATORS = 4
DEFAULT_CYCLING_FREQUENCY_HZ = 2000.0
"""The report's best compromise at 10 V (§9)."""
DEFAULT_SCHEME = "fixed_slots"
"""The report's scheme (§9.1): each actuator owns a 1/n slot of the cycle."""


_SETTINGS = keyword_settings(SMAEnv.__init__, exclude=("pwm_mode",))
"""The single envs' settings (``model``, ``reference``, ...) but ``pwm_mode`` (always resolved
here): taken as ``**settings`` and shown in the signature, so one added there reaches this env."""


class SMAMultiplexedEnv(EpisodeRendering, ImportableSpec, gym.Env):
    __doc__ = docs.env_doc(
        "n SMA actuators sharing one PWM (``SMAMultiplexed-v0``).",
        Description="""
            n actuators on one PWM swept at a cycling frequency (report §9), each tracking
            its own reference, in one of two schemes (`scheme`). `"fixed_slots"` (the
            report's): the multiplexer visits the actuators in turn once per cycle, so
            actuator j may conduct only in its slot [j/n, (j+1)/n) and gets at most 1/n
            duty. `"shared_budget"`: the driver still conducts through one actuator at a
            time, but only the sum of the duties in a cycle is limited (to 1). The action
            gives each actuator a share of the cycle in [0, 1]; **if the shares sum to more
            than 1, each is multiplied by 1 / sum** (proportional scaling), and the pulses
            are laid end to end from the cycle's start in actuator order (pulse j starts
            where pulse j - 1 ends). The physics is PWM-resolved (each pulse where the
            driver puts it, sensors read at the end of each actuator's period), so the
            simulation sees the real pulse train. Besides the Gymnasium API:
            `reference_description()`, `multiplexer`, `scheme`, `position_scale_m`,
            `resistance_scale_ohm`, `duty_range`, `control_period_s`, `duty_for()`,
            `action_for()`, `pulse_layout()`, `actuator_rewards`.
            """,
        Action_Space=docs.join(
            "`Box(-1, 1, (n,), float32)`: entry j is actuator j's action; duty range [0, 1/n] on "
            "fixed slots, [0, 1] (the share asked, scaled down if the shares sum past 1) on a shared budget.",
            docs.ACTION,
        ),
        Observation_Space=docs.join(
            "`Box(low, high, (n * 10,), float32)`: the tracking env's features of each actuator, "
            "concatenated (actuator 0 first):",
            task.feature_table(task.OBS_POSITION),
        ),
        Rewards=docs.join(docs.REWARD, "The env's reward is the mean over the actuators."),
        Starting_State=docs.join(
            docs.START,
            '`reset(options={"references": [...]})` gives each actuator its own (one entry per actuator).',
        ),
        Episode_End=docs.EPISODE_END,
        Info=docs.join(
            "The single envs' keys, the same at reset and at every step, each an array of fixed "
            "shape (n,) (float; bool for `resistance_valid`, int for `reference_kind`), except "
            "`time_s`, one float. For a JSON log, `{k: np.asarray(v).tolist() for k, v in info.items()}`.",
            docs.INFO_KEYS,
            "Each actuator's reference in full: `env.unwrapped.reference_description()` (a list).",
        ),
        Arguments=docs.arguments(
            docs.RENDER_MODE,
            """
            - `n_actuators`: 1 to 16 (default 4).
            - `cycling_frequency_hz`: 100 to 4000 Hz (default 2000: the report's best
              compromise at 10 V).
            - `scheme`: `"fixed_slots"` (default, the report's) or `"shared_budget"`.
            """,
            docs.ARGUMENTS,
            "- No `pwm_mode`: the physics is always PWM-resolved.",
        ),
        Version_History=docs.join(
            """
            * 0.3: `scheme` added (`"shared_budget"`: one duty budget for the bank, shares
              scaled by 1 / sum when they sum past 1, pulses laid end to end); the default
              `"fixed_slots"` gives bit for bit the results of 0.2.
            * 0.2: the reset `info["references"]` list of dicts is gone (use
              `reference_description()`); `reference_kind` added; unknown kwargs raise
              `ValueError`; `env.spec.id` carries the `sma_gym:` prefix; `render()` no
              longer switches matplotlib's global backend; the contract is on the class and
              the keyword arguments in its signature.
            * 0.1: first release.
            """
        ),
    )

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 100}

    def __init__(
        self,
        n_actuators: int = DEFAULT_N_ACTUATORS,
        cycling_frequency_hz: float = DEFAULT_CYCLING_FREQUENCY_HZ,
        render_mode: str | None = None,
        *,
        scheme: str = DEFAULT_SCHEME,
        **settings: Any,
    ):
        arguments = with_settings(locals(), _SETTINGS, settings)
        self.n = require_int_range("n_actuators", n_actuators, 1, 16)
        f = require_range("cycling_frequency_hz", cycling_frequency_hz, 100.0, 4000.0, "Hz")
        self.scheme = require_choice("scheme", scheme, SCHEMES)
        # PWM-resolved always: each actuator conducts only where the driver puts its pulse.
        self.settings = Settings.from_arguments(TRACKING, arguments, pwm_mode="resolved")
        self._init_rendering(render_mode, self.settings.control_period_s)
        self.multiplexer = Multiplexer(self.n, f, self.scheme)
        self.sim = Simulator(
            self.settings.model,
            n=self.n,
            control_period_s=self.settings.control_period_s,
            pwm_mode="resolved",
            multiplexer=self.multiplexer,
        )
        self.task = self.settings.task_state(self.n, task.OBS_POSITION)
        low, high = task.bounds(task.OBS_POSITION)
        self.features_per_actuator = len(low)
        self.observation_space = spaces.Box(np.tile(low, self.n), np.tile(high, self.n), dtype=np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(self.n,), dtype=np.float32)
        self.feature_names = task.FEATURES[task.OBS_POSITION]
        self.duty_range = task.DutyRange(0.0, self.multiplexer.duty_max)
        self.control_period_s = self.settings.control_period_s
        self.position_scale_m = float(self.sim.usable_stroke_m[0])
        self.resistance_scale_ohm = float(self.sim.cold_resistance_ohm[0])
        self._actuators = np.arange(self.n, dtype=np.int64)
        self._obs = np.zeros((self.n, self.features_per_actuator), dtype=np.float32)
        self._reward = np.zeros(self.n)
        self._step_reward = np.zeros(self.n)
        self._term = np.zeros(self.n, dtype=np.bool_)
        self._ref = np.zeros(self.n)
        self._duty = np.zeros((1, self.n))
        self._evaluate = self.task.bind(self.sim, self._actuators, self._obs, self._reward, self._term, self._ref)

    def duty_for(self, actions: np.ndarray) -> np.ndarray:
        """Each actuator's duty for (clipped) actions in [-1, 1] (:meth:`DutyRange.duty_for`)."""
        return self.duty_range.duty_for(actions)

    def action_for(self, duties: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`duty_for` (for controllers that compute duties)."""
        return self.duty_range.action_for(duties)

    def pulse_layout(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(duty, pulse start) of each actuator for ``actions``, fractions of the cycle.

        Fixed slots: the duty, each pulse at the start of its slot. Shared budget: the shares
        scaled by 1 / sum if they sum past 1, laid end to end
        (:meth:`~sma_gym.electrical.multiplexer.Multiplexer.layout`).
        """
        return self.multiplexer.layout(self.duty_for(actions))

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self.sim.rng = self.np_random
        options = {} if options is None else options
        unknown = set(options) - {"reference", "references"}
        if unknown:
            raise ValueError(
                f"reset options {sorted(unknown)}: expected 'reference' or 'references' (one per actuator)"
            )
        specs = options.get("references")
        if specs is None:
            specs = [options.get("reference")] * self.n
        if len(specs) != self.n:
            raise ValueError(f"options['references'] has {len(specs)} entries: expected {self.n}")
        strokes = self.sim.usable_stroke_m
        for j, spec in enumerate(specs):
            ref = refs.resolve(spec, self.np_random, float(strokes[j]), self.settings.reference)
            self.task.set_reference(j, ref)
        self.sim.reset()
        for j in range(self.n):
            self.task.reset_actuator(j, self.sim)
        self._evaluate()
        self._start_rendering()
        return self._obs.reshape(-1).copy(), self._info()

    @property
    def actuator_rewards(self) -> np.ndarray:
        """Each actuator's reward in the last :meth:`step` (shape (n,); the env's reward is
        their mean). Kept through :meth:`reset`, so a vector env that resets a finished
        episode at once still reads the rewards of the step that finished it."""
        return self._step_reward.copy()

    def reference_description(self) -> list[dict[str, Any]]:
        """Each actuator's reference (kind, name, parameters; keys depend on the kind)."""
        return [ref.describe() for ref in self.task.references]

    def step(self, action):
        a = require_action(action, self.n)
        duty = self.duty_for(a)
        if self.scheme == "shared_budget":
            duty, start = self.multiplexer.layout(duty)
            self.sim.set_pulse_start(start)
        self._duty[0] = duty
        self.sim.step_unchecked(self._duty)
        self.task.last_duty[:] = duty
        self._evaluate()
        self._step_reward[:] = self._reward
        if self.render_mode is not None:
            self._rendered_step()
        return self._obs.reshape(-1).copy(), float(self._reward.mean()), bool(self._term.any()), False, self._info()

    def _info(self) -> dict[str, Any]:
        info = self.task.info(self.sim, self._ref)
        info["time_s"] = float(self.sim.time_s[0])  # one clock for all actuators
        return info

    def _render_title(self) -> str:
        return f"{self.n} multiplexed actuators, {self.multiplexer.cycling_frequency_hz:g} Hz"

    def _render_labels(self) -> list[str] | None:
        return [str(j) for j in range(self.n)]


spell_out_settings(SMAMultiplexedEnv.__init__, _SETTINGS)

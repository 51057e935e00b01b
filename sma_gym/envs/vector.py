"""Native vector env: thousands of single-actuator envs as columns of one simulator.

``gymnasium.make_vec("sma_gym:SMATracking-v0", num_envs=4096,
vectorization_mode="vector_entry_point")`` builds :class:`SMAVectorEnv`: one batched
:class:`~sma_gym.Simulator` step and one compiled task evaluation per vector step, instead
of N Python env steps.

Semantics match N single envs exactly (tested): sub-env i is seeded with ``seed + i`` (as
Gymnasium's ``SyncVectorEnv`` does) and draws its references, conditions and sensor noise
from its own generator in the same order as a single env. Episodes are truncated after
``max_episode_steps`` (from the registration). Autoreset mode: ``SAME_STEP``: when a
sub-env ends, ``step`` returns the first observation of its next episode, and the last
observation and info of the ended one are in ``info["final_obs"]`` / ``info["final_info"]``
(with the masks ``info["_final_obs"]``, ``info["_final_info"]``), like
``SyncVectorEnv(autoreset_mode=SAME_STEP)``. Stable-baselines3 can use it through
:class:`sma_gym.envs.sb3.SB3VecEnv`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from sma_gym._validation import require_int_range
from sma_gym.core import layout as L
from sma_gym.envs import task
from sma_gym.envs.single import ROBUST, SELF_SENSING, TRACKING, Settings, Variant, reset_column
from sma_gym.simulator import Simulator

_INFO_ROWS = (
    ("position_m", L.S_X),
    ("position_measured_m", L.S_POS_MEAS),
    ("temperature_c", L.S_T),
    ("martensite_fraction", L.S_XI),
    ("stress_pa", L.S_SIGMA),
    ("power_w", L.S_POWER),
    ("electrical_energy_j", L.S_E_ELECTRIC),
    ("spring_force_n", L.S_FORCE),
    ("duty", L.S_DUTY_CMD),
    ("time_s", L.S_TIME),
)


class SMAVectorEnv(VectorEnv):
    """``num_envs`` single-actuator envs of one variant, simulated as one batch."""

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.SAME_STEP}

    FIXED_AT_MAKE = (
        "control_period_s", "settings", "sim", "task", "variant", "num_envs", "feature_names", "duty_range",
        "observation_space", "action_space", "single_observation_space", "single_action_space",
    )
    """Attributes the simulator or the spaces were built from: changing one afterwards would
    leave the simulator stepping with the old value, so adapters refuse to set them."""

    def __init__(self, num_envs: int, variant: Variant = TRACKING, max_episode_steps: int | None = None, **kwargs: Any):
        self.num_envs = require_int_range("num_envs", num_envs, 1, 1 << 20)
        if max_episode_steps is not None:
            max_episode_steps = require_int_range("max_episode_steps", max_episode_steps, 1, 1 << 40)
        self.max_episode_steps = max_episode_steps
        self.variant = variant
        self.settings = Settings.from_kwargs(variant, **kwargs)
        self.sim = Simulator(
            [self.settings.model] * self.num_envs,
            control_period_s=self.settings.control_period_s,
            pwm_mode=self.settings.pwm_mode,
        )
        self.task = task.TaskState(self.num_envs)
        low, high = task.bounds(variant.observation)
        self.single_observation_space = spaces.Box(low, high, dtype=np.float32)
        self.single_action_space = spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.feature_names = task.FEATURES[variant.observation]
        self.duty_range = variant.duty_range
        self.control_period_s = self.settings.control_period_s
        lo, hi = variant.duty_range
        self._duty_lo = lo
        self._duty_half_range = 0.5 * (hi - lo)
        n = self.num_envs
        self._columns = np.arange(n, dtype=np.int64)
        self._obs = np.zeros((n, len(self.feature_names)), dtype=np.float32)
        self._reward = np.zeros(n)
        self._term = np.zeros(n, dtype=np.bool_)
        self._ref = np.zeros(n)
        self._steps = np.zeros(n, dtype=np.int64)
        self._duty = np.zeros((1, n))
        self._rngs: list[np.random.Generator | None] = [None] * n
        self._conditions: list[dict | None] = [None] * n
        self._all_true = np.ones(n, dtype=bool)

    @property
    def position_scale_m(self) -> np.ndarray:
        """Stroke each sub-env's position features are divided by [m], shape (num_envs,)."""
        p = self.sim.params
        eot = p[:, L.P_EOT]
        return np.where(np.isfinite(eot), eot, p[:, L.P_EPS0] * p[:, L.P_LENGTH])

    @property
    def resistance_scale_ohm(self) -> np.ndarray:
        """Cold resistance each sub-env's resistance feature is relative to [ohm]."""
        p = self.sim.params
        return p[:, L.P_RHO_M] * p[:, L.P_LENGTH] / p[:, L.P_AREA]

    def reset(self, *, seed: int | list[int] | None = None, options: dict | None = None):
        if seed is None:
            seeds: list[int | None] = [None] * self.num_envs
        elif isinstance(seed, (int, np.integer)):
            seeds = [int(seed) + i for i in range(self.num_envs)]
        else:
            seeds = list(seed)
            if len(seeds) != self.num_envs:
                raise ValueError(f"seed has {len(seeds)} entries: expected {self.num_envs} (one per env)")
        if seed is not None:
            self._np_random, self._np_random_seed = seeding.np_random(seeds[0])
        infos: list[dict] = []
        for i in range(self.num_envs):
            if seeds[i] is not None or self._rngs[i] is None:
                self._rngs[i], _ = seeding.np_random(seeds[i])
            infos.append(reset_column(self.sim, self.task, i, self._rngs[i], self.settings, options))
            self._conditions[i] = infos[-1].get("condition")
        self._steps[:] = 0
        self._outputs(self._columns)
        info = self._info()
        info["reference"] = np.array([x["reference"] for x in infos], dtype=object)
        info["_reference"] = self._all_true.copy()
        return self._obs.copy(), info

    def reset_envs(self, indices: Sequence[int], options: dict | None = None) -> list[tuple[np.ndarray, dict[str, Any]]]:
        """Reset only the sub-envs ``indices`` (each with its own generator); the others go on.

        Returns ``(observation, info)`` per index, in the order given.
        """
        columns = np.asarray(sorted(set(int(i) for i in indices)), dtype=np.int64)
        described = {}
        for i in columns:
            if self._rngs[i] is None:
                self._rngs[i], _ = seeding.np_random(None)
            info = reset_column(self.sim, self.task, int(i), self._rngs[i], self.settings, options)
            self._conditions[i] = info.get("condition")
            described[int(i)] = info["reference"]
            self._steps[i] = 0
        if columns.size:
            self._outputs(columns)
        return [(self._obs[i].copy(), {"reference": described[int(i)]}) for i in indices]

    def step(self, actions):
        a = np.asarray(actions, dtype=np.float64).reshape(self.num_envs, -1)
        if a.shape[1] != 1:
            raise ValueError(f"actions have shape {np.shape(actions)}: expected ({self.num_envs}, 1)")
        if not np.isfinite(a).all():
            bad = int(np.flatnonzero(~np.isfinite(a[:, 0]))[0])
            raise ValueError(f"actions[{bad}] = {a[bad, 0]!r}: expected finite values in [-1, 1]")
        duty = self._duty_lo + (np.clip(a[:, 0], -1.0, 1.0) + 1.0) * self._duty_half_range
        self._duty[0] = duty
        noise = None
        if self.sim.has_noise:
            noise = np.empty((1, 4, self.num_envs))
            for i, rng in enumerate(self._rngs):
                noise[0, :, i] = rng.standard_normal((1, 4, 1))[0, :, 0]
        self.sim.step_unchecked(self._duty, noise)
        self.task.last_duty[:] = duty
        self._outputs(self._columns)
        self._steps += 1
        terminated = self._term.copy()
        if self.max_episode_steps is not None:
            truncated = (self._steps >= self.max_episode_steps) & ~terminated
        else:
            truncated = np.zeros(self.num_envs, dtype=bool)
        reward = self._reward.copy()
        info = self._info()
        done = terminated | truncated
        if done.any():
            ended = np.flatnonzero(done)
            final_obs = np.full(self.num_envs, None, dtype=object)
            for i in ended:
                final_obs[i] = self._obs[i].copy()
            final_info = {k: v.copy() for k, v in info.items()}
            final_info.update({f"_{k}": done.copy() for k in info if not k.startswith("_")})
            for i in ended:
                self._conditions[i] = reset_column(self.sim, self.task, i, self._rngs[i], self.settings, None).get("condition")
                self._steps[i] = 0
            self._outputs(ended.astype(np.int64))
            info = self._info()
            info["final_obs"] = final_obs
            info["_final_obs"] = done.copy()
            info["final_info"] = final_info
            info["_final_info"] = done.copy()
        return self._obs.copy(), reward, terminated, truncated, info

    def _outputs(self, columns: np.ndarray) -> None:
        t = self.task
        s = self.settings
        if len(columns) == self.num_envs:
            obs, rew, term, ref = self._obs, self._reward, self._term, self._ref
        else:
            k = len(columns)
            obs = np.zeros((k, self._obs.shape[1]), dtype=np.float32)
            rew, term, ref = np.zeros(k), np.zeros(k, dtype=np.bool_), np.zeros(k)
        task.task_outputs(
            self.sim.state, self.sim.params, self.variant.observation, t.kind, t.params, t.wp_t, t.wp_x, t.held,
            t.last_duty, s.energy_weight, s.overheat_limit_c, obs, rew, term, ref, columns,
        )
        if len(columns) != self.num_envs:
            self._obs[columns] = obs
            self._ref[columns] = ref
            # A fresh episode is neither rewarded nor terminated yet; keep the step's values.

    def _info(self) -> dict[str, Any]:
        st = self.sim.state
        info: dict[str, Any] = {name: st[:, row].copy() for name, row in _INFO_ROWS}
        info["reference_m"] = self._ref.copy()
        info["resistance_valid"] = ~np.isnan(st[:, L.S_R_MEAS])
        if self.variant.randomised:
            info["condition"] = np.array(self._conditions, dtype=object)
        for key in list(info):
            info["_" + key] = self._all_true
        return info

    def close_extras(self, **kwargs: Any) -> None:
        pass


def tracking(num_envs: int, **kwargs: Any) -> SMAVectorEnv:
    """Vector entry point of ``SMATracking-v0``."""
    return SMAVectorEnv(num_envs, TRACKING, **kwargs)


def self_sensing(num_envs: int, **kwargs: Any) -> SMAVectorEnv:
    """Vector entry point of ``SMASelfSensing-v0``."""
    return SMAVectorEnv(num_envs, SELF_SENSING, **kwargs)


def robust(num_envs: int, **kwargs: Any) -> SMAVectorEnv:
    """Vector entry point of ``SMARobust-v0``."""
    return SMAVectorEnv(num_envs, ROBUST, **kwargs)

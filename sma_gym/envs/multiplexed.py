"""``SMAMultiplexed-v0``: n actuators on one PWM swept at a cycling frequency (report §9).

The contract (spaces, reward, episode end, ``info``, arguments, version history) is the
docstring of :class:`SMAMultiplexedEnv`.
"""

from __future__ import annotations

import inspect
from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from sma_gym._validation import (
    require_action,
    require_actions,
    require_choice,
    require_int_range,
    require_options,
    require_range,
)
from sma_gym.electrical.multiplexer import SCHEMES, Multiplexer
from sma_gym.envs import ImportableSpec, docs, task
from sma_gym.envs import references as refs
from sma_gym.envs.render import EpisodeRendering
from sma_gym.envs.single import (
    TRACKING,
    MadeWith,
    Settings,
    SMAEnv,
    keyword_settings,
    reject_unknown,
    spell_out_settings,
    with_settings,
)
from sma_gym.envs.task import UnstartedEnvs
from sma_gym.envs.vector import BUILT_FROM, EpisodeLimit, SubEnvAccess, reset_arguments
from sma_gym.simulator import Simulator

DEFAULT_N_ACTUATORS = 4
DEFAULT_CYCLING_FREQUENCY_HZ = 2000.0
"""The report's best compromise at 10 V (§9)."""
DEFAULT_SCHEME = "fixed_slots"
"""The report's scheme (§9.1): each actuator owns a 1/n slot of the cycle."""


_SETTINGS = keyword_settings(SMAEnv.__init__, exclude=("pwm_mode",))
"""The single envs' settings (``model``, ``reference``, ...) but ``pwm_mode`` (always resolved
here): taken as ``**settings`` and shown in the signature, so one added there reaches this env."""


def reference_specs(options: dict[str, Any], n: int, also: tuple[str, ...] = ()) -> list[Any]:
    """One reference spec per actuator from a bank's reset options: ``references`` (a list
    or tuple of n), or ``reference`` for all of them, or neither (drawn); ``also``: the
    other keys the caller takes (named in the error for an unknown key)."""
    allowed = ("reference", "references", *also)
    unknown = set(options) - set(allowed)
    if unknown:
        raise ValueError(
            f"reset options {sorted(unknown)}: expected {', '.join(map(repr, allowed))} "
            "('references': one per actuator)"
        )
    specs = options.get("references")
    if specs is None:
        return [options.get("reference")] * n
    if "reference" in options:
        raise ValueError("reset options: both 'reference' and 'references' given; expected one of them")
    if not isinstance(specs, (list, tuple)):
        raise ValueError(f"options['references'] = {specs!r}: expected a list of {n} references (one per actuator)")
    if len(specs) != n:
        raise ValueError(f"options['references'] has {len(specs)} entries: expected {n}")
    return list(specs)


class SMAMultiplexedEnv(MadeWith, EpisodeRendering, ImportableSpec, gym.Env):
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
            docs.MODEL_CHANGE,
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
            """,
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
        self.position_scale_m = float(self.sim.usable_stroke_m[0])
        self.resistance_scale_ohm = float(self.sim.cold_resistance_ohm[0])
        self._actuators = np.arange(self.n, dtype=np.int64)
        self._obs = np.zeros((self.n, self.features_per_actuator), dtype=np.float32)
        self._reward = np.zeros(self.n)
        self._step_reward = np.zeros(self.n)
        self._term = np.zeros(self.n, dtype=np.bool_)
        self._ref = np.zeros(self.n)
        self._duty = np.zeros((1, self.n))
        self._unstarted = UnstartedEnvs(1, vector=False)
        self._warned_after_end = False
        self._bind_task()

    def _bind_task(self) -> None:
        """The step's outputs, bound once (again when ``energy_weight`` is set)."""
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
        kept = (self._np_random, self._np_random_seed, self.sim.rng)
        super().reset(seed=seed)
        self.sim.rng = self.np_random
        # Every reference drawn before any is set: one refused leaves the running episode as
        # it was, its generator and seed too.
        before = self.np_random.bit_generator.state
        try:
            specs = reference_specs(require_options(options), self.n)
            strokes = self.sim.usable_stroke_m
            drawn = [
                refs.resolve(spec, self.np_random, float(strokes[j]), self.settings.reference)
                for j, spec in enumerate(specs)
            ]
        except Exception:
            self.np_random.bit_generator.state = before
            self._np_random, self._np_random_seed, self.sim.rng = kept
            raise
        for j, ref in enumerate(drawn):
            self.task.set_reference(j, ref)
        self.sim.reset()
        for j in range(self.n):
            self.task.reset_actuator(j, self.sim)
        self._evaluate()
        self._warned_after_end = False
        self._unstarted.started()
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
        return self.task.describe_references()

    def step(self, action):
        self._unstarted.require_none()
        if self._term.any() and not self._warned_after_end:
            task.warn_step_after_termination()  # once per episode
            self._warned_after_end = True
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
        reward = float(task.bank_rewards(self._reward, self.task.penalty))
        return self._obs.reshape(-1).copy(), reward, bool(self._term.any()), False, self._info()

    def _info(self) -> dict[str, Any]:
        info = self.task.info(self.sim, self._ref)
        info["time_s"] = float(self.sim.time_s[0])  # one clock for all actuators
        return info

    def _render_title(self) -> str:
        return f"{self.n} multiplexed actuators, {self.multiplexer.cycling_frequency_hz:g} Hz"

    def _render_labels(self) -> list[str] | None:
        return [str(j) for j in range(self.n)]


spell_out_settings(SMAMultiplexedEnv.__init__, _SETTINGS)


class SMAMultiplexedVectorEnv(MadeWith, EpisodeLimit, SubEnvAccess, VectorEnv):
    __doc__ = docs.env_doc(
        "``num_envs`` multiplexed banks simulated as one batch (the native vector env of ``SMAMultiplexed-v0``).",
        Description="""
            `gymnasium.make_vec("sma_gym:SMAMultiplexed-v0", num_envs=N,
            vectorization_mode="vector_entry_point", n_actuators=n, ...)`: bank b is actuators
            b*n ... b*n + n - 1 of one :class:`~sma_gym.Simulator`, stepped together, each bank
            on its own driver (its own slots or budget). Semantics match N single
            `SMAMultiplexedEnv`s exactly (tested): bank b is seeded with `seed + b` and draws
            its references and sensor noise from its own generator in the same order as a
            single env. Besides the Gymnasium API: the single env's constants (`n`, `scheme`,
            `multiplexer`, `duty_range`, `feature_names`, `control_period_s`,
            `duty_for()`, `action_for()`), `position_scale_m` and `resistance_scale_ohm`
            (one per bank) and `reference_description()`; `get_attr`, `set_attr` and `call`
            answer as `SyncVectorEnv`'s, one entry per bank (an attribute set is shared by
            every bank).
            """,
        Action_Space="`Box(-1, 1, (num_envs, n), float32)`: row b is bank b's action (the single env's).",
        Observation_Space="`Box(low, high, (num_envs, n * 10), float32)`: row b is bank b's observation.",
        Rewards="Row b: bank b's reward (the mean over its actuators, as the single env's).",
        Starting_State=docs.join(
            docs.START,
            '`reset(options={"references": [...]})`: one reference per actuator, for every bank reset; '
            '`reset(options={"reset_mask": mask})` resets only the masked banks.',
        ),
        Episode_End=docs.join(
            docs.EPISODE_END,
            "Autoreset `NEXT_STEP` only (Gymnasium's default): the step after a bank ends ignores "
            "its action, resets it and returns its first observation with reward 0.",
        ),
        Info="The single env's keys, each an array of shape (num_envs, n) (`time_s`: (num_envs,)), with `_key` masks (all true, but after a masked reset: true for the banks it reset).",
        Arguments=docs.arguments(
            """
            - `num_envs`: number of banks (1 to 2**16).
            - `max_episode_steps`: truncate episodes after this many steps (`None`: never).
              Through `make_vec` it reads as in `gym.make`, the same in every
              vectorization mode: absent or `None` the registered 1000, `-1` never.
            - `autoreset_mode`: `NEXT_STEP` (the only one).
            - every argument of :class:`SMAMultiplexedEnv` except `render_mode`.
            """
        ),
        Version_History=docs.join(docs.MODEL_CHANGE, "* 0.3: first release."),
    )

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}

    FIXED_AT_MAKE = (*BUILT_FROM, "n", "scheme", "multiplexer", "render_mode")
    """Attributes the simulator, the driver or the spaces were built from: adapters refuse
    to set them (the simulator would go on stepping with the old value)."""

    PER_ENV = ("position_scale_m", "resistance_scale_ohm")
    """One value per bank (sequence of length ``num_envs``): adapters hand bank i its own."""

    def __init__(
        self,
        num_envs: int,
        n_actuators: int = DEFAULT_N_ACTUATORS,
        cycling_frequency_hz: float = DEFAULT_CYCLING_FREQUENCY_HZ,
        max_episode_steps: int | None = None,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        render_mode: None = None,
        **kwargs: Any,
    ):
        self.num_envs = require_int_range("num_envs", num_envs, 1, 1 << 16)
        self.max_episode_steps = max_episode_steps
        mode = autoreset_mode.value if isinstance(autoreset_mode, AutoresetMode) else autoreset_mode
        require_choice("autoreset_mode", mode, (AutoresetMode.NEXT_STEP.value,))
        if render_mode is not None:
            raise ValueError(f"render_mode = {render_mode!r}: expected None (the bank vector env does not render)")
        self.autoreset_mode = AutoresetMode.NEXT_STEP
        self.render_mode = None
        # The bank env's own arguments but its render_mode, and this env's: an unknown one is
        # named against these (the prototype below would list its own, render_mode included).
        of_bank = [name for name in inspect.signature(SMAMultiplexedEnv).parameters if name != "render_mode"]
        mine = [name for name in inspect.signature(SMAMultiplexedVectorEnv).parameters if name != "kwargs"]
        accepted = (*mine, *(name for name in of_bank if name not in mine))
        reject_unknown({k: v for k, v in kwargs.items() if k not in of_bank}, accepted)
        # One single env as the prototype: the same checks, settings and constants.
        self._bank = SMAMultiplexedEnv(n_actuators, cycling_frequency_hz, **kwargs)
        bank = self._bank
        self.n, self.scheme, self.multiplexer = bank.n, bank.scheme, bank.multiplexer
        self.settings, self.duty_range, self.feature_names = bank.settings, bank.duty_range, bank.feature_names
        self.metadata = dict(self.metadata, render_fps=max(1, round(1.0 / self.control_period_s)))
        n, m = self.n, self.num_envs
        mux = self.multiplexer
        slots = [(mux.period_s, mux.phase(j), mux.duty_max) for _ in range(m) for j in range(n)]
        self.sim = Simulator(
            [self.settings.model] * (m * n),
            control_period_s=self.control_period_s,
            pwm_mode="resolved",
            pwm_slots=slots,
        )
        self.task = self.settings.task_state(m * n, task.OBS_POSITION)
        self.single_observation_space = bank.observation_space
        self.single_action_space = bank.action_space
        self.observation_space = batch_space(self.single_observation_space, m)
        self.action_space = batch_space(self.single_action_space, m)
        self._obs = np.zeros((m * n, bank.features_per_actuator), dtype=np.float32)
        self._reward = np.zeros(m * n)
        self._term = np.zeros(m * n, dtype=np.bool_)
        self._ref = np.zeros(m * n)
        self._duty = np.zeros((1, m * n))
        self._start = np.zeros(m * n)
        self._steps = np.zeros(m, dtype=np.int64)
        self._ended = np.zeros(m, dtype=bool)
        self._rngs: list[np.random.Generator | None] = [None] * m
        self._unstarted = UnstartedEnvs(m)
        self._all = np.arange(m * n, dtype=np.int64)
        self._bind_task()

    def _bind_task(self) -> None:
        """The step's outputs, bound once (again when ``energy_weight`` is set)."""
        self._evaluate = self.task.bind(self.sim, self._all, self._obs, self._reward, self._term, self._ref)

    @property
    def position_scale_m(self) -> np.ndarray:
        """Stroke each bank's position features are divided by [m], shape (num_envs,)."""
        return self.sim.usable_stroke_m[:: self.n].copy()

    @property
    def resistance_scale_ohm(self) -> np.ndarray:
        """Cold resistance each bank's resistance feature is relative to [ohm], shape (num_envs,)."""
        return self.sim.cold_resistance_ohm[:: self.n].copy()

    def duty_for(self, actions: np.ndarray) -> np.ndarray:
        """Each actuator's duty for (clipped) actions in [-1, 1] (the single env's)."""
        return self.duty_range.duty_for(actions)

    def action_for(self, duties: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`duty_for`."""
        return self.duty_range.action_for(duties)

    def reference_description(self) -> list[list[dict[str, Any]]]:
        """Each bank's references (one list per bank, one dict per actuator)."""
        described = self.task.describe_references(self.n, "sub-envs (banks)")
        return [described[b * self.n : (b + 1) * self.n] for b in range(self.num_envs)]

    def reset(self, *, seed: int | Sequence[int | None] | None = None, options: dict | None = None):
        """Reset all banks, or those in ``options["reset_mask"]``; bank b gets ``seed + b``."""
        mask, seeds, options = reset_arguments(seed, options, self.num_envs)
        if mask is None:
            mask = np.ones(self.num_envs, dtype=bool)
        first = int(np.flatnonzero(mask)[0])
        kept = (self._np_random, self._np_random_seed, list(self._rngs))
        if seeds[first] is not None:
            # As SMAVectorEnv: the vector env's own generator and np_random_seed follow the first seed.
            self._np_random, self._np_random_seed = seeding.np_random(seeds[first])
        for b in np.flatnonzero(mask):
            if seeds[b] is not None:
                self._rngs[b], _ = seeding.np_random(seeds[b])
        try:
            self._reset_banks(np.flatnonzero(mask), options)
        except Exception:
            # Refused: not even the seeds are applied.
            self._np_random, self._np_random_seed, self._rngs[:] = kept
            raise
        return self._observation(), self._info(mask)

    def _reset_banks(self, banks: np.ndarray, options: dict) -> None:
        n = self.n
        specs = reference_specs(options, n, also=("reset_mask",))
        # Every bank's references drawn before any is set: one refused leaves every bank's
        # episode and generator as it was.
        drawn, before, generators = {}, [], list(self._rngs)
        try:
            for b in banks:
                if self._rngs[b] is None:
                    self._rngs[b], _ = seeding.np_random(None)
                rng = self._rngs[b]
                before.append((rng, rng.bit_generator.state))
                for j, spec in enumerate(specs):
                    i = b * n + j
                    drawn[i] = refs.resolve(spec, rng, float(self.sim.usable_stroke_m[i]), self.settings.reference)
        except Exception:
            for rng, state in before:
                rng.bit_generator.state = state
            self._rngs[:] = generators  # and no generator made for it
            raise
        for b in banks:
            for j in range(n):
                self.task.set_reference(b * n + j, drawn[b * n + j])
            actuators = np.arange(b * n, (b + 1) * n)
            self.sim.reset(actuators)
            for i in actuators:
                self.task.reset_actuator(int(i), self.sim)
            self._steps[b] = 0
        self._ended[banks] = False
        self._unstarted.started(banks)
        self._evaluate()

    def step(self, actions):
        m, n = self.num_envs, self.n
        a = require_actions(actions, m, n, ignored=self._ended)
        self._unstarted.require_none()
        restart = self._ended.copy()
        duty = self.duty_for(a)
        if self.scheme == "shared_budget":
            duty, start = self.multiplexer.layout(duty)  # every bank at once
            self._start[:] = start.reshape(-1)
            self.sim.set_pulse_start(self._start)
        self._duty[0] = duty.reshape(-1)
        noise = None
        if self.sim.has_noise:
            # A bank restarting this step draws no noise: a single env draws none on reset.
            noise = np.zeros((1, 4, m * n))
            for b in np.flatnonzero(~restart):
                noise[0, :, b * n : (b + 1) * n] = self._rngs[b].standard_normal((1, 4, n))[0]
        self.sim.step_unchecked(self._duty, noise)
        self.task.last_duty[:] = self._duty[0]
        self._evaluate()
        self._steps += 1
        reward = task.bank_rewards(self._reward.reshape(m, n), self.task.penalty.reshape(m, n))
        terminated = self._term.reshape(m, n).any(axis=1)
        if restart.any():
            self._reset_banks(np.flatnonzero(restart), {})
            reward[restart] = 0.0
            terminated[restart] = False
        if self.max_episode_steps is not None:
            # As Gymnasium's TimeLimit: truncated at the limit even when it terminated too.
            truncated = self._steps >= self.max_episode_steps
        else:
            truncated = np.zeros(m, dtype=bool)
        self._ended = terminated | truncated
        return self._observation(), reward, terminated, truncated, self._info()

    def render(self) -> tuple[None, ...]:
        """No frames (this vector env does not render): a warning and one None per bank, as
        Gymnasium's sync env returns without a render mode."""
        gym.logger.warn(
            "render() of the bank vector env: no frames (it takes no render_mode; "
            "make_vec(..., vectorization_mode='sync', render_mode='rgb_array') draws them)"
        )
        return (None,) * self.num_envs

    def _observation(self) -> np.ndarray:
        return self._obs.reshape(self.num_envs, -1).copy()

    def _info(self, fresh: np.ndarray | None = None) -> dict[str, Any]:
        """Every bank's info; the ``_key`` masks are ``fresh`` (the banks a masked reset reset)
        or all true."""
        m, n = self.num_envs, self.n
        info = {key: value.reshape(m, n) for key, value in self.task.info(self.sim, self._ref).items()}
        info["time_s"] = self.sim.time_s[::n].copy()
        fresh = np.ones(m, dtype=bool) if fresh is None else fresh
        for key in list(info):
            # Each mask its own array: a caller editing one must not change another.
            info["_" + key] = fresh.copy()
        return info

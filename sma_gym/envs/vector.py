"""Native vector env: thousands of single-actuator envs as actuators of one simulator.

``gymnasium.make_vec("sma_gym:SMATracking-v0", num_envs=4096,
vectorization_mode="vector_entry_point")`` builds :class:`SMAVectorEnv`: one batched
:class:`~sma_gym.Simulator` step and one compiled task evaluation per vector step, instead
of N Python env steps. The contract is the docstring of :class:`SMAVectorEnv`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.envs.registration import EnvSpec
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from sma_gym._validation import require_actions, require_choice, require_int_range, require_options
from sma_gym.envs import ImportableSpec, docs, task
from sma_gym.envs.conditions import CONDITION_INFO, CONDITION_INFO_KEYS, condition_info
from sma_gym.envs.render import EpisodeHistory, EpisodePlot, check_render_mode
from sma_gym.envs.single import (
    TRACKING,
    MadeWith,
    Settings,
    SMARobustEnv,
    Variant,
    draw_actuator,
    keyword_settings,
    spell_out_settings,
    start_actuator,
    with_settings,
)
from sma_gym.envs.task import UnstartedEnvs
from sma_gym.simulator import Simulator

_MODES = {mode.value: mode for mode in AutoresetMode}


BUILT_FROM = (
    *MadeWith.READ_ONLY,  # read-only on every env: refused here as the others are, with a ValueError
    "settings",
    "sim",
    "task",
    "num_envs",
    "feature_names",
    "duty_range",
    "observation_space",
    "action_space",
    "single_observation_space",
    "single_action_space",
    "autoreset_mode",
)
"""What every native vector env builds its simulator and spaces from (its ``FIXED_AT_MAKE``
adds its own)."""


class EpisodeLimit(ImportableSpec):
    """Mixin of the native vector envs: ``max_episode_steps`` is checked whenever it is set
    (through an adapter's ``set_attr`` too: a text or 0 was taken and failed or ended every
    step), and ``spec.max_episode_steps`` is the limit the env applies (Gymnasium's
    ``make_vec`` stores the registered spec's 1000 whatever was given)."""

    _max_episode_steps: int | None = None

    @property
    def max_episode_steps(self) -> int | None:
        """Truncate every episode after this many steps (``None``: never)."""
        return self._max_episode_steps

    @max_episode_steps.setter
    def max_episode_steps(self, value: int | None) -> None:
        self._max_episode_steps = None if value is None else require_int_range("max_episode_steps", value, 1, 1 << 40)

    @property
    def spec(self) -> EnvSpec | None:
        spec = self._spec
        return None if spec is None else dataclasses.replace(spec, max_episode_steps=self._max_episode_steps)

    @spec.setter
    def spec(self, value: EnvSpec | None) -> None:
        ImportableSpec.spec.fset(self, value)


class SubEnvAccess:
    """Mixin of the native vector envs: Gymnasium's ``get_attr``, ``set_attr`` and ``call``
    as ``SyncVectorEnv`` has them (one entry per sub-env), over one batched env. Code
    written against the sync env (``v.call("reference_description")``) failed with an
    ``AttributeError`` on the native one (found by a new user). ``PER_ENV`` attributes and
    ``PER_ENV_METHODS`` results hold one entry per sub-env, which sub-env i gets; other
    attributes are shared by every sub-env."""

    num_envs: int
    FIXED_AT_MAKE: ClassVar[tuple[str, ...]] = ()
    PER_ENV: ClassVar[tuple[str, ...]] = ()
    PER_ENV_METHODS: ClassVar[tuple[str, ...]] = ("reference_description", "render")
    """Methods whose result is a sequence with one entry per sub-env."""

    def get_attr(self, name: str) -> tuple[Any, ...]:
        """Each sub-env's value of the attribute ``name`` (a tuple of ``num_envs``)."""
        value = getattr(self, name)
        if name in self.PER_ENV:
            return tuple(value[i] for i in range(self.num_envs))
        return (value,) * self.num_envs

    def set_attr(self, name: str, values: Any) -> None:
        """Set the attribute ``name``, shared by every sub-env: one value, or a list or tuple
        of ``num_envs`` equal values (``SyncVectorEnv`` takes one per sub-env; here they are
        one attribute). Refused: an attribute the simulator or the spaces were built from,
        and one held per sub-env."""
        if name in self.FIXED_AT_MAKE:
            raise ValueError(
                f"set_attr({name!r}): fixed when the env is made (the simulator was built with it); "
                f"make a new env with {name}=... instead"
            )
        if name in self.PER_ENV:
            raise ValueError(f"set_attr({name!r}): one value per sub-env, drawn by the env; expected another name")
        if isinstance(values, (list, tuple)):
            if len(values) != self.num_envs:
                raise ValueError(
                    f"set_attr({name!r}, ...): {len(values)} values for {self.num_envs} sub-envs; expected one "
                    "value, or one per sub-env"
                )
            if any(v is not values[0] and not _same(v, values[0]) for v in values):
                raise ValueError(
                    f"set_attr({name!r}, ...): the values differ between sub-envs, but the native vector env "
                    "shares one; expected equal values (or one sub-env per env: vectorization_mode='sync')"
                )
            values = values[0]
        setattr(self, name, values)

    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple[Any, ...]:
        """Each sub-env's result of ``name``: an attribute's value (as :meth:`get_attr`), or
        the result of a method in ``PER_ENV_METHODS`` called once for the batch."""
        attribute = getattr(self, name)
        if not callable(attribute):
            return self.get_attr(name)
        if name not in self.PER_ENV_METHODS:
            raise ValueError(
                f"call({name!r}): the native vector env runs its sub-envs as one batch; expected an attribute or "
                f"one of {', '.join(self.PER_ENV_METHODS)} (call the env's own {name}() for the batch)"
            )
        return tuple(attribute(*args, **kwargs))


def _same(a: Any, b: Any) -> bool:
    try:
        return bool(np.all(a == b))
    except Exception:
        return False


class SMAVectorEnv(MadeWith, EpisodeLimit, SubEnvAccess, VectorEnv):
    __doc__ = docs.env_doc(
        "``num_envs`` single-actuator envs of one variant, simulated as one batch.",
        Description="""
            The native vector env of the three single-actuator ids (``SMATracking-v0``,
            ``SMASelfSensing-v0``, ``SMARobust-v0``): sub-env i is actuator i of one
            :class:`~sma_gym.Simulator`, stepped together. Semantics match N single envs
            exactly (tested): sub-env i is seeded with `seed + i` (as Gymnasium's
            `SyncVectorEnv` does) and draws its references, conditions and sensor noise from
            its own generator in the same order as a single env. Besides the Gymnasium API:
            `reference_description()`, `conditions`, `reset_envs(indices)`, and the per-sub-env
            arrays `position_scale_m`, `resistance_scale_ohm`; `get_attr`, `set_attr` and
            `call` answer as `SyncVectorEnv`'s, one entry per sub-env (an attribute set is
            shared by every sub-env). Stable-baselines3 can use it in
            any autoreset mode through :class:`sma_gym.envs.sb3.SB3VecEnv`.
            """,
        Action_Space=docs.join(
            "`Box(-1, 1, (num_envs, 1), float32)`: sub-env i's action is row i; the single env's duty range.",
            docs.ACTION,
        ),
        Observation_Space="`Box(low, high, (num_envs, 10), float32)`: row i is sub-env i's "
        "observation, the single env's features (see its class).",
        Rewards=docs.join(docs.REWARD, "One reward per sub-env, shape (num_envs,)."),
        Starting_State=docs.join(
            docs.START,
            """
            `reset(options={"reset_mask": mask})` (a bool array, one entry per sub-env) resets
            only the masked sub-envs, in every autoreset mode, as in Gymnasium.
            """,
        ),
        Episode_End=docs.join(
            docs.EPISODE_END,
            """
            Autoreset: `autoreset_mode` works as in Gymnasium's `SyncVectorEnv` and is
            reported in `metadata["autoreset_mode"]`:

            * `NEXT_STEP` (default, as for every Gymnasium vector env, so Gymnasium's vector
              observation wrappers work): the step on which a sub-env ends returns its last
              observation; the next `step` ignores that sub-env's action, resets it and
              returns the first observation of its new episode with reward 0 and
              `terminated = truncated = False`.
            * `SAME_STEP`: the ending step already returns the first observation of the next
              episode; the last observation and info of the ended one are in
              `info["final_obs"]` / `info["final_info"]` (masks `info["_final_obs"]`,
              `info["_final_info"]`).
            * `DISABLED`: ended sub-envs are not reset; reset them with
              `reset(options={"reset_mask": mask})` before the next `step` (stepping one
              raises).
            """,
        ),
        Info=docs.join(
            "The single env's keys, each an array of fixed shape (num_envs,) with its `_key` "
            "mask (all true, but after a masked reset: true for the sub-envs it reset), the same "
            "keys at reset and at every step:",
            docs.INFO_KEYS,
            "and for the robustness variant the drawn condition:",
            task.info_list(CONDITION_INFO),
        ),
        Arguments=docs.arguments(
            """
            - `num_envs`: number of sub-envs (1 to 2**20).
            - `variant`: which single-actuator env (:data:`~sma_gym.envs.single.TRACKING`,
              `SELF_SENSING`, `ROBUST`); the vector entry points of the ids set it.
            - `max_episode_steps`: truncate episodes after this many steps (`None`: never).
              Through `make_vec` it reads as in `gym.make`, the same in every
              vectorization mode: absent or `None` the registered 1000, `-1` never.
            - `autoreset_mode`: an :class:`~gymnasium.vector.AutoresetMode` or its value string.
            - `render_mode`: `None` or `"rgb_array"`: `render()` returns one frame per
              sub-env (a tuple, as `SyncVectorEnv` does), each the single env's plot of
              that sub-env's current episode.
            """,
            docs.ARGUMENTS,
            docs.PWM_MODE,
            "- `supply_voltage_v`, `convection`, `wire_diameter_m`, `spread`: robustness "
            "variant only, as for ``SMARobust-v0``.",
        ),
        Version_History=docs.join(
            docs.MODEL_CHANGE,
            """
            * 0.2: `autoreset_mode` (default `NEXT_STEP`; 0.1 always ran `SAME_STEP`),
              `reset_mask`, `render_mode`; `info` without the object arrays `reference`
              (reset) and `condition` (use `reference_description()`, `conditions`,
              `reference_kind` and the `condition_*` arrays); `spec.id` carries the
              `sma_gym:` prefix; the contract is on the class and the keyword arguments in
              its signature.
            * 0.1: first release.
            """,
        ),
    )

    metadata = {"render_modes": ["rgb_array"], "render_fps": 100, "autoreset_mode": AutoresetMode.NEXT_STEP}

    FIXED_AT_MAKE = (*BUILT_FROM, "variant", "render_mode")
    """Attributes the simulator or the spaces were built from: changing one afterwards would
    leave the simulator stepping with the old value, so adapters refuse to set them."""

    PER_ENV = ("position_scale_m", "resistance_scale_ohm", "conditions")
    """Attributes that hold one value per sub-env (sequence of length ``num_envs``):
    adapters hand sub-env i its own entry."""

    def __init__(
        self,
        num_envs: int,
        variant: Variant = TRACKING,
        max_episode_steps: int | None = None,
        autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
        render_mode: str | None = None,
        **settings: Any,
    ):
        # The single envs' settings, conditions included (one definition, spelled out below).
        arguments = with_settings(locals(), VECTOR_SETTINGS, settings)
        self.num_envs = require_int_range("num_envs", num_envs, 1, 1 << 20)
        self.max_episode_steps = max_episode_steps
        mode = autoreset_mode.value if isinstance(autoreset_mode, AutoresetMode) else autoreset_mode
        self.autoreset_mode = _MODES[require_choice("autoreset_mode", mode, tuple(_MODES))]
        self.render_mode = check_render_mode(render_mode, self.metadata["render_modes"])
        self.variant = variant
        self.settings = Settings.from_arguments(variant, arguments)
        self.metadata = dict(
            self.metadata,
            autoreset_mode=self.autoreset_mode,
            render_fps=max(1, round(1.0 / self.settings.control_period_s)),
        )
        self.sim = Simulator(
            [self.settings.model] * self.num_envs,
            control_period_s=self.settings.control_period_s,
            pwm_mode=self.settings.pwm_mode,
        )
        self.task = self.settings.task_state(self.num_envs, variant.observation)
        low, high = task.bounds(variant.observation)
        self.single_observation_space = spaces.Box(low, high, dtype=np.float32)
        self.single_action_space = spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.feature_names = task.FEATURES[variant.observation]
        self.duty_range = variant.duty_range
        n = self.num_envs
        self._all_envs = np.arange(n, dtype=np.int64)
        self._obs = np.zeros((n, len(self.feature_names)), dtype=np.float32)
        self._reward = np.zeros(n)
        self._term = np.zeros(n, dtype=np.bool_)
        self._ref = np.zeros(n)
        self._steps = np.zeros(n, dtype=np.int64)
        self._duty = np.zeros((1, n))
        self._rngs: list[np.random.Generator | None] = [None] * n
        self._unstarted = UnstartedEnvs(n)
        self.conditions: list[dict[str, Any] | None] = [None] * n
        """The condition each sub-env drew at its last reset (robustness env), else ``None``."""
        self._condition_info = {
            key: np.zeros(n, dtype=bool if "forced" in key else float) for key in CONDITION_INFO_KEYS
        }
        self._all_true = np.ones(n, dtype=bool)
        # NEXT_STEP / DISABLED: sub-envs whose episode ended on the last step.
        self._ended = np.zeros(n, dtype=bool)
        # rgb_array: each sub-env's episode so far, drawn one after the other by one plot.
        self._histories = [EpisodeHistory() for _ in range(n)] if render_mode is not None else []
        self._plots: list[EpisodePlot] = []
        """One per sub-env, made at the first render: each keeps its own axes' limits and
        cached background, so a frame redraws only the lines (a plot shared by the sub-envs
        redrew the whole figure for each, 4x slower than Gymnasium's sync env)."""

    @property
    def position_scale_m(self) -> np.ndarray:
        """Stroke each sub-env's position features are divided by [m], shape (num_envs,)."""
        return self.sim.usable_stroke_m.copy()

    @property
    def resistance_scale_ohm(self) -> np.ndarray:
        """Cold resistance each sub-env's resistance feature is relative to [ohm]."""
        return self.sim.cold_resistance_ohm.copy()

    def reset(self, *, seed: int | Sequence[int | None] | None = None, options: dict | None = None):
        """Reset all sub-envs, or those in ``options["reset_mask"]``; sub-env i gets ``seed + i``."""
        mask, seeds, options = reset_arguments(seed, options, self.num_envs)
        if mask is None:
            mask = self._all_true
        first = int(np.flatnonzero(mask)[0])
        kept = (self._np_random, self._np_random_seed, list(self._rngs))
        if seeds[first] is not None:
            self._np_random, self._np_random_seed = seeding.np_random(seeds[first])
        for i in np.flatnonzero(mask):
            if seeds[i] is not None:
                self._rngs[i], _ = seeding.np_random(seeds[i])
        try:
            self._reset_envs(np.flatnonzero(mask), options)
        except Exception:
            # Refused: not even the seeds are applied.
            self._np_random, self._np_random_seed, self._rngs[:] = kept
            raise
        return self._obs.copy(), self._info(mask)

    def reset_envs(
        self, indices: Sequence[int], options: dict | None = None
    ) -> list[tuple[np.ndarray, dict[str, Any]]]:
        """Reset only the sub-envs ``indices`` (each with its own generator); the others go on.

        Returns ``(observation, info)`` per index, in the order given (info: that sub-env's
        entries as Python scalars).
        """
        if np.ndim(indices) == 0:
            raise ValueError(f"reset_envs indices = {indices!r}: expected a sequence of sub-env indices, e.g. [0]")
        indices = list(indices)
        for i in indices:
            if isinstance(i, (bool, np.bool_)) or not isinstance(i, (int, np.integer)) or not 0 <= i < self.num_envs:
                raise ValueError(
                    f"reset_envs indices = {indices!r}: expected sub-env indices, integers in [0, {self.num_envs - 1}]"
                )
        self._reset_envs(np.asarray(sorted({int(i) for i in indices}), dtype=np.int64), options)
        info = self._info()
        return [
            (self._obs[i].copy(), {k: v[i].item() for k, v in info.items() if not k.startswith("_")}) for i in indices
        ]

    def reference_description(self) -> list[dict[str, Any]]:
        """Each sub-env's current reference (kind, name, parameters; keys depend on the kind)."""
        return self.task.describe_references(envs="sub-envs")

    def _reset_envs(self, envs: np.ndarray, options: dict | None) -> None:
        """Start a new episode in the sub-envs ``envs``, each drawing from its own generator."""
        # Every sub-env's draw first: an option refused for one (a level past its drawn wire's
        # stroke) then leaves every sub-env's episode and generator as it was.
        drawn, before, generators = [], [], list(self._rngs)
        try:
            for i in envs:
                if self._rngs[i] is None:
                    self._rngs[i], _ = seeding.np_random(None)
                before.append(self._rngs[i].bit_generator.state)
                drawn.append(draw_actuator(self.sim, int(i), self._rngs[i], self.settings, options))
        except Exception:
            for i, state in zip(envs, before):
                self._rngs[i].bit_generator.state = state
            self._rngs[:] = generators  # and no generator made for it
            raise
        for i, episode in zip(envs, drawn):
            condition = start_actuator(self.sim, self.task, int(i), episode)
            self.conditions[i] = condition
            if condition is not None:
                for key, value in condition_info(condition).items():
                    self._condition_info[key][i] = value
            self._steps[i] = 0
            if self._histories:
                self._histories[i].clear()
        self._ended[envs] = False
        self._unstarted.started(envs)
        if envs.size:
            self._evaluate(envs.astype(np.int64))
            self._record(envs)

    def step(self, actions):
        a = require_actions(actions, self.num_envs, ignored=self._ended)
        self._unstarted.require_none()
        restart = self._ended.copy()
        if restart.any() and self.autoreset_mode == AutoresetMode.DISABLED:
            raise ValueError(
                f"sub-envs {np.flatnonzero(restart).tolist()} ended and autoreset_mode = DISABLED: expected "
                "reset(options={'reset_mask': mask}) for them before the next step"
            )
        duty = self.duty_range.duty_for(a[:, 0])
        self._duty[0] = duty
        noise = None
        if self.sim.has_noise:
            # Sub-envs restarting this step draw no noise: a single env draws none on reset.
            noise = np.zeros((1, 4, self.num_envs))
            for i in np.flatnonzero(~restart):
                noise[0, :, i] = self._rngs[i].standard_normal((1, 4, 1))[0, :, 0]
        self.sim.step_unchecked(self._duty, noise)
        self.task.last_duty[:] = duty
        self._evaluate(self._all_envs)
        self._steps += 1
        if restart.any():
            # NEXT_STEP: the sub-env was stepped with the batch; resetting it now discards that.
            self._reset_envs(np.flatnonzero(restart), None)
            self._reward[restart] = 0.0
            self._term[restart] = False
        self._record(np.flatnonzero(~restart))
        terminated = self._term.copy()
        if self.max_episode_steps is not None:
            # As Gymnasium's TimeLimit: truncated at the limit even when it terminated too.
            truncated = self._steps >= self.max_episode_steps
        else:
            truncated = np.zeros(self.num_envs, dtype=bool)
        reward = self._reward.copy()
        info = self._info()
        done = terminated | truncated
        if not done.any():
            return self._obs.copy(), reward, terminated, truncated, info
        if self.autoreset_mode != AutoresetMode.SAME_STEP:
            self._ended = done
            return self._obs.copy(), reward, terminated, truncated, info
        final_obs = np.full(self.num_envs, None, dtype=object)
        for i in np.flatnonzero(done):
            final_obs[i] = self._obs[i].copy()
        final_info = {k: v.copy() for k, v in info.items()}
        final_info.update({f"_{k}": done.copy() for k in info if not k.startswith("_")})
        self._reset_envs(np.flatnonzero(done), None)
        info = self._info()
        info["final_obs"] = final_obs
        info["_final_obs"] = done.copy()
        info["final_info"] = final_info
        info["_final_info"] = done.copy()
        return self._obs.copy(), reward, terminated, truncated, info

    def _evaluate(self, envs: np.ndarray) -> None:
        if len(envs) == self.num_envs:
            obs, rew, term, ref = self._obs, self._reward, self._term, self._ref
        else:
            k = len(envs)
            obs = np.zeros((k, self._obs.shape[1]), dtype=np.float32)
            rew, term, ref = np.zeros(k), np.zeros(k, dtype=np.bool_), np.zeros(k)
        self.task.bind(self.sim, envs, obs, rew, term, ref)()
        if len(envs) != self.num_envs:
            self._obs[envs] = obs
            self._ref[envs] = ref
            # A fresh episode is neither rewarded nor terminated yet; keep the step's values.

    def _info(self, fresh: np.ndarray | None = None) -> dict[str, Any]:
        """Every sub-env's info; the ``_key`` masks are ``fresh`` (the sub-envs a masked reset
        reset, as Gymnasium's vector envs mark them) or all true."""
        info = self.task.info(self.sim, self._ref)
        if self.variant.randomised:
            info.update({key: value.copy() for key, value in self._condition_info.items()})
        fresh = self._all_true if fresh is None else fresh
        for key in list(info):
            # A fresh mask each: a caller editing one must not change another, nor the next reset.
            info["_" + key] = fresh.copy()
        return info

    def _record(self, envs: np.ndarray) -> None:
        if not self._histories:
            return
        sim = self.sim
        for i in envs:
            self._histories[i].add(
                t=sim.time_s[i],
                position=sim.position_m[i],
                reference=self._ref[i],
                duty=sim.duty_applied[i],
                resistance=self.task.held[i, 0],
                temperature=sim.temperature_c[i],
            )

    def render(self) -> tuple[np.ndarray | None, ...]:
        """One (H, W, 3) uint8 frame per sub-env (``render_mode="rgb_array"``); without a
        render mode a warning and one None per sub-env, as Gymnasium's sync env returns."""
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' to make_vec()")
            return (None,) * self.num_envs
        # As Gymnasium's sync env (OrderEnforcing per sub-env): an empty episode is no frame.
        self._unstarted.require_none("render()")
        if not self._plots:
            self._plots = [EpisodePlot() for _ in range(self.num_envs)]
        name = self.spec.id if self.spec else "SMA"
        return tuple(
            plot.frame(h, f"{name} [{i}]: {self.settings.model.name}")
            for i, (plot, h) in enumerate(zip(self._plots, self._histories))
        )

    def close_extras(self, **kwargs: Any) -> None:
        self._plots = []

    def __getstate__(self) -> dict[str, Any]:
        # As the single env's renderer: the plot's canvas cannot be pickled; a copy draws its own.
        return {**self.__dict__, "_plots": []}


VECTOR_SETTINGS = keyword_settings(SMARobustEnv.__init__)
"""Every single env's settings, the robustness conditions included (a condition kwarg for a
variant that does not randomise is refused by :meth:`Settings.from_arguments`)."""

spell_out_settings(SMAVectorEnv.__init__, VECTOR_SETTINGS)


def reset_arguments(
    seed: int | Sequence[int | None] | None, options: dict | None, num_envs: int
) -> tuple[np.ndarray | None, list[int | None], dict]:
    """A vector reset's ``(reset_mask or None, one seed per sub-env, the other options)``:
    sub-env i gets ``seed + i`` (as Gymnasium's ``SyncVectorEnv``) or its entry of a list;
    ``ValueError`` naming a bad mask or seed list."""
    options = require_options(options)
    mask = options.pop("reset_mask", None)
    if mask is not None and not (
        isinstance(mask, np.ndarray) and mask.dtype == np.bool_ and mask.shape == (num_envs,) and mask.any()
    ):
        raise ValueError(
            f"options['reset_mask'] = {mask!r}: expected a bool numpy array of shape ({num_envs},) with a True entry"
        )

    def is_seed(value: Any) -> bool:
        return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_)) and value >= 0

    expected = f"expected None, an integer >= 0 or a list of {num_envs} such (or None), one per env"
    if seed is None:
        seeds: list[int | None] = [None] * num_envs
    elif is_seed(seed):
        seeds = [int(seed) + i for i in range(num_envs)]
    elif isinstance(seed, (list, tuple, np.ndarray)) and np.ndim(seed) == 1:
        seeds = list(seed)
        if len(seeds) != num_envs or not all(s is None or is_seed(s) for s in seeds):
            raise ValueError(f"seed = {seed!r}: {expected}")
        seeds = [None if s is None else int(s) for s in seeds]
    else:
        raise ValueError(f"seed = {seed!r}: {expected}")
    return mask, seeds, options

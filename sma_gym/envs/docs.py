"""The envs' contracts: class docstrings in Gymnasium's sections, assembled from shared parts.

Gymnasium documents each env on its class (``help(env.unwrapped)``) under Description,
Action Space, Observation Space, Rewards, Starting State, Episode End, Arguments and
Version History. Our envs share most of that text, and the tables of features and
``info`` keys are generated from their single definitions in :mod:`sma_gym.envs.task`, so
the text here cannot drift from the code.
"""

from __future__ import annotations

import textwrap

from sma_gym.envs import EPISODE_STEPS, task
from sma_gym.envs.references import FIELDS, NAMED
from sma_gym.simulator import PWM_MODES

SECTIONS = (
    "Description",
    "Action Space",
    "Observation Space",
    "Rewards",
    "Starting State",
    "Episode End",
    "Info",
    "Arguments",
    "Version History",
)


def env_doc(summary: str, **sections: str) -> str:
    """A class docstring: ``summary``, then each section (keyword = title with ``_`` for
    spaces) in Gymnasium's order. Section texts are dedented, so they may be indented in
    the source."""
    given = {title.replace("_", " "): text for title, text in sections.items()}
    unknown = set(given) - set(SECTIONS)
    if unknown:
        raise ValueError(f"sections {sorted(unknown)}: expected some of {list(SECTIONS)}")
    parts = [summary.strip()]
    for title in SECTIONS:
        if title in given:
            parts.append(f"## {title}\n\n{textwrap.dedent(given[title]).strip()}")
    return "\n\n".join(parts) + "\n"


def join(*texts: str) -> str:
    """Dedented texts as paragraphs of one section."""
    return "\n\n".join(textwrap.dedent(t).strip() for t in texts)


def arguments(*items: str) -> str:
    """Dedented lists of arguments as one list, then :data:`CHECKED`."""
    return "\n".join(textwrap.dedent(t).strip() for t in items) + "\n\n" + CHECKED


ACTION = """
    The action is mapped affinely onto the duty range [lo, hi],
    `duty = lo + (a + 1) / 2 (hi - lo)` (:class:`~sma_gym.envs.task.DutyRange`, also the
    env's `duty_for` / `action_for`); values outside [-1, 1] are clipped, NaN or inf
    raise `ValueError`. Each step advances the simulator by `control_period_s` (default
    10 ms; the report's controllers run at 1 kHz: pass `control_period_s=0.001`).
    """

REWARD = f"""
    Per actuator and step, *r = -|x_true - r(t)| / stroke - energy_weight P_el / P_full*,
    with `P_el` the mean electrical power of the step and `P_full = V^2 / R_cold` the power
    at duty 1 into the cold wire (the hot wire's resistance is lower, so at duty 1 the
    energy term reaches up to 1.21 `energy_weight` on the presets); `stroke` is the usable
    stroke (`ActuatorParams.usable_stroke_m`: the shorter of the driver's end-of-travel
    position and the loaded wire's reach, which is below eps0 l0 because the spring stretches
    the austenite and the hot wire expands: 17.16 of 17.96 mm on the bench twin). The reward uses the true
    position, whatever the agent sees. The step on which a wire passes `overheat_limit_c`
    also gets the overheat penalty, *-{EPISODE_STEPS} (1 + energy_weight P_el / P_full)*: a whole
    registered episode a full stroke off the reference at the power that overheated it
    (`task.overheat_penalty`; a bank's reward, the mean over its actuators, carries the
    whole penalty of each one that overheats, and that actuator's own reward carries it
    once: `task.bank_rewards`), so that ending an episode early never pays: without it, holding
    duty 1 on a wire without an end-of-travel cut (the bench twins) overheated it in 1.2 s
    for a better return than the report's controllers tracking.
    """

START = """
    The wire at rest: at ambient temperature, fully martensitic, extended (x = 0), its
    readings held at the cold wire's values. The reference is drawn at every reset from
    the env's generator among the `reference` kinds (levels within the actuator's
    stroke), or set by `reset(options={"reference": name_or_dict})`.
    """

EPISODE_END = """
    `terminated` when a wire exceeds `overheat_limit_c`; truncated by `max_episode_steps`
    (registered: 1000 steps = 10 s at the default control period).
    """

_REFERENCE_FIELDS = "; ".join(f"{kind}: " + ", ".join(f"`{f}`" for f in fields) for kind, fields in FIELDS.items())

ARGUMENTS = f"""
    - `model`: preset name, model JSON path or :class:`~sma_gym.ModelConfig`.
    - `control_period_s`: 1e-4 to 0.1 s (default {task.DEFAULT_CONTROL_PERIOD_S:g}).
    - `reference`: a kind ({", ".join(f"`{k!r}`" for k in NAMED)}), a tuple of kinds drawn
      from at each reset, or a dict `{{"kind": kind, field: value, ...}}` (default
      {task.DEFAULT_REFERENCE}); the fields, in s, m and rad ({_REFERENCE_FIELDS}; a field
      left out takes a default, the report's for step and sine; `{{"kind": kind}}` alone
      draws that kind), are
      :data:`~sma_gym.envs.references.FIELDS`. The same in `reset(options={{"reference": ...}})`.
    - `energy_weight`: 0 to 10 (default {task.DEFAULT_ENERGY_WEIGHT:g}); `overheat_limit_c`:
      40 to 500 degC and above the temperature where the wire starts to contract (default
      {task.DEFAULT_OVERHEAT_C:g}: Flexinol's trained memory degrades when held much hotter).
    - `position_noise_std_m`, `resistance_noise_std_ohm`: override the model's sensor noise.
    """

CHECKED = (
    "Every value is checked when the env is made: a bad one, or an unknown name, raises "
    "`ValueError` naming it and what was expected."
)

PWM_MODE = f"""
    - `pwm_mode`: {", ".join(f"`{m!r}`" for m in PWM_MODES)} (default `{task.DEFAULT_PWM_MODE!r}`;
      `'resolved'` integrates every PWM pulse).
    """

RENDER_MODE = """
    - `render_mode`: `None`, `"human"` or `"rgb_array"`: a (640, 640, 3) frame of the
      episode so far (position and reference, duty, resistance, temperature).
    """

INFO_KEYS = task.info_list(task.INFO)

MODEL_CHANGE = """
    * main (unreleased; the package reports 0.4.0.dev0, it reported 0.1.0 through 0.3 and
      main until 2026-12-07): **the dynamics changed under the same id.** The
      nominal wire is issue 11's (docs/model.md): Preisach-type minor loops whose hysteron
      widths are spread (the wire moves back within about a kelvin of a reversal, where
      0.2's play law crossed the whole 15 K first), an 8 K spread of transformation
      temperatures, 24.2 J/g latent heat, each phase's own thermal expansion, h0 and the
      austenite resistivity recalibrated, and the end-of-travel cut integrated with a tighter
      bound in its switching band. Spaces, rewards and `info` are unchanged.
      Results measured under this id before and after this change are not comparable; the
      id is still `-v0` (a version bump is pending), so record the package's commit with
      results. 0.2's minor loops, onset and energy come back with a `model` whose wire has
      `minor_loop_law="play"`, `transformation_spread_k=0` and `latent_heat_j_kg=0` (not
      bit for bit: h0 and the resistivity were calibrated with the new terms).
    * main (unreleased): `step()` before the first `reset()` raises `ResetNeeded` also
      on the class built directly or stepped through `env.unwrapped` (it ran an episode
      without a reference); through `make_vec`, `max_episode_steps=None` is the registered
      1000 and `-1` never, as in `gym.make`, in every vectorization mode (the native
      vector env took `None` as never).
    * main (unreleased): an unknown kwarg raises `UnexpectedKwargError`, a `ValueError` as
      before and also a `TypeError` in Python's wording ("got an unexpected keyword
      argument"), which is how tools probe a constructor: TorchRL's `GymEnv` can build every
      id (it passes `frameskip` and drops it on that `TypeError`). The native vector envs'
      `_key` info masks after a masked reset are true only for the sub-envs it reset, as in
      Gymnasium's `SyncVectorEnv` (they were all true); a restarting sub-env's ignored
      action may be NaN, as there. `control_period_s` is read-only after make (setting it
      was accepted and changed nothing). `reference="report-step"` or `"report-sine"` on a
      model whose stroke cannot reach its fixed levels is refused at make, as a dict is (it
      was refused only at the first reset).
    * main (unreleased, 2026-12-07): a refused `reset()` (a bad option) changes nothing:
      not the running episode, its generator or its seed (the robust env had set its
      newly drawn condition and the bank its first references before the option was
      refused, and a given seed was applied); `gym.make`'s `TimeLimit` still restarts its
      count. The native vector envs truncate an episode that ends on its last step even
      when it terminated there too, as `TimeLimit` does (they reported it terminated
      only), and `render()` without frames warns and returns one `None` per sub-env, as
      `SyncVectorEnv` does. A ramp reference shorter than 1 us and a hand-built
      `Reference` that fails a dict's checks are refused.
    * main (unreleased, 2026-12-07, later): refused at make, where before no episode could
      run: an `overheat_limit_c` at or below the temperature where the wire starts to
      contract (every episode ended before the wire moved; limits of 40-61 degC on the
      standard wire, which tests used to overheat it quickly, are refused now), and, on
      `SMASelfSensing-v0`, a model whose PWM pulses at the smallest duty are shorter than the
      settling time (`Driver.min_readable_duty` above 0.05: its resistance was not read at
      every duty). `SMARobust-v0` checks its condition ranges at their corners at make:
      ranges that could draw a wire it cannot run (below the surroundings' temperature, a
      reference beyond its stroke) failed a reset at random, and every reset after it.
      Integer kwargs (`n_actuators`, `num_envs`, `max_episode_steps`) refuse what `int()`
      truncated (a 0-d array 2.9 gave 2). An env made with `model=ModelConfig(...)` or
      `ActuatorParams(...)` is made again from its JSON spec.
    * main (unreleased, 2026-12-07, third): the settings an env is made with are read-only
      attributes (`model`, `reference`, `overheat_limit_c`, `pwm_mode`, as `control_period_s`
      was): setting one, directly or by `set_attr`, was taken and changed nothing.
      `energy_weight` may be set (a reward curriculum; `set_attr` on the vector envs and
      the SB3 adapter too) and acts from the next step. A step after the episode
      terminated warns once per episode, as Gymnasium's classic-control envs do. Reward:
      the overheat penalty (see Rewards); on the presets, whose end-of-travel cut keeps
      the wire below 120 degC, no episode reaches the default limit, so their rewards are
      unchanged.
    """

ROBUST_MODEL_CHECK = """
    * main (unreleased), `SMARobust-v0` only: a `model` whose supply, wire diameter or
      convection differs from the default model's raises `ValueError` unless the matching
      condition kwarg is given; before, the draws replaced its supply and diameter and
      multiplied an already fan-cooled convection by the fan's factor again, unasked.
      With `convection` fixed ("natural" or "forced"), a seed's other draws (supply, wire,
      spread) are now those of the default "random" draw; fixing it shifted them, so a
      natural and a forced episode of one seed saw different wires. The default draws are
      bit for bit the same.
    """

VERSION_0_2 = (
    MODEL_CHANGE
    + """
    * 0.2: `info` is flat and JSON-serialisable (`reference_description()` and the drawn
      condition replace the nested `info["reference"]` / `info["condition"]`;
      `reference_kind` and `condition_*` carry their numbers); unknown kwargs raise
      `ValueError` instead of `TypeError`; `env.spec.id` carries the `sma_gym:` prefix, so
      `gymnasium.make` resolves a logged id in any process; `render()` no longer switches
      matplotlib's global backend; the contract is on the class and the keyword arguments
      in its signature. Dynamics and rewards unchanged, so the ids stay `-v0`.
    * 0.1: first release.
    """
)

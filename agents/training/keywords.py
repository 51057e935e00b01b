"""The stable-baselines3 keywords ``train.py`` passes on, each with the values it accepts.

Every keyword of SB3's ``SAC`` and ``PPO`` is here, in one of three kinds: one that a
hyperparameter file or ``--hyperparams`` may set, checked (:data:`KEYWORDS`); one that
``train.py`` sets itself (:data:`OWN_KEYWORDS`, named with the option that does); one no
YAML file can hold, an object (:data:`NOT_FROM_A_FILE`). The same for the keywords of the
policy (``policy_kwargs``, :data:`POLICY_KEYWORDS`). SB3 itself checks few of them, and many
only late: ``gradient_steps: abc`` crashed at the first update with a ``TypeError``
traceback, ``ent_coef: .nan`` after ``learning_starts`` steps, while ``gradient_steps: 0``
(no update ever) and ``ent_coef: -1`` trained to the end into an agent that had not
learnt. :func:`check_model_kwargs` refuses all of these before a run folder exists, naming
where the value came from, the key, the value and what was expected, and passes the rest on
in the types SB3 needs (``gradient_steps: 2.0`` as ``2``; a ``train_freq`` list as a tuple).
Reviewed against SB3 2.9.2's source. (``tests/test_train.py`` checks that the tables
cover SB3's signatures, so a keyword a new SB3 adds is not passed on unchecked.)
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any, NamedTuple


class Check(NamedTuple):
    """A test of a value, what it expects (as the error message says it), and what the value
    becomes for SB3 once it passed (a count read as ``2.0`` must reach it as ``2``)."""

    test: Callable[[Any], bool]
    expected: str
    convert: Callable[[Any], Any] | None = None


RUN_KEYS = ("n_timesteps", "n_envs", "frame_stack", "vec_env_wrapper", "env_kwargs")
"""RL Zoo's keys of an entry that configure the run; the rest go to the algorithm."""

ZOO_ONLY_KEYS = (
    "normalize",
    "env_wrapper",
    "callback",
    "monitor_kwargs",
    "replay_buffer_class",
    "replay_buffer_kwargs",
    "noise_type",
    "noise_std",
)
"""RL Zoo's keys train.py does not implement: refused rather than silently ignored."""


def _real(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def is_count(value: Any, low: int) -> bool:
    """``value`` is a whole number >= ``low`` (a YAML ``2.0e+5`` is one; ``True`` and ``1.5`` are not)."""
    return _real(value) and float(value).is_integer() and value >= low


def _count(low: int) -> Check:
    return Check(lambda v: is_count(v, low), f"an integer >= {low}", int)


def _number(low: float, *, strict: bool = True, high: float | None = None) -> Check:
    def ok(v: Any) -> bool:
        return _real(v) and (v > low if strict else v >= low) and (high is None or v <= high)

    if high is None:
        return Check(ok, f"a number {'>' if strict else '>='} {low:g}")
    return Check(ok, f"a number in {'(' if strict else '['}{low:g}, {high:g}]")


def _or_none(check: Check) -> Check:
    return Check(lambda v: v is None or check.test(v), f"{check.expected} or null", check.convert)


def _or_schedule(check: Check) -> Check:
    return Check(lambda v: callable(v) or check.test(v), f"{check.expected} (or a schedule, from Python)")


FLAG = Check(lambda v: isinstance(v, bool), "true or false")
POLICY = Check(
    lambda v: v == "MlpPolicy",
    "'MlpPolicy' (sma-gym's observations are flat vectors: CnnPolicy is for images, MultiInputPolicy for dicts)",
)


def _train_freq(value: Any) -> bool:
    if isinstance(value, (tuple, list)):  # SB3's (frequency, unit)
        return len(value) == 2 and is_count(value[0], 1) and value[1] in ("step", "episode")
    return is_count(value, 1)


def _as_train_freq(value: Any) -> Any:
    """SB3 reads a tuple only (a YAML or literal list was refused when the model was built)."""
    return (int(value[0]), value[1]) if isinstance(value, (tuple, list)) else int(value)


def _as_number(value: Any) -> Any:
    """A number given as text (a quoted "0.1", which SB3 passes to ``float``) as the number;
    anything else as it is."""
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return value
    return value


def _sac_ent_coef(value: Any) -> bool:
    if isinstance(value, str) and value.startswith("auto"):  # "auto" or "auto_<initial value>", learnt either way
        head, sep, initial = value.partition("_")
        if head != "auto":
            return False
        if not sep:
            return True
        try:
            return _number(0.0).test(float(initial))
        except ValueError:
            return False
    return _number(0.0, strict=False).test(_as_number(value))  # 0: no entropy bonus (an ablation SB3 trains)


def _fixed_or_auto(value: Any) -> Any:
    return value if isinstance(value, str) and value.startswith("auto") else _as_number(value)


_COMMON: dict[str, Check] = {
    "policy": POLICY,
    "learning_rate": _or_schedule(_number(0.0)),
    "gamma": _number(0.0, strict=False, high=1.0),  # 0: a myopic agent, which SB3 trains
    "use_sde": FLAG,
    "sde_sample_freq": Check(
        lambda v: is_count(v, -1), "an integer >= -1 (-1 or 0: new noise only at the start of a rollout)", int
    ),
    "stats_window_size": _count(1),
    "policy_kwargs": Check(lambda v: isinstance(v, Mapping), "dict(name=literal, ...)"),
}

KEYWORDS: dict[str, dict[str, Check]] = {
    "sac": {
        **_COMMON,
        "buffer_size": _count(1),
        "learning_starts": _count(0),
        "batch_size": _count(1),
        "tau": _number(0.0, high=1.0),  # 0 would never update the target networks
        "train_freq": Check(_train_freq, "an integer >= 1 or [n, 'step' | 'episode']", _as_train_freq),
        "gradient_steps": Check(
            lambda v: is_count(v, -1) and v != 0,
            "an integer >= 1, or -1 (as many as environment steps); 0 would never train",
            int,
        ),
        # SB3 refuses True with the replay buffer's timeout handling, which the envs' time limits need.
        "optimize_memory_usage": Check(lambda v: v is False, "false (SB3 refuses true with time-limited episodes)"),
        "n_steps": _count(1),
        "ent_coef": Check(_sac_ent_coef, "a number >= 0, 'auto' or 'auto_<initial number > 0>'", _fixed_or_auto),
        "target_update_interval": _count(1),
        "target_entropy": Check(lambda v: v == "auto" or _real(_as_number(v)), "'auto' or a number", _fixed_or_auto),
        "use_sde_at_warmup": FLAG,
    },
    "ppo": {
        **_COMMON,
        "n_steps": _count(1),
        "batch_size": _count(1),  # >= 2 with normalize_advantage: checked with it below
        "n_epochs": _count(1),
        "gae_lambda": _number(0.0, strict=False, high=1.0),  # 0: one-step TD
        "clip_range": _or_schedule(_number(0.0)),
        "clip_range_vf": _or_none(_or_schedule(_number(0.0))),
        "normalize_advantage": FLAG,
        "ent_coef": _number(0.0, strict=False),
        "vf_coef": _number(0.0, strict=False),
        "max_grad_norm": _number(0.0),
        "target_kl": _or_none(_number(0.0)),
    },
}
"""The keywords a hyperparameter file may set, per algorithm, each with its check."""

OWN_KEYWORDS = {
    "env": "--env",
    "seed": "--seed",
    "device": "--device",
    "tensorboard_log": "train.py (the run folder's tb/)",
    "verbose": "train.py (--no-progress for plain progress lines)",
    "_init_setup_model": "train.py",
}
"""Keywords ``train.py`` sets itself, with the option that sets them."""

NOT_FROM_A_FILE = {"sac": ("action_noise",), "ppo": ("rollout_buffer_class", "rollout_buffer_kwargs")}
"""Keywords whose values are objects, per algorithm (SAC's replay buffer's are
:data:`ZOO_ONLY_KEYS`: RL Zoo builds them from its own keys)."""

_NET = Check(
    lambda v: isinstance(v, list) and all(is_count(n, 1) for n in v),
    "a list of layer sizes (integers >= 1)",
    lambda v: [int(n) for n in v],
)

POLICY_KEYWORDS: dict[str, dict[str, Check]] = {
    algo: {
        "log_std_init": Check(_real, "a number"),
        "use_expln": FLAG,
        "features_extractor_kwargs": Check(lambda v: isinstance(v, Mapping), "a dict"),
        "normalize_images": FLAG,
        "optimizer_kwargs": Check(lambda v: isinstance(v, Mapping) and all(isinstance(k, str) for k in v), "a dict"),
        "share_features_extractor": FLAG,
        **extra,
    }
    for algo, extra in (
        ("sac", {"clip_mean": _number(0.0, strict=False), "n_critics": _count(1)}),  # clip_mean 0: no clipping
        ("ppo", {"ortho_init": FLAG, "full_std": FLAG, "squash_output": FLAG}),
    )
}
"""The policy's literal keywords per algorithm (its classes, ``activation_fn`` and the
like, cannot be written as literals); ``net_arch`` is checked apart."""

NET_HEADS = {"sac": ("pi", "qf"), "ppo": ("pi", "vf")}
"""The networks ``net_arch`` may size apart, as a dict: the actor and the critic (SAC needs
both; PPO takes either, the other then without hidden layers)."""

POLICY_SET_BY_ALGORITHM = ("observation_space", "action_space", "lr_schedule", "use_sde")
"""Policy keywords the algorithm passes itself (``use_sde`` is the algorithm's keyword)."""


def text_number_hint(value: Any) -> str:
    """Why a number may have arrived as text: YAML 1.1 reads ``3e-4`` (no dot) as a string."""
    if isinstance(value, str) and "e" in value.lower():
        try:
            number = float(value)
        except ValueError:
            return ""
        if math.isfinite(number):
            return f" (YAML 1.1 reads {value} as text: write it with a dot and a signed exponent, e.g. {number:.1e})"
    return ""


def _checked(check: Check, key: str, value: Any, where: str) -> Any:
    if not check.test(value):
        raise ValueError(f"{where}: {key} = {value!r}: expected {check.expected}{text_number_hint(value)}")
    return value if check.convert is None else check.convert(value)


def check_model_kwargs(model_kwargs: Mapping[str, Any], algo: str, source: Callable[[str], str]) -> dict[str, Any]:
    """``model_kwargs`` of ``algo`` (``"sac"``/``"ppo"``) checked, as SB3 takes them (counts as
    ``int``, ``train_freq`` as a tuple). A keyword train.py does not pass on, or a value SB3
    cannot learn with or would refuse only late, is a ``ValueError`` naming where the key
    came from (``source(key)``), the key, its value and what was expected."""
    table = KEYWORDS[algo]
    out = {}
    for key, value in model_kwargs.items():
        where = source(key)
        if key in OWN_KEYWORDS:
            raise ValueError(f"{where}: {key} is set by {OWN_KEYWORDS[key]}, not by the hyperparameters")
        if key in NOT_FROM_A_FILE[algo]:
            raise ValueError(f"{where}: {key} takes an object, which train.py cannot read from a file")
        if key not in table:
            raise ValueError(
                f"{where}: {key!r} is neither a run key {list(RUN_KEYS)} nor a keyword of stable-baselines3's "
                f"{algo.upper()} {sorted(table)}"
            )
        out[key] = _checked(table[key], key, value, where)
        if key == "policy_kwargs":
            out[key] = check_policy_kwargs(value, algo, f"{where}: policy_kwargs")
    if algo == "ppo" and out.get("batch_size") == 1 and out.get("normalize_advantage", True):
        # SB3 asserts it when the model is built: one sample has no spread to normalise by.
        raise ValueError(
            f"{source('batch_size')}: batch_size = 1 with normalize_advantage: expected batch_size >= 2, "
            "or normalize_advantage: false"
        )
    return out


def check_policy_kwargs(policy_kwargs: Mapping[str, Any], algo: str, where: str) -> dict[str, Any]:
    """:func:`check_model_kwargs` for the policy's keywords."""
    table = POLICY_KEYWORDS[algo]
    heads = NET_HEADS[algo]
    out = {}
    for key, value in policy_kwargs.items():
        if key in POLICY_SET_BY_ALGORITHM:
            raise ValueError(
                f"{where}: {key} is set by the algorithm{' (its own use_sde keyword)' if key == 'use_sde' else ''}"
            )
        if key == "net_arch":
            if value is None:  # SB3's default sizes
                out[key] = value
            elif (
                isinstance(value, Mapping)
                and (set(value) == set(heads) if algo == "sac" else set(value) <= set(heads))
                and all(_NET.test(v) for v in value.values())
            ):
                out[key] = {head: _NET.convert(v) for head, v in value.items()}
            elif _NET.test(value):
                out[key] = _NET.convert(value)
            else:
                raise ValueError(
                    f"{where}: net_arch = {value!r}: expected {_NET.expected}, or dict({'=[...], '.join(heads)}=[...]) "
                    f"for the actor and the critic apart"
                )
            continue
        if key not in table:
            raise ValueError(
                f"{where}: {key!r} is no literal keyword of {algo.upper()}'s MlpPolicy; expected one of "
                f"{sorted([*table, 'net_arch'])}"
            )
        out[key] = _checked(table[key], key, value, where)
    return out

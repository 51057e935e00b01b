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
the key, its value and what was expected. (``tests/test_train.py`` checks that the tables
cover SB3's signatures, so a keyword a new SB3 adds is not passed on unchecked.)
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

Check = tuple[Callable[[Any], bool], str]
"""A test of a value and what it expects, as the error message says it."""


def _real(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def is_count(value: Any, low: int) -> bool:
    """``value`` is a whole number >= ``low`` (a YAML ``2.0e+5`` is one; ``True`` and ``1.5`` are not)."""
    return _real(value) and float(value).is_integer() and value >= low


def _count(low: int) -> Check:
    return (lambda v: is_count(v, low)), f"an integer >= {low}"


def _number(low: float, *, strict: bool = True, high: float | None = None) -> Check:
    def ok(v: Any) -> bool:
        return _real(v) and (v > low if strict else v >= low) and (high is None or v <= high)

    if high is None:
        return ok, f"a number {'>' if strict else '>='} {low:g}"
    return ok, f"a number in {'(' if strict else '['}{low:g}, {high:g}]"


def _or_none(check: Check) -> Check:
    test, expected = check
    return (lambda v: v is None or test(v)), f"{expected} or null"


def _or_schedule(check: Check) -> Check:
    test, expected = check
    return (lambda v: callable(v) or test(v)), f"{expected} (or a schedule, from Python)"


FLAG: Check = (lambda v: isinstance(v, bool), "true or false")
POLICY: Check = (
    lambda v: v == "MlpPolicy",
    "'MlpPolicy' (sma-gym's observations are flat vectors: CnnPolicy is for images, MultiInputPolicy for dicts)",
)


def _train_freq(value: Any) -> bool:
    if isinstance(value, (tuple, list)):  # SB3's (frequency, unit)
        return len(value) == 2 and is_count(value[0], 1) and value[1] in ("step", "episode")
    return is_count(value, 1)


def _sac_ent_coef(value: Any) -> bool:
    if isinstance(value, str):  # "auto" or "auto_<initial value>", learnt either way
        head, _, initial = value.partition("_")
        if head != "auto":
            return False
        if not initial:
            return True
        try:
            return _number(0.0)[0](float(initial))
        except ValueError:
            return False
    return _number(0.0)[0](value)


_COMMON: dict[str, Check] = {
    "policy": POLICY,
    "learning_rate": _or_schedule(_number(0.0)),
    "gamma": _number(0.0, high=1.0),
    "use_sde": FLAG,
    "sde_sample_freq": (
        lambda v: is_count(v, -1),
        "an integer >= -1 (-1 or 0: new noise only at the start of a rollout)",
    ),
    "stats_window_size": _count(1),
    "policy_kwargs": (lambda v: isinstance(v, Mapping), "dict(name=literal, ...)"),
}

KEYWORDS: dict[str, dict[str, Check]] = {
    "sac": {
        **_COMMON,
        "buffer_size": _count(1),
        "learning_starts": _count(0),
        "batch_size": _count(1),
        "tau": _number(0.0, high=1.0),  # 0 would never update the target networks
        "train_freq": (_train_freq, "an integer >= 1 or [n, 'step' | 'episode']"),
        "gradient_steps": (
            lambda v: is_count(v, -1) and v != 0,
            "an integer >= 1, or -1 (as many as environment steps); 0 would never train",
        ),
        "optimize_memory_usage": FLAG,
        "n_steps": _count(1),
        "ent_coef": (_sac_ent_coef, "a number > 0, 'auto' or 'auto_<initial number > 0>'"),
        "target_update_interval": _count(1),
        "target_entropy": (lambda v: v == "auto" or _real(v), "'auto' or a number"),
        "use_sde_at_warmup": FLAG,
    },
    "ppo": {
        **_COMMON,
        "n_steps": _count(1),
        "batch_size": _count(2),  # SB3 normalises advantages over a minibatch
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

NOT_FROM_A_FILE = (
    "action_noise",
    "replay_buffer_class",
    "replay_buffer_kwargs",
    "rollout_buffer_class",
    "rollout_buffer_kwargs",
)
"""Keywords whose values are objects (RL Zoo builds some from its own keys, which train.py
does not implement)."""

_NET: Check = (
    lambda v: isinstance(v, list) and all(is_count(n, 1) for n in v),
    "a list of layer sizes (integers >= 1)",
)

POLICY_KEYWORDS: dict[str, dict[str, Check]] = {
    algo: {
        "log_std_init": (_real, "a number"),
        "use_expln": FLAG,
        "features_extractor_kwargs": (lambda v: isinstance(v, Mapping), "a dict"),
        "normalize_images": FLAG,
        "optimizer_kwargs": (lambda v: isinstance(v, Mapping) and all(isinstance(k, str) for k in v), "a dict"),
        "share_features_extractor": FLAG,
        **extra,
    }
    for algo, extra in (
        ("sac", {"clip_mean": _number(0.0), "n_critics": _count(1)}),
        ("ppo", {"ortho_init": FLAG, "full_std": FLAG, "squash_output": FLAG}),
    )
}
"""The policy's literal keywords per algorithm (its classes, ``activation_fn`` and the
like, cannot be written as literals); ``net_arch`` is checked apart."""

NET_HEADS = {"sac": ("pi", "qf"), "ppo": ("pi", "vf")}
"""The networks ``net_arch`` may size apart, as a dict: the actor and the critic."""

POLICY_SET_BY_ALGORITHM = ("observation_space", "action_space", "lr_schedule", "use_sde")
"""Policy keywords the algorithm passes itself (``use_sde`` is the algorithm's keyword)."""


def _text_number_hint(value: Any) -> str:
    """Why a number may have arrived as text: YAML 1.1 reads ``3e-4`` (no dot) as a string."""
    if isinstance(value, str) and "e" in value.lower():
        try:
            number = float(value)
        except ValueError:
            return ""
        if math.isfinite(number):
            return f" (YAML 1.1 reads {value} as text: write it with a dot and a signed exponent, e.g. {number:.1e})"
    return ""


def check_model_kwargs(model_kwargs: Mapping[str, Any], algo: str, where: str) -> None:
    """Refuse a keyword of ``algo`` (``"sac"``/``"ppo"``) that train.py does not pass on, or a
    value stable-baselines3 cannot learn with or would refuse only late; a ``ValueError``
    naming ``where``, the key, its value and what was expected."""
    table = KEYWORDS[algo]
    for key, value in model_kwargs.items():
        if key in OWN_KEYWORDS:
            raise ValueError(f"{where}: {key} is set by {OWN_KEYWORDS[key]}, not by the hyperparameters")
        if key in NOT_FROM_A_FILE:
            raise ValueError(f"{where}: {key} takes an object, which train.py cannot read from a file")
        if key not in table:
            raise ValueError(
                f"{where}: {key!r} is no keyword of stable-baselines3's {algo.upper()}; expected one of {sorted(table)}"
            )
        test, expected = table[key]
        if not test(value):
            raise ValueError(f"{where}: {key} = {value!r}: expected {expected}{_text_number_hint(value)}")
    if "policy_kwargs" in model_kwargs:
        check_policy_kwargs(model_kwargs["policy_kwargs"], algo, f"{where}: policy_kwargs")


def check_policy_kwargs(policy_kwargs: Mapping[str, Any], algo: str, where: str) -> None:
    """:func:`check_model_kwargs` for the policy's keywords."""
    table = POLICY_KEYWORDS[algo]
    heads = NET_HEADS[algo]
    for key, value in policy_kwargs.items():
        if key in POLICY_SET_BY_ALGORITHM:
            raise ValueError(
                f"{where}: {key} is set by the algorithm{' (its own use_sde keyword)' if key == 'use_sde' else ''}"
            )
        if key == "net_arch":
            sizes = value.values() if isinstance(value, Mapping) else [value]
            if isinstance(value, Mapping) and not set(value) <= set(heads):
                ok = False
            else:
                ok = all(_NET[0](v) for v in sizes)
            if not ok:
                raise ValueError(
                    f"{where}: net_arch = {value!r}: expected {_NET[1]}, or dict({'=[...], '.join(heads)}=[...]) "
                    f"for the actor and the critic apart"
                )
            continue
        if key not in table:
            raise ValueError(
                f"{where}: {key!r} is no literal keyword of {algo.upper()}'s MlpPolicy; expected one of "
                f"{sorted([*table, 'net_arch'])}"
            )
        test, expected = table[key]
        if not test(value):
            raise ValueError(f"{where}: {key} = {value!r}: expected {expected}{_text_number_hint(value)}")

"""The run configuration of ``train.py``: hyperparameter file, command line, checks.

Hyperparameters live in ``hyperparams/<algo>.yml``, RL Baselines3 Zoo's format (one file
per algorithm, one entry per env id), the one source that ``train.py`` and
``python -m rl_zoo3.train --conf-file hyperparams/<algo>.yml`` both read. The agent's
features are the entry's ``vec_env_wrapper`` list (:data:`RESIDUAL_WRAPPER`, then
:data:`HISTORY_WRAPPER`; for the multiplexed bank :data:`BANK_WRAPPER` alone, one policy per
actuator); command-line options override the file.
:meth:`RunConfig.from_args` merges the two and checks every value before anything is
created, so a bad option exits 2 with its name.
"""

from __future__ import annotations

import argparse
import ast
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any, NamedTuple

from sma_gym_agents.card import (
    ALLOCATIONS,
    BANK_ENV_ID,
    CARD_SUFFIX,
    FILTER_S_EXPECTED,
    PolicyCard,
    is_filter_time_constant,
)
from sma_gym_agents.controllers import ALL_SPECS, spec_by_label
from sma_gym_agents.history import HISTORIES, HistoryFeatures
from sma_gym_agents.training.keywords import (
    RUN_KEYS,
    ZOO_ONLY_KEYS,
    check_model_kwargs,
    is_count,
    text_number_hint,
)

ROOT = Path(__file__).resolve().parents[2]
"""The repository: ``train.py``, ``hyperparams/`` and the default ``runs/`` live here."""
HYPERPARAMS = ROOT / "hyperparams"
ALGOS = ("sac", "ppo")
DEFAULT_ALGO = "sac"
QUICK_TIMESTEPS = 1_500
DEFAULT_RESIDUAL_SCALE = 0.5
EVAL_FREQ = {"sac": 20_000, "ppo": 250_000}
"""Default ``--eval-freq`` per algorithm: a command-line option, as in RL Zoo, not a hyperparameter."""
RESIDUAL_WRAPPER = "sma_gym_agents.training.envs.ResidualVecEnv"
HISTORY_WRAPPER = "sma_gym_agents.training.envs.HistoryVecEnv"
BANK_WRAPPER = "sma_gym_agents.training.envs.BankVecEnv"
BANK_ENV = BANK_ENV_ID
"""The env whose agent is one policy shared by every actuator of the bank (:data:`BANK_WRAPPER`)."""
NOT_FOR_TRAIN_PY: dict[str, str] = {}
"""Env ids the hyperparameter files hold for RL Zoo only, with the reason (none since the bank trains)."""

DESCRIPTION = "Train a stable-baselines3 agent on an sma-gym env and compare it with the report's controllers."


def hyperparams_path(algo: str) -> Path:
    """``hyperparams/<algo>.yml``."""
    return HYPERPARAMS / f"{algo}.yml"


def load_hyperparams(env_id: str, algo: str = DEFAULT_ALGO) -> dict[str, Any]:
    """The entry of ``env_id`` in ``hyperparams/<algo>.yml``, as the zoo reads it;
    ``ValueError`` naming the known ids if absent."""
    import yaml  # only here: the rest of the configuration needs no YAML

    path = hyperparams_path(algo)
    try:
        with path.open() as handle:
            entries = yaml.safe_load(handle)
    except yaml.YAMLError as err:  # its message names the line and column
        raise ValueError(f"{path} is not valid YAML: {err}") from None
    if not isinstance(entries, dict):
        raise ValueError(
            f"{path}: expected a mapping of env ids to their hyperparameters, got {type(entries).__name__}"
        )
    if env_id not in entries:
        raise ValueError(f"--env {env_id!r}: no entry in {path}; expected one of {sorted(map(str, entries))}")
    entry = entries[env_id]
    if not isinstance(entry, dict) or not all(isinstance(k, str) for k in entry):
        raise ValueError(f"{path} [{env_id}]: expected a mapping of hyperparameter names to values, got {entry!r}")
    return dict(entry)


def literal_kwargs(text: str | dict[str, Any], key: str) -> dict[str, Any]:
    """A zoo keyword string such as ``"dict(net_arch=dict(pi=[256], qf=[256]))"`` as a dict,
    read without ``eval`` (literals and ``dict(...)`` of literals only; the zoo itself
    evaluates it as Python)."""
    if isinstance(text, dict):
        return dict(text)
    reason = ""
    try:
        value = _literal(ast.parse(text, mode="eval").body)
        if isinstance(value, dict):
            return value
    except _RepeatedKeyword as err:
        reason = f" ({err})"
    except (SyntaxError, ValueError, TypeError):
        pass
    raise ValueError(f"{key} = {text!r}: train.py reads dict(name=literal, ...) or a mapping of literals{reason}")


class _RepeatedKeyword(ValueError):
    """``dict(a=1, a=2)``: Python refuses it (the zoo evaluates the text), ast does not."""


def _literal(node: ast.expr) -> Any:
    """``ast.literal_eval`` that also reads ``dict(name=value, ...)``, nested anywhere."""
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "dict" and not node.args:
        names = [kw.arg for kw in node.keywords]
        if None in names:
            raise ValueError("dict(**...) is no literal")
        repeated = sorted({n for n in names if names.count(n) > 1})
        if repeated:
            raise _RepeatedKeyword(f"repeated keyword {', '.join(map(str, repeated))}")
        return {kw.arg: _literal(kw.value) for kw in node.keywords}
    if isinstance(node, ast.List):
        return [_literal(e) for e in node.elts]
    if isinstance(node, ast.Tuple):
        return tuple(_literal(e) for e in node.elts)
    if isinstance(node, ast.Dict):
        if any(k is None for k in node.keys):
            raise ValueError("{**...} is no literal")
        return {_literal(k): _literal(v) for k, v in zip(node.keys, node.values, strict=True)}
    return ast.literal_eval(node)


class AgentFeatures(NamedTuple):
    """What a zoo ``vec_env_wrapper`` value makes of the agent's view (:func:`agent_features`)."""

    history: str
    residual: str | None
    residual_scale: float
    residual_allocation: str
    residual_filter_s: float


def agent_features(wrappers: Any) -> AgentFeatures:
    """The agent's view from a zoo ``vec_env_wrapper`` value: our residual wrapper (optional;
    keyword arguments ``base``, ``scale``, ``filter_s``) then our history wrapper (optional;
    ``error_features: true`` for history ``"ema+error"``), nothing else; or the bank's wrapper
    alone (its ``allocation``: how a residual bank agent's base grants an overrun shared
    budget, :data:`sma_gym_agents.card.ALLOCATIONS`)."""
    items = [] if wrappers is None else wrappers if isinstance(wrappers, list) else [wrappers]
    parsed = [(next(iter(w)), dict(next(iter(w.values())) or {})) if isinstance(w, dict) else (w, {}) for w in items]
    names = [name for name, _ in parsed]
    if BANK_WRAPPER in names:
        bank = parsed[0][1]
        if (
            names != [BANK_WRAPPER]
            or set(bank) - {"base", "scale", "allocation"}
            or (set(bank) & {"scale", "allocation"} and "base" not in bank)
        ):
            raise ValueError(
                f"vec_env_wrapper {items}: {BANK_WRAPPER} stands alone, with the keyword arguments base, "
                "scale and allocation (a residual bank agent) or none"
            )
        allocation = str(bank.get("allocation", "proportional"))
        if allocation not in ALLOCATIONS:
            raise ValueError(f"{BANK_WRAPPER} allocation = {allocation!r}: expected one of {ALLOCATIONS}")
        base = bank.get("base")
        scale = float(bank.get("scale", DEFAULT_RESIDUAL_SCALE))
        return AgentFeatures("none", None if base is None else str(base), scale, allocation, 0.0)
    if names not in ([], [RESIDUAL_WRAPPER], [HISTORY_WRAPPER], [RESIDUAL_WRAPPER, HISTORY_WRAPPER]):
        # train.py rebuilds the agent's view at evaluation (sma_gym_agents.trained.AgentPolicy), which
        # knows these two features in this order only.
        raise ValueError(
            f"vec_env_wrapper {names}: train.py knows {RESIDUAL_WRAPPER} then {HISTORY_WRAPPER}, each optional"
        )
    kwargs = dict(parsed)
    residual = kwargs.get(RESIDUAL_WRAPPER)
    if residual is not None and set(residual) - {"base", "scale", "filter_s"}:
        raise ValueError(f"{RESIDUAL_WRAPPER} {residual}: expected the keyword arguments base, scale and filter_s")
    history = kwargs.get(HISTORY_WRAPPER)
    if history and (set(history) - {"error_features"} or not isinstance(history.get("error_features"), bool)):
        raise ValueError(f"{HISTORY_WRAPPER} {history}: expected no keyword arguments or error_features: true/false")
    if residual is not None and "base" not in residual:
        raise ValueError(f"{RESIDUAL_WRAPPER}: expected a base controller (base: VSC3 + FF)")
    return AgentFeatures(
        "none" if HISTORY_WRAPPER not in kwargs else "ema+error" if (history or {}).get("error_features") else "ema",
        None if residual is None else str(residual["base"]),
        DEFAULT_RESIDUAL_SCALE if residual is None else float(residual.get("scale", DEFAULT_RESIDUAL_SCALE)),
        "proportional",
        0.0 if residual is None else float(residual.get("filter_s", 0.0)),
    )


def key_value_option(
    items: list[str] | None, option: str = "--env-kwargs", example: str = "n_actuators:16"
) -> dict[str, Any]:
    """``option key:value ...`` as a dict (values as Python literals where they parse, else
    strings); ``ValueError`` naming an item without a key."""
    out: dict[str, Any] = {}
    for item in items or []:
        key, sep, text = item.partition(":")
        if not sep or not key.isidentifier():
            raise ValueError(f"{option} {item!r}: expected KEY:VALUE, e.g. {example}")
        if key in out:  # the last one won, without a word
            raise ValueError(f"{option} {key}: given twice; expected each key once")
        try:
            out[key] = ast.literal_eval(text)
        except (SyntaxError, ValueError):
            out[key] = text
    return out


def env_kwargs_option(items: list[str] | None) -> dict[str, Any]:
    """``--env-kwargs key:value ...`` as a dict (:func:`key_value_option`)."""
    return key_value_option(items)


_OWN_OPTIONS = {"vec_env_wrapper": "--history and --residual", "env_kwargs": "--env-kwargs"}
"""Run keys of the file that ``--hyperparams`` leaves to another option (the algorithm's
keywords that train.py sets are :data:`~sma_gym_agents.training.keywords.OWN_KEYWORDS`)."""


def hyperparams_option(items: list[str] | None) -> dict[str, Any]:
    """``--hyperparams key:value ...`` (RL Zoo's option): entries of the file's table to replace
    or add; ``ValueError`` naming a key another option sets. The algorithm's keywords are
    checked with the file's (:func:`~sma_gym_agents.training.keywords.check_model_kwargs`)."""
    out = key_value_option(items, "--hyperparams", "learning_rate:1e-3 gamma:0.999")
    for key in out:
        if key in _OWN_OPTIONS:
            raise ValueError(f"--hyperparams {key}: set it with {_OWN_OPTIONS[key]}")
    return out


def build_parser() -> argparse.ArgumentParser:
    """``train.py``'s command line."""
    p = argparse.ArgumentParser(
        prog="train.py", description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument(
        "--env",
        default="SMATracking-v0",
        type=lambda text: text.removeprefix("sma_gym:"),  # env.spec.id's form is the same id
        help="env id, with or without the 'sma_gym:' of env.spec.id (default SMATracking-v0)",
    )
    p.add_argument(
        "--algo",
        choices=ALGOS,
        default=DEFAULT_ALGO,
        help=f"algorithm: reads hyperparams/<algo>.yml (default {DEFAULT_ALGO})",
    )
    p.add_argument("--timesteps", type=int, help="total environment steps (default: from the hyperparameter file)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument(
        "--eval-freq",
        type=int,
        help=f"environment steps (over all envs) between validation evaluations (default {EVAL_FREQ['sac']} for SAC, "
        f"{EVAL_FREQ['ppo']} for PPO), as RL Zoo's --eval-freq",
    )
    p.add_argument(
        "--env-kwargs",
        nargs="+",
        metavar="KEY:VALUE",
        help="make kwargs merged over the file's env_kwargs (RL Zoo's --env-kwargs replaces them instead; a value "
        "is read as a Python literal, else as a string), e.g. n_actuators:16 scheme:shared_budget",
    )
    p.add_argument(
        "--hyperparams",
        nargs="+",
        metavar="KEY:VALUE",
        help="entries over the file's, as RL Zoo's --hyperparams (values read as --env-kwargs's), e.g. "
        "gamma:0.999 learning_rate:1e-3; recorded in run.json",
    )
    p.add_argument("--n-envs", type=int, help="parallel envs in the native vector env (default: from the file)")
    p.add_argument(
        "--frame-stack", type=int, help="observations stacked as the agent's history (default: from the file)"
    )
    p.add_argument("--history", choices=HISTORIES, help="history features (agents/history.py; default: from the file)")
    p.add_argument(
        "--residual", help="base controller the agent corrects, e.g. 'VSC3 + FF', or 'none' (default: from the file)"
    )
    p.add_argument(
        "--out", help="run folder (default runs/<env>-<algo>-<time>); must be new or empty unless --overwrite"
    )
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="allow a non-empty --out: the previous run's outputs there are replaced (a single run puts them back if "
        "it is refused or stopped before its first checkpoint, and keeps them in .previous-run if stopped later; "
        "a sweep, if it is stopped before any seed kept a file) "
        "(default: refuse a non-empty --out)",
    )
    p.add_argument("--device", default="cpu", help="torch device, e.g. cpu, cuda, cuda:1, mps (default cpu)")
    p.add_argument(
        "--quick",
        action="store_true",
        help=f"tiny budget ({QUICK_TIMESTEPS} steps, rounded up to whole steps of all --n-envs envs and, for PPO, to "
        "whole rollouts: 2048 with the file's settings) and a short evaluation, for smoke tests",
    )
    p.add_argument(
        "--threads",
        type=int,
        default=1,
        help="torch intra-op threads (default 1: SAC's small networks gain nothing from more, and torch's default "
        "pool of every core thrashes when anything else runs on the machine)",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar or progress lines")
    p.add_argument(
        "--seeds",
        type=int,
        help="train N seeds (--seed .. --seed+N-1) of this configuration in parallel processes, each in <out>/seed-<s>/, "
        "and write every goal over the seeds (interquartile mean, 95 %% bootstrap interval) to <out>/seeds.md and seeds.json",
    )
    p.add_argument(
        "--workers", type=int, help="with --seeds: runs at a time (default min(N, the cores this process may run on))"
    )
    p.add_argument(
        "--resume",
        action="store_true",
        help="with --seeds: continue a sweep in its --out folder: seeds that finished there with this same "
        "configuration are kept, the others (never started, interrupted or failed) are run again; the table is over "
        "all N seeds",
    )
    return p


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    return build_parser().parse_args(argv)


@dataclass(frozen=True)
class RunConfig:
    """Everything a training run is made of; written to ``run.json`` in this field order."""

    env_id: str
    algo: str
    """Lower-case algorithm, one of :data:`ALGOS`."""
    timesteps: int
    n_envs: int
    frame_stack: int
    history: str
    """One of :data:`sma_gym_agents.history.HISTORIES` (:mod:`sma_gym_agents.history`)."""
    residual: str | None
    """Label of the controller the agent corrects (:mod:`sma_gym_agents.residual`), or None."""
    residual_scale: float
    """Largest correction, as a fraction of full duty."""
    eval_freq: int
    """Environment steps between validation evaluations (over all envs)."""
    env_kwargs: dict[str, Any]
    seed: int
    device: str
    threads: int
    """torch intra-op threads."""
    quick: bool
    residual_allocation: str = "proportional"
    """How a residual bank agent's base grants an overrun shared budget (:data:`ALLOCATIONS`)."""
    residual_filter_s: float = 0.0
    """Time constant of the low-pass the residual's correction passes [s] (0: none)."""
    model_kwargs: dict[str, Any] = field(default_factory=dict)
    """Keyword arguments of the stable-baselines3 algorithm (``policy`` included if set)."""

    @classmethod
    def from_args(cls, args: argparse.Namespace) -> RunConfig:
        """The hyperparameter file's entry for the env, overridden by the options, checked."""
        if args.env in NOT_FOR_TRAIN_PY:
            raise ValueError(f"--env {args.env}: {NOT_FOR_TRAIN_PY[args.env]}")
        algo = args.algo or DEFAULT_ALGO
        overrides = hyperparams_option(args.hyperparams)
        table = {**load_hyperparams(args.env, algo), **overrides}
        entry = f"{hyperparams_path(algo).name} [{args.env}]"

        def source(key: str) -> str:  # where a key's value came from, for its error
            return f"--hyperparams {key}" if key in overrides else entry

        refused = sorted(set(table) & set(ZOO_ONLY_KEYS))
        if refused:
            raise ValueError(f"{source(refused[0])}: train.py does not implement {refused} (RL Zoo does)")
        for key in ("n_timesteps", "n_envs", "frame_stack"):
            # int() made 1.5 one step and 2.7 two envs without a word, and "abc" an unnamed error.
            if key in table and not is_count(table[key], 1):
                raise ValueError(
                    f"{source(key)}: {key} = {table[key]!r}: expected an integer >= 1{text_number_hint(table[key])}"
                )
        env_kwargs = table.get("env_kwargs", {})
        if not isinstance(env_kwargs, dict):
            raise ValueError(f"{entry}: env_kwargs = {env_kwargs!r}: expected a mapping of env arguments")
        if "n_timesteps" not in table and args.timesteps is None:
            raise ValueError(f"{entry}: no n_timesteps; give it there or with --timesteps")
        model_kwargs = {k: v for k, v in table.items() if k not in RUN_KEYS}
        if "policy_kwargs" in model_kwargs:
            model_kwargs["policy_kwargs"] = literal_kwargs(
                model_kwargs["policy_kwargs"], f"{source('policy_kwargs')}: policy_kwargs"
            )
        model_kwargs = check_model_kwargs(model_kwargs, algo, source)
        features = agent_features(table.get("vec_env_wrapper"))
        if (args.env == BANK_ENV) != (BANK_WRAPPER in str(table.get("vec_env_wrapper"))):
            raise ValueError(
                f"{hyperparams_path(algo).name} [{args.env}]: {BANK_ENV} trains through vec_env_wrapper "
                f"{BANK_WRAPPER} (one policy for every actuator), and only it does"
            )
        timesteps = int(table["n_timesteps"] if args.timesteps is None else args.timesteps)
        eval_freq = EVAL_FREQ[algo] if args.eval_freq is None else args.eval_freq
        if args.quick:
            quick_kwargs = (
                {"learning_starts": 200, "buffer_size": 10_000} if algo == "sac" else {"n_steps": 64, "batch_size": 64}
            )
            given = [
                f"{o} {v}"
                for o, v in (("--timesteps", args.timesteps), ("--eval-freq", args.eval_freq))
                if v is not None
            ] + [f"--hyperparams {k}" for k in overrides if k in quick_kwargs]
            if given:
                raise ValueError(
                    f"--quick with {' and '.join(given)}: --quick sets {QUICK_TIMESTEPS} steps, an evaluation every "
                    f"500 and {', '.join(f'{k} {v}' for k, v in quick_kwargs.items())}; give either --quick or those"
                )
            timesteps, eval_freq = QUICK_TIMESTEPS, 500
            model_kwargs.update(quick_kwargs)
        if args.residual is not None and not args.residual.strip():
            # '' was read as "not given": the file's base controller, without a word.
            raise ValueError(f"--residual {args.residual!r}: expected 'none' or a controller's label")
        residual = (None if args.residual == "none" else args.residual) if args.residual else features.residual
        run = cls(
            env_id=args.env,
            algo=algo,
            timesteps=timesteps,
            n_envs=int(table.get("n_envs", 1) if args.n_envs is None else args.n_envs),
            frame_stack=int(table.get("frame_stack", 1) if args.frame_stack is None else args.frame_stack),
            history=args.history or features.history,
            residual=residual,
            residual_scale=features.residual_scale,
            eval_freq=eval_freq,
            env_kwargs={**env_kwargs, **env_kwargs_option(args.env_kwargs)},
            seed=args.seed,
            device=args.device,
            threads=args.threads,
            quick=args.quick,
            model_kwargs=model_kwargs,
            residual_allocation=features.residual_allocation,
            residual_filter_s=features.residual_filter_s if residual is not None else 0.0,
        )
        run = run.checked()
        check_env_kwargs(run.env_id, run.env_kwargs)
        return run

    def checked(self) -> RunConfig:
        """This configuration with the device and residual label checked (and the label
        normalised); ``ValueError`` naming the option otherwise."""
        if not 0 <= self.seed <= MAX_SEED:
            raise ValueError(
                f"--seed {self.seed}: expected an integer in [0, {MAX_SEED}] (numpy's and torch's seeds are 32-bit unsigned)"
            )
        check_device(self.device)
        for name in ("timesteps", "n_envs", "frame_stack", "threads", "eval_freq"):
            if getattr(self, name) < 1:
                raise ValueError(f"--{name.replace('_', '-')} = {getattr(self, name)}: expected an integer >= 1")
        freq = self.model_kwargs.get("train_freq")
        if isinstance(freq, tuple) and freq[1] == "episode" and self.n_envs > 1:
            # SB3 refuses it at its first rollout, after the run folder exists.
            raise ValueError(
                f"train_freq = {list(freq)} with {self.n_envs} envs: SB3 trains per episode with one env only; "
                "expected --n-envs 1, or train_freq in steps"
            )
        if self.frame_stack > 1 and (self.history != "none" or self.residual is not None):
            # The evaluation harness stacks raw env observations; stacking on top of history
            # features or a residual base would be seen differently in training and evaluation.
            raise ValueError(
                f"--frame-stack {self.frame_stack} with history or residual: expected --frame-stack 1, or --history none --residual none"
            )
        if self.env_id == BANK_ENV and (self.history != "none" or self.frame_stack > 1):
            # The per-actuator view (sma_gym_agents.bank.BankView, with the residual's base
            # share) is the bank agent's only feature.
            raise ValueError(
                f"--env {BANK_ENV} with history {self.history!r}, frame stack {self.frame_stack}: "
                "expected --history none --frame-stack 1"
            )
        if self.history not in HISTORIES:
            raise ValueError(f"history = {self.history!r}: expected one of {HISTORIES}")
        if self.history == "ema+error":
            # Built once here, so an env without a position sensor is refused before a run
            # folder or run.json exists.
            HistoryFeatures.for_env(1, self.env_id, self.env_kwargs, self.history)
        residual = self.residual
        if residual is not None:
            try:
                residual = spec_by_label(residual).label
            except ValueError as err:
                raise ValueError(
                    f"--residual {residual!r}: expected 'none' or one of {[c.label for c in ALL_SPECS]}"
                ) from err
        if not 0.0 < self.residual_scale <= 1.0:
            raise ValueError(f"residual_scale = {self.residual_scale}: expected a fraction of full duty in (0, 1]")
        if not is_filter_time_constant(self.residual_filter_s):
            raise ValueError(f"residual filter_s = {self.residual_filter_s}: expected {FILTER_S_EXPECTED}")
        if self.residual_allocation not in ALLOCATIONS:
            raise ValueError(f"residual_allocation = {self.residual_allocation!r}: expected one of {ALLOCATIONS}")
        return self if residual == self.residual else replace(self, residual=residual)

    def as_dict(self) -> dict[str, Any]:
        """The fields as ``run.json`` records them."""
        return asdict(self)

    def card(self, name: str, **progress: Any) -> PolicyCard:
        """The card of a model of this run (``progress``: timesteps, train_time_s, validation_return)."""
        return PolicyCard(
            algo=self.algo.upper(),
            name=name,
            env_id=self.env_id,
            env_kwargs=self.env_kwargs,
            frame_stack=self.frame_stack,
            history=self.history,
            residual=self.residual,
            residual_scale=self.residual_scale,
            residual_filter_s=self.residual_filter_s,
            residual_allocation=self.residual_allocation,
            seed=self.seed,
            **progress,
        )

    @property
    def agent_name(self) -> str:
        """The name of the run's best model in tables (``"SAC agent"``)."""
        return f"{self.algo.upper()} agent"


def check_env_kwargs(env_id: str, env_kwargs: dict[str, Any]) -> None:
    """Build the env once with ``env_kwargs``, so that a value it refuses is reported before
    a run folder exists (and before a sweep starts its seeds)."""
    import gymnasium as gym

    try:
        gym.make("sma_gym:" + env_id, **env_kwargs).close()
    except (TypeError, ValueError) as err:
        raise ValueError(f"--env-kwargs / env_kwargs of {env_id}: {err}") from None


def check_device(device: str) -> str:
    """``device`` if torch can train on it here, else a ``ValueError`` naming it."""
    import torch

    try:
        parsed = torch.device(device)
    except (RuntimeError, TypeError) as err:
        raise ValueError(
            f"--device {device!r}: not a torch device ({err}); expected e.g. cpu, cuda, cuda:0, mps"
        ) from None
    available = {
        "cpu": lambda: True,
        "cuda": lambda: (
            torch.cuda.is_available() and (parsed.index is None or parsed.index < torch.cuda.device_count())
        ),
        "mps": lambda: bool(getattr(torch.backends, "mps", None)) and torch.backends.mps.is_available(),
    }
    if parsed.type not in available:
        raise ValueError(f"--device {device!r}: expected cpu, cuda[:N] or mps")
    if not available[parsed.type]():
        raise ValueError(f"--device {device!r}: not available on this machine (use --device cpu)")
    return device


RUN_OUTPUTS = (
    "run.json",
    "results.md",
    "goals.json",
    "best_model.zip",
    f"best_model{CARD_SUFFIX}",
    "final_model.zip",
    f"final_model{CARD_SUFFIX}",
    "checkpoints",
    "evaluation",
    "validation",
    "tb",
)
"""What a run writes into its folder: what ``--overwrite`` replaces (:func:`set_aside_outputs`), and nothing else."""


MAX_SEED = 2**32 - 1
"""Largest ``--seed`` (numpy's and torch's seeds are 32-bit unsigned)."""


SWEEP_OUTPUTS = ("seeds.md", "seeds.json", "logs")
"""What a sweep writes besides its ``seed-<s>`` folders (what ``--overwrite`` replaces)."""


def sweep_paths(out: Path) -> list[Path]:
    """A sweep's outputs in ``out``: :data:`SWEEP_OUTPUTS` and its ``seed-<s>`` folders."""
    import re

    named = [out / name for name in SWEEP_OUTPUTS if (out / name).exists() or (out / name).is_symlink()]
    return named + sorted(p for p in out.glob("seed-*") if re.fullmatch(r"seed-\d+", p.name))


def require_no_outputs_of(out: Path, kind: str, paths: Sequence[Path], instead: str) -> None:
    """``--overwrite`` replaces a run's outputs of its own kind only: refuse an ``out`` that
    holds ``kind``'s (``paths`` that exist), which would stay beside the new ones, mixed."""
    present = [p.name for p in paths if p.exists() or p.is_symlink()]
    if present:
        shown = ", ".join(present[:5]) + (", ..." if len(present) > 5 else "")
        raise ValueError(
            f"--overwrite: {out} holds {kind}'s outputs ({shown}), which this run would leave beside its own; "
            f"give {instead}, or move them away first"
        )


PREVIOUS_RUN_DIR = ".previous-run"
"""Where ``--overwrite`` keeps the earlier run's outputs (inside ``--out``) until the new run
has trained: a run refused or stopped before its first checkpoint puts them back; one stopped
later leaves them there (the stop's message names it) until the next ``--overwrite``."""


def set_aside_outputs(out: Path) -> Path:
    """Move a previous run's outputs in ``out`` into :data:`PREVIOUS_RUN_DIR` (``--overwrite``)
    and return that folder: gone from ``out``, so none is mistaken for this run's, but not
    yet deleted."""
    import shutil

    aside = out / PREVIOUS_RUN_DIR
    if aside.exists():  # left by a process killed outright: older than the run in out
        shutil.rmtree(aside)
    aside.mkdir()
    for name in RUN_OUTPUTS:
        path = out / name
        if path.exists() or path.is_symlink():
            path.rename(aside / name)
    return aside


def put_back_outputs(aside: Path, out: Path) -> None:
    """Undo :func:`set_aside_outputs`: the previous run's outputs back in ``out``."""
    for path in aside.iterdir():
        path.rename(out / path.name)
    aside.rmdir()


def prepare_out(out: Path) -> None:
    """Delete a previous run's outputs from ``out`` (``--overwrite``), so none is mistaken for this run's."""
    import shutil

    for name in RUN_OUTPUTS:
        path = out / name
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path)
        elif path.exists() or path.is_symlink():
            path.unlink()

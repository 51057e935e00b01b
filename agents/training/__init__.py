"""Train a stable-baselines3 agent on an sma-gym env and compare it with the report's controllers.

    python train.py                        # the default: SMATracking-v0, algorithm from hyperparams/
    python train.py --env SMARobust-v0 --algo ppo --timesteps 500000 --n-envs 16 --out runs/robust
    python train.py --quick                # tiny budget, for smoke tests
    python train.py --seeds 5 --workers 2  # five seeds in parallel, goals over seeds (seeds.md)
    python train.py --seeds 5 --resume --out runs/s  # go on with a sweep cut short

``train.py`` (at the top of the repository) is a shell over this package:

* :mod:`sma_gym_agents.training.config`: :class:`RunConfig`, the frozen run configuration, from
  ``hyperparams/<algo>.yml`` (RL Zoo's format, which the zoo reads too) overridden by the
  command line, every value checked before anything is created;
* :mod:`sma_gym_agents.training.keywords`: every keyword of stable-baselines3's SAC and PPO
  (and of their policy) that a hyperparameter file may set, each with its check;
* :mod:`sma_gym_agents.training.envs`: what the agent sees and does (residual base controller,
  history features, frame stack) in training and on the validation references;
* :mod:`sma_gym_agents.training.learn`: the stable-baselines3 loop, checkpoints, best model, progress;
* :mod:`sma_gym_agents.training.compare`: the agent beside the report's controllers, and the goals;
* :mod:`sma_gym_agents.training.run`: one run into its folder (train, compare, write the results);
* :mod:`sma_gym_agents.training.cli`: ``main(argv)``, what ``train.py`` runs.
* :mod:`sma_gym_agents.training.sweep`: ``train.py --seeds N``, the same configuration over seeds in
  parallel processes, every goal as an interquartile mean with a bootstrap interval.

By default the agent is a residual on the report's controller (``agents/residual.py``: it
corrects VSC3 + FF's duty, or the self-sensing PID's without a position sensor) and sees
history features (``agents/history.py``: averages of its duty and the position over the
wire's thermal time constants); docs/training.md gives the measurements behind these
choices. The run folder (named at the end) gets:

* ``best_model.zip`` (best on held-out validation references, by a periodic evaluation),
  ``final_model.zip`` and ``checkpoints/``: ordinary stable-baselines3 zips that
  ``SAC.load`` / ``PPO.load`` open, each with a ``.json`` card (:class:`sma_gym_agents.card.PolicyCard`:
  env id and kwargs, history, residual base, frame stack; for the best model the step and
  validation return it was chosen at) that ``sma-gym evaluate --policy`` and
  :func:`sma_gym_agents.trained.load_policy` read;
* ``results.md``: the agent beside the report's controllers (all ten of Table 6.1 on the
  tracking env; PID and VSC3 + FF with and without a sensor on the self-sensing env; PID,
  VSC3, VSC3 + FF, PID + FF over the chapter-7 conditions on the robustness env) on
  references it never trained on (the report's 8 mm step and 0.1 Hz sine), goals checked
  (:data:`sma_gym_agents.training.compare.GOALS`); ``evaluation/``: the harness's tables and plots;
* ``tb/``: TensorBoard logs (``tensorboard --logdir <folder>/tb``).

A run never mixes its files with another run's: a non-empty ``--out`` is refused unless
``--overwrite`` is given (then the previous run's outputs are set aside, put back if the new
run is refused or stopped before its first checkpoint, left set aside in ``.previous-run`` if it is
stopped later, deleted once it has trained; a sweep sets the earlier sweep aside and puts it back if
it is stopped before any seed kept a file), a folder
another run is writing to is refused (``.sma-gym.lock``), every file is written atomically,
and each card records the SHA-256 of its zip (a card that does not match is refused).

The validation references used to pick the best model are drawn from the training
distribution with seeds the training never uses; the final comparison uses the report's
references, which the training distribution never produces exactly.
"""

from sma_gym_agents.training.cli import main
from sma_gym_agents.training.config import RunConfig, parse_args, prepare_out

__all__ = ["RunConfig", "main", "parse_args", "prepare_out"]

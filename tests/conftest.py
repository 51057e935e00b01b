"""Test-wide settings.

Property tests (hypothesis) draw the same examples on every run by default, so CI on a
clean clone gives the same verdict as the developer's machine: a random draw that fails
once in twenty runs would otherwise block a change that did not cause it. To search for
new failures, draw fresh examples with the ``explore`` profile (each run draws others):

    python -m pytest tests/test_properties.py --hypothesis-profile=explore

and turn any failure it finds into a fix and, where it names a case worth keeping, an
``@example`` on the test.
"""

import os

# The README's command runs two pytest-xdist workers on two cores. torch's and OpenBLAS's
# default pools start a thread per core in each worker, four on two cores, and a pool that
# spins while another holds the core thrashes. One thread each, unless the caller set it
# (before numpy or torch is imported, which read these once).
for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import pytest  # noqa: E402
from hypothesis import HealthCheck, settings  # noqa: E402

settings.register_profile("deterministic", derandomize=True, print_blob=True)
settings.register_profile("explore", derandomize=False, print_blob=True, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("deterministic")


@pytest.fixture(autouse=True, scope="session")
def _sb3_logs_in_pytest_tmp(tmp_path_factory: pytest.TempPathFactory):
    """Keep stable-baselines3's log folders out of the machine's temp directory.

    Every ``learn()`` without a logger of its own makes an empty ``SB3-<date>`` folder in
    the system's temp directory (``stable_baselines3.common.logger.configure``), and nothing
    removes it: a test run left four behind each time. ``$SB3_LOGDIR`` moves them into
    pytest's own temp tree, which pytest cleans up."""
    before = os.environ.get("SB3_LOGDIR")
    os.environ["SB3_LOGDIR"] = str(tmp_path_factory.mktemp("sb3-logs"))
    yield
    if before is None:
        os.environ.pop("SB3_LOGDIR", None)
    else:
        os.environ["SB3_LOGDIR"] = before

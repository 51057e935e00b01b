"""Test-wide settings.

Property tests (hypothesis) draw the same examples on every run by default, so CI on a
clean clone gives the same verdict as the developer's machine: a random draw that fails
once in twenty runs would otherwise block a change that did not cause it. To search for
new failures, draw fresh examples with the ``explore`` profile (each run draws others):

    python -m pytest tests/test_properties.py --hypothesis-profile=explore

and turn any failure it finds into a fix and, where it names a case worth keeping, an
``@example`` on the test.
"""

from hypothesis import HealthCheck, settings

settings.register_profile("deterministic", derandomize=True, print_blob=True)
settings.register_profile("explore", derandomize=False, print_blob=True, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("deterministic")

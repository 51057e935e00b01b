"""Diagnose what the model is missing from measured traces (``sma-gym diagnose``), and make
traces in which an effect is hidden (``sma-gym synth``)."""

from sma_gym.diagnosis.workflow import Diagnosis, diagnose

__all__ = ["Diagnosis", "diagnose"]

"""Measured data: the file format and its loader (see :mod:`sma_gym.data.measured`)."""

from sma_gym.data.measured import (
    REAL_BENCH_RUNS,
    MeasuredDataError,
    MeasuredTrace,
    find_real_data_dir,
    load_trace,
    load_traces,
    real_bench_folder,
    write_trace,
)

__all__ = [
    "REAL_BENCH_RUNS",
    "MeasuredDataError",
    "MeasuredTrace",
    "find_real_data_dir",
    "load_trace",
    "load_traces",
    "real_bench_folder",
    "write_trace",
]

"""The measured-data format: loading, validation messages, and never touching the input."""

import hashlib
import json

import numpy as np
import pytest

from sma_gym.data import MeasuredDataError, find_real_data_dir, load_trace, load_traces, write_trace
from sma_gym.data.measured import MeasuredTrace


def write(path, text):
    path.write_text(text)
    return path


def digest(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_a_valid_file_with_sidecar_loads(tmp_path):
    f = write(tmp_path / "ok.csv", "t,duty,position,resistance\n0,0,0,\n0.001,0.5,1e-5,3.7\n0.002,0.5,2e-5,3.69\n")
    write(tmp_path / "ok.csv.json", json.dumps({"supply_voltage_v": 10, "wire_diameter_m": 3e-4}))
    before = digest(f)
    trace = load_trace(f)
    assert trace.conditions == {"supply_voltage_v": 10.0, "wire_diameter_m": 3e-4}
    assert np.isnan(trace.resistance[0]) and trace.resistance[1] == 3.7
    assert set(trace.outputs()) == {"position", "resistance"}
    assert digest(f) == before


def test_diagnose_says_which_conditions_no_sidecar_gives_and_what_it_assumes(tmp_path, capsys):
    """A 24 V bench diagnosed without its sidecar was diagnosed at the model's 10 V without a
    word (found by a new user): the command names each condition it takes from the model."""
    from sma_gym.cli import main
    from sma_gym.data.measured import SIDECAR_KEYS
    from sma_gym.diagnosis.fitting import assumed_conditions
    from sma_gym.diagnosis.synth import SynthSpec
    from sma_gym.diagnosis.synth import write as write_synth
    from sma_gym.model import ModelConfig, load_model

    bench = load_model("bench-0.5mm-ht-datasheet")
    bare = MeasuredTrace(path="x.csv", t=0.01 * np.arange(3.0), duty=np.zeros(3), position=np.zeros(3))
    assert assumed_conditions(bench, bare) == {
        "supply_voltage_v": bench.actuator.driver.supply_voltage_v,
        "wire_diameter_m": bench.actuator.wire.diameter_m,
        "pwm_frequency_hz": bench.actuator.driver.pwm_frequency_hz,
        "ambient_temperature_c": bench.actuator.convection.ambient_temperature_c,
    }
    given = dict(bare.__dict__, conditions={"supply_voltage_v": 24.0, "wire_diameter_m": 5e-4})
    assert set(assumed_conditions(bench, MeasuredTrace(**given))) == {"pwm_frequency_hz", "ambient_temperature_c"}

    path, _ = write_synth(SynthSpec(ModelConfig(), excitation="steps", duration_s=2.0, seed=1), tmp_path / "run.csv")
    (tmp_path / "run.csv.json").unlink()
    bare_run, _ = write_synth(
        SynthSpec(ModelConfig(), excitation="steps", duration_s=2.0, seed=2), tmp_path / "bare.csv"
    )
    (tmp_path / "bare.csv.json").unlink()
    # An unknown effect stops the command once the files and the model are read.
    args = ["diagnose", str(path), str(bare_run), "--model", "bench-0.5mm-ht-datasheet", "--effects", "warp"]
    assert main([*args, "--out", str(tmp_path / "d")]) == 2
    notes = [line for line in capsys.readouterr().err.splitlines() if "taken from the model" in line]
    assert len(notes) == 1 and "run.csv, bare.csv" in notes[0] and "'bench-0.5mm-ht-datasheet'" in notes[0]
    assert f"supply_voltage_v = {bench.actuator.driver.supply_voltage_v:g}" in notes[0]
    every = {
        "supply_voltage_v": 24.0,
        "wire_diameter_m": 5e-4,
        "pwm_frequency_hz": 1000.0,
        "ambient_temperature_c": 20.0,
    }
    assert set(every) == set(SIDECAR_KEYS)
    (tmp_path / "run.csv.json").write_text(json.dumps(every))
    assert main([*args[:2], *args[3:], "--out", str(tmp_path / "d")]) == 2
    assert "taken from the model" not in capsys.readouterr().err


def test_every_problem_is_reported_with_file_row_and_column(tmp_path):
    f = write(
        tmp_path / "bad.csv",
        "t,duty,position\n0,0,0\n0.001,1.5,0\n0.001,0.2,0\n0.003,,0\n0.004,0.1,nan\n",
    )
    before = digest(f)
    with pytest.raises(MeasuredDataError) as err:
        load_trace(f)
    text = str(err.value)
    assert f"{f}:3:duty: 1.5 outside [0, 1]" in text
    assert f"{f}:4:t:" in text and "does not increase" in text
    assert f"{f}:5:duty: missing" in text
    assert f"{f}:6:position: missing" in text
    assert len(err.value.problems) == 4
    assert digest(f) == before


def test_a_malformed_row_or_cell_is_named_once(tmp_path):
    """A row with a wrong field count, or a cell that is no number, is one problem: it is
    not reported again as missing values it never had."""
    f = write(tmp_path / "rows.csv", "t,duty,position\n0,0,0\n0.001,0,0,7\n0.002,abc,0\n0.003,0.1,0\n")
    with pytest.raises(MeasuredDataError) as err:
        load_trace(f)
    assert err.value.problems == [f"{f}:3: 4 fields, expected 3", f"{f}:4:duty: 'abc' is not a number"]


@pytest.mark.parametrize(
    "text, needle",
    [
        ("t,position\n0,0\n1,0\n", "missing required column"),
        ("t,duty,position\n0,0,5\n0.001,0,6\n", "millimetres"),
        ("t,duty,position\n0,0,5000\n0.001,0,6000\n", "micrometres"),
        ("t,duty,position\n0,0,0\n1,0,0\n2,0,0\n", "milliseconds"),
        ("t,duty,position,speed\n0,0,0,1\n0.001,0,0,1\n", "unknown column"),
        ("t;duty;position\n0;0;0\n0.001;0;0\n", "one column separated by ';'; expected commas"),
        ("t\tduty\tposition\n0\t0\t0\n0.001\t0\t0\n", "separated by '\\\\t'"),
        ("t,duty,position\n0,50,0\n0.001,50,0\n", "a percentage?"),
        ("", "empty file"),
        ("t,duty,position\n0,0,0\n", "at least 2"),
        ("t,duty,position\n0,0,x\n0.001,0,0\n", "'x' is not a number"),
        (  # the message said "expected ohm" for a value that was in ohm
            "t,duty,position,resistance\n0,0.2,0,4\n0.001,0.2,0,-3\n",
            r"f.csv:3:resistance: -3 ohm \(1 row outside the range\); expected values in \(0, 1000\] ohm",
        ),
        # A logger's fill value: a wire always has a resistance.
        ("t,duty,position,resistance\n0,0.2,0,4\n0.001,0.2,0,0\n", r"f.csv:3:resistance: 0 ohm"),
        # A reading where the wire was not driven: the model has none to compare it with.
        (
            "t,duty,position,current\n0,0.2,0,0.5\n0.001,0,0,0.003\n",
            "f.csv:3:current: 0.003 where the duty is 0 .1 row.; this column holds readings during a PWM pulse",
        ),
        # The supply's voltage logged as a column was compared with the wire's.
        ("t,duty,position,supply_voltage\n0,0.2,0,10\n0.001,0,0,10\n", "the column wire_voltage .* supply_voltage_v"),
        # A pandas index (to_csv's default) or a trailing comma.
        (",t,duty,position\n0,0,0,0\n1,0.001,0,0\n", "f.csv:1: column 1 has no name .a pandas index"),
        # An oscilloscope's one row per channel.
        ("t,0,0.001,0.002\nduty,0,0,0\nposition,0,0,0\n", "is the file transposed"),
        ("t,duty,position\n0,0,0\n0.001,\uff10.5,0\n", "'\uff10.5' is not a number"),  # a full-width 0
    ],
)
def test_unit_slips_and_malformed_files_are_named(tmp_path, text, needle):
    f = write(tmp_path / "f.csv", text)
    with pytest.raises(MeasuredDataError, match=needle):
        load_trace(f)


def test_bad_sidecars_are_reported(tmp_path):
    f = write(tmp_path / "s.csv", "t,duty,position\n0,0,0\n0.001,0,0\n")
    write(tmp_path / "s.csv.json", json.dumps({"supply_voltage_v": -3, "colour": "blue"}))
    with pytest.raises(MeasuredDataError) as err:
        load_trace(f)
    assert "supply_voltage_v" in str(err.value) and "colour" in str(err.value)


def test_several_files_report_all_their_problems(tmp_path):
    a = write(tmp_path / "a.csv", "t,duty,position\n0,2,0\n0.001,0,0\n")
    b = write(tmp_path / "b.csv", "t,duty\n0,0\n")
    with pytest.raises(MeasuredDataError) as err:
        load_traces([a, b, tmp_path / "missing.csv"])
    text = str(err.value)
    assert "a.csv:2:duty" in text and "b.csv:1:position" in text and "missing.csv: file does not exist" in text


def test_write_then_load_round_trips_and_refuses_to_overwrite(tmp_path):
    trace = MeasuredTrace(
        path="x",
        t=np.arange(5) * 1e-3,
        duty=np.array([0, 0.1, 0.2, 0.3, 0.4]),
        position=np.arange(5) * 1e-5,
        resistance=np.array([np.nan, 3.7, 3.6, np.nan, 3.5]),
        conditions={"supply_voltage_v": 10.0},
    )
    path = write_trace(tmp_path / "w.csv", trace)
    back = load_trace(path)
    assert np.array_equal(back.position, trace.position)
    assert np.array_equal(back.resistance, trace.resistance, equal_nan=True)
    assert back.conditions == {"supply_voltage_v": 10.0}
    with pytest.raises(FileExistsError):
        write_trace(path, trace)


def test_zero_order_hold_resampling_to_control_steps():
    trace = MeasuredTrace(
        path="x", t=np.array([0.0, 0.01, 0.02, 0.03]), duty=np.array([0.0, 0.5, 1.0, 1.0]), position=np.zeros(4)
    )
    ends, duty = trace.duty_at_control_steps(0.005)
    assert np.allclose(ends, [0.005, 0.01, 0.015, 0.02, 0.025, 0.03])
    assert np.allclose(duty, [0.0, 0.0, 0.5, 0.5, 1.0, 1.0])


def test_a_control_step_spanning_rows_gets_their_time_weighted_mean_duty():
    """A 2 kHz controller's alternating commands replayed at 1 kHz deliver their mean, not
    the one at each step's start; a jittered row boundary inside a step blends the two rows."""
    t = np.arange(40) * 5e-4
    fast = MeasuredTrace(path="x", t=t, duty=np.where(np.arange(40) % 2 == 0, 0.3, 0.0), position=np.zeros(40))
    assert np.allclose(fast.duty_at_control_steps(1e-3)[1], 0.15)
    jitter = MeasuredTrace(
        path="y", t=np.array([0.0, 0.0104, 0.02]), duty=np.array([0.0, 1.0, 0.5]), position=np.zeros(3)
    )
    ends, duty = jitter.duty_at_control_steps(1e-3)
    assert duty[9] == 0.0 and duty[10] == pytest.approx(0.6) and duty[11] == 1.0
    assert duty[-1] == 1.0  # the step ending at the last row is still the row before's hold


def test_the_real_bench_files_load_when_present():
    folder = find_real_data_dir()
    if folder is None:
        pytest.skip("../shared/data/real is not present on this machine")
    for name in ("step01.csv", "ramp01.csv"):
        trace = load_trace(folder / name)
        assert trace.duration_s == pytest.approx(49.99, abs=0.02)
        assert 0.015 < trace.position.max() < 0.018


def test_the_real_data_folder_can_be_named_wherever_it_is(tmp_path, monkeypatch):
    """A clone away from ``../shared`` found no real runs and said only that they were not in
    ``../shared/data/real`` (found by a new user); ``$SMA_GYM_REAL_DATA`` names the folder."""
    monkeypatch.setenv("SMA_GYM_REAL_DATA", str(tmp_path))
    assert find_real_data_dir() == tmp_path
    monkeypatch.setenv("SMA_GYM_REAL_DATA", str(tmp_path / "nowhere"))
    with pytest.raises(ValueError, match="SMA_GYM_REAL_DATA = .*nowhere.*expected a folder"):
        find_real_data_dir()


def test_a_file_with_too_few_rows_is_told_one_minimum(tmp_path):
    """A header-only file was told "expected at least 2" and the same file with two rows
    "expected at least 20": the minimum of the command that loads it, both times."""
    for text in ("t,duty,position\n", "t,duty,position\n0,0,0\n0.001,0,0\n"):
        f = write(tmp_path / "short.csv", text)
        with pytest.raises(MeasuredDataError, match="expected at least 20 "):
            load_trace(f, min_rows=20)
    with pytest.raises(MeasuredDataError, match=r"expected at least 2$"):
        load_trace(write(tmp_path / "empty.csv", "t,duty,position\n"))


def test_a_comment_line_is_named_as_one_not_as_missing_columns(tmp_path):
    f = write(tmp_path / "logger.csv", "# bench 3, 2025-01-01\nt,duty,position\n0,0,0\n0.001,0.5,1e-5\n")
    with pytest.raises(MeasuredDataError) as err:
        load_trace(f)
    assert "is a comment line; expected the header" in str(err.value) and "missing" not in str(err.value)


@pytest.mark.parametrize(
    "repeats, message",
    # Past about 9000 rows the swallowed field is longer than the csv module's 128 KiB limit.
    [
        (60, "a double quote opened on this line runs on to line 61"),
        (12000, "not readable as CSV"),
        # On the last line it swallowed the line's end: read as a number (or a field count).
        (5, "runs on to the end of the file"),
    ],
)
def test_a_stray_quote_is_named_with_its_row_not_swallowing_the_file_or_crashing_the_reader(tmp_path, repeats, message):
    """A quote left open made the rest of the file one field: a small file then lost its rows
    ("5 data rows, expected at least 20"), a large one crashed the reader (``_csv.Error``:
    field larger than field limit)."""
    rows = [f"{k * 0.01:.2f},0.1,{k * 1e-6:.6g}\n" for k in range(repeats)]
    rows[4] = '0.04,"0.1,4e-6\n'
    f = write(tmp_path / "quote.csv", "t,duty,position\n" + "".join(rows))
    before = digest(f)
    with pytest.raises(MeasuredDataError, match=r"quote\.csv:6: .*stray") as err:
        load_trace(f)
    assert message in str(err.value) and "expected one row per line" in str(err.value)
    assert digest(f) == before


@pytest.mark.skipif(not hasattr(__import__("os"), "mkfifo"), reason="no named pipes here")
def test_a_named_pipe_is_refused_not_waited_on(tmp_path):
    """Opening a named pipe blocks until something writes to it: the loaders hung for ever."""
    import os

    from sma_gym.model import load_model

    pipe = tmp_path / "pipe.csv"
    os.mkfifo(pipe)
    with pytest.raises(MeasuredDataError, match="pipe.csv.*named pipe, expected a file"):
        load_trace(pipe)
    with pytest.raises(ValueError, match="pipe.csv.*named pipe, expected a file"):
        load_model(str(pipe))


def test_small_format_slips_are_named_not_read_as_something_else(tmp_path):
    """Python's float reads "1_0e-6" as 1e-5; a sidecar's ``"notes": null`` became the
    text "None"; a model file's ``"version": true`` passed as version 1."""
    from sma_gym.model import load_model

    rows = "".join(f"{k * 0.001:.3f},0.1,{k * 1e-6:.6g}\n" for k in range(30))
    f = write(tmp_path / "u.csv", "t,duty,position\n" + rows.replace("0.002,0.1,2e-06", "0.002,0.1,2_0e-06"))
    with pytest.raises(MeasuredDataError, match=r"u\.csv:4:position: '2_0e-06' is not a number"):
        load_trace(f)
    g = write(tmp_path / "s.csv", "t,duty,position\n" + rows)
    write(tmp_path / "s.csv.json", json.dumps({"notes": None, "model": 5}))
    with pytest.raises(MeasuredDataError, match=r"notes = None: expected a string") as err:
        load_trace(g)
    assert "model = 5: expected a string" in str(err.value)
    model = tmp_path / "m.json"
    model.write_text(json.dumps({"format": "sma-gym-model", "version": True}))
    with pytest.raises(ValueError, match="'version' = True"):
        load_model(str(model))


def test_a_loggers_zeros_between_pulses_read_as_empty_and_header_problems_are_capped(tmp_path):
    """A logger that writes 0 A / 0 V / 0 ohm where the wire is not driven: each such cell
    was a reading the model cannot make, scored as a 10-sigma miss; and a header of 20 000
    unknown names gave a 3 MB message (each missing column repeated the whole header)."""
    f = write(
        tmp_path / "z.csv",
        "t,duty,position,resistance,current,wire_voltage\n0,0,0,0,0,0\n0.001,0.2,0,4.1,2.4,9.8\n0.002,0,0,0,0,0\n",
    )
    trace = load_trace(f)
    assert np.isnan(trace.resistance[[0, 2]]).all() and np.isnan(trace.current[[0, 2]]).all()
    assert np.isnan(trace.wire_voltage[[0, 2]]).all() and trace.wire_voltage[1] == 9.8
    wide = write(tmp_path / "w.csv", ",".join(f"c{k}" for k in range(20_000)) + "\n" + ",".join(["0"] * 20_000) + "\n")
    with pytest.raises(MeasuredDataError) as err:
        load_trace(wide)
    assert len(str(err.value)) < 5_000 and "more unknown columns" in str(err.value)


def test_a_trace_made_from_arrays_is_checked_as_a_file_is():
    """``MeasuredTrace`` is public and ``diagnose`` takes it, but arrays in millimetres or a
    reversed time were diagnosed (a verdict of 'unexplained'), and lists failed deep inside
    the fit; ``load_traces('run.csv')`` read each character as a file."""
    from sma_gym.data import load_traces

    t = 0.01 * np.arange(50)
    with pytest.raises(MeasuredDataError, match="expected metres"):
        MeasuredTrace("mm.csv", t, np.full(50, 0.2), np.linspace(0.0, 5.0, 50))
    with pytest.raises(MeasuredDataError, match="does not increase"):
        MeasuredTrace("back.csv", t[::-1], np.zeros(50), np.zeros(50))
    with pytest.raises(MeasuredDataError, match="lengths"):
        MeasuredTrace("short.csv", t, np.zeros(49), np.zeros(50))
    listed = MeasuredTrace("list.csv", list(t), [0.2] * 50, [0.0] * 50)
    assert listed.t.dtype == float and not listed.t.flags.writeable
    zeros = MeasuredTrace("z.csv", t, np.r_[np.zeros(25), np.full(25, 0.2)], np.zeros(50), current=np.full(50, 0.0))
    assert np.isnan(zeros.current[:25]).all()  # as in a file: a logger's 0 where the wire was not driven
    with pytest.raises(MeasuredDataError, match="run.csv: file does not exist"):
        load_traces("run.csv")
    with pytest.raises(TypeError, match="expected the path of a CSV file"):
        load_trace(np.zeros(3))


def test_an_output_with_empty_cells_varies_and_files_of_other_rates_get_a_note():
    """np.ptp over a resistance column with the format's empty cells was NaN, so a trace
    whose resistance varied beside a flat position was refused as a disconnected sensor; and
    files at 100 Hz and 1 kHz fitted together weighed 10:1 without a word."""
    from sma_gym.diagnosis.workflow import data_notes, require_diagnosable

    t = 0.001 * np.arange(2000)
    duty = np.where((t > 0.5) & (t < 1.5), 0.3, 0.0)
    resistance = np.where(duty > 0, 4.0 - 0.2 * t, np.nan)
    flat = MeasuredTrace("r_only.csv", t, duty, np.zeros_like(t), resistance=resistance)
    # Refused before as "no measured output varies" (position, resistance, ...): now for what it is.
    with pytest.raises(ValueError, match="r_only.csv: position is 0 m in every row while the wire is heated"):
        require_diagnosable([flat])
    moving = MeasuredTrace("moving.csv", t, duty, 1e-3 * np.clip(t - 0.6, 0.0, None), resistance=resistance)
    require_diagnosable([moving])
    sparse = MeasuredTrace("slow.csv", t[::10], duty[::10], np.zeros(200))
    (note,) = [n for n in data_notes([flat, sparse]) if "sampled every" in n]
    assert "r_only.csv is sampled every 1 ms and slow.csv every 10 ms" in note and "10x" in note
    assert not [n for n in data_notes([flat], [sparse]) if "sampled every" in n]  # held out: no weight


def test_rows_are_parsed_as_they_are_read_and_blank_lines_keep_their_meaning(tmp_path):
    """The reader held every row as a list of strings (a 47 MB file of 10^6 rows took
    850 MB; now about 220 MB, benchmarks aside): rows are parsed one at a time, and blank
    lines still count where they are (inside the data: a row of the wrong length; at the
    end: dropped), with old Mac line ends read as lines."""
    inside = write(tmp_path / "inside.csv", "t,duty,position\n0,0,0\n\n0.001,0,0\n\n\n")
    with pytest.raises(MeasuredDataError, match=r"inside.csv:3: 0 fields, expected 3"):
        load_trace(inside)
    trace = load_trace(write(tmp_path / "cr.csv", "t,duty,position\r0,0,0\r0.001,0.5,0\r\r"))
    assert list(trace.duty) == [0.0, 0.5]
    with pytest.raises(MeasuredDataError, match="empty file"):
        load_trace(write(tmp_path / "blank.csv", "\n,,\n\n"))


def test_a_quantised_reading_has_its_rounding_as_noise_and_a_stuck_one_is_refused():
    """A resistance rounded to 0.1 ohm has third differences mostly 0: its noise was read as
    the floor (0.5 mohm), and it outweighed the position in the fit (a right 'none' became
    'unexplained'); a current of 0.4 A in every row took the 'corrected' model 3 mm off."""
    from sma_gym.diagnosis.fitting import noise_level, quantisation_step
    from sma_gym.diagnosis.workflow import require_diagnosable

    rng = np.random.default_rng(0)
    smooth = 3.5 + 0.3 * np.sin(np.linspace(0.0, 6.0, 2000)) + rng.normal(0.0, 1e-3, 2000)
    rounded = np.round(smooth, 1)
    assert quantisation_step(rounded) == pytest.approx(0.1) and quantisation_step(smooth) == 0.0
    assert noise_level(rounded, 5e-4) == pytest.approx(0.1 / np.sqrt(12.0))
    assert noise_level(smooth, 5e-4) == pytest.approx(1e-3, rel=0.2)  # unrounded: its own noise
    t = 0.001 * np.arange(2000)
    duty = np.where(t > 0.5, 0.3, 0.0)
    x = 1e-3 * np.clip(t - 0.6, 0.0, None)
    stuck = MeasuredTrace("stuck.csv", t, duty, x, current=np.where(duty > 0, 0.4, np.nan))
    with pytest.raises(ValueError, match="stuck.csv: current is 0.4 A in every row while the wire moves 1.4 mm"):
        require_diagnosable([MeasuredTrace("ok.csv", t, duty, x)], [stuck])
    # An ideal supply holds the wire's voltage: constant is no stuck sensor; nor is a constant
    # current where the wire never transformed (its resistance hardly changes).
    volts = np.where(duty > 0, 10.0, np.nan)
    require_diagnosable([MeasuredTrace("v.csv", t, duty, x, wire_voltage=volts)])
    still = np.where(t > 1.0, 2e-4, 0.0)
    require_diagnosable([MeasuredTrace("warm.csv", t, duty, still, current=np.where(duty > 0, 0.4, np.nan))])


def test_a_model_file_named_like_the_data_is_named_as_such_not_as_a_bad_sidecar(tmp_path):
    """bench2.json (a model) beside bench2.csv was read as its sidecar and reported as five
    unknown keys; a sidecar given as the model said only "'format' = None" (a new user's trial)."""
    from sma_gym.diagnosis.synth import SynthSpec
    from sma_gym.diagnosis.synth import write as write_synth
    from sma_gym.model import ModelConfig, load_model

    path, _ = write_synth(SynthSpec(ModelConfig(), excitation="steps", duration_s=2.0, seed=1), tmp_path / "b.csv")
    (tmp_path / "b.csv.json").rename(tmp_path / "conditions.json")
    ModelConfig().save(str(tmp_path / "b.json"))
    with pytest.raises(MeasuredDataError) as err:
        load_trace(path)
    assert "b.json: a model file (format 'sma-gym-model'), read as the sidecar of b.csv because of its name" in str(
        err.value
    )
    assert "unknown key" not in str(err.value) and "or write the conditions into b.csv.json" in str(err.value)
    # The model saved where the sidecar goes: only renaming it helps.
    (tmp_path / "b.json").rename(tmp_path / "b.csv.json")
    with pytest.raises(MeasuredDataError, match="because of its name; rename the model file \\(a sidecar holds"):
        load_trace(path)
    with pytest.raises(ValueError, match="a measured file's sidecar of conditions is not a model"):
        load_model(tmp_path / "conditions.json")

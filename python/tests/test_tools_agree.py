"""observe, calibrate and detect give the tools' numbers to the last bit, on simulated logs of
the paper arm (conftest.sim: mo-sim, mo-observe, mo-calibrate, mo-detect)."""
import csv
import json
import math
import shutil

import numpy as np
import pytest

import momentum
from conftest import profile_document, run, tool


def same_bits(a, b):
    a, b = np.ascontiguousarray(a, dtype=np.float64), np.ascontiguousarray(b, dtype=np.float64)
    return a.shape == b.shape and np.array_equal(a.view(np.uint64), b.view(np.uint64))


def assert_same_columns(python, tool_output):
    assert python.columns == tool_output.columns
    for name in python.columns:
        assert same_bits(python[name], tool_output[name]), name


def test_observe_equals_mo_observe(arm, sim):
    log = momentum.read(sim["free1"])
    observed = momentum.observe(arm, log)
    expected = momentum.read(sim["free1_observed"])
    assert_same_columns(observed, expected)
    # r and mu for each of the 3 joints, and the residuals are not trivially zero.
    assert {"r1", "r2", "r3", "mu1", "mu2", "mu3", "tau_f1"} <= set(observed.columns)
    assert np.nanmax(np.abs(observed["r2"])) > 0.1
    assert observed.summary["rows_written"] == log.rows


def test_observe_with_options_equals_the_tool(arm, sim, tmp_path):
    """Options by the tools' names: order, k1, restart_column, no friction, from a path."""
    out = tmp_path / "o.csv"
    run(tool("mo-observe"), "-p", arm, sim["hits"], "-o", out, "--order", "1", "--k1", "30,40,50", "--restart-column",
        "--no-friction")
    observed = momentum.observe(momentum.Profile(arm), sim["hits"], order=1, k1=[30, 40, 50], restart_column=True,
                                friction=False)
    assert_same_columns(observed, momentum.read(out))
    assert "mu1" not in observed.columns and observed["restart"][0] == 1


def test_observe_pandas_in_and_out(arm, sim):
    pytest.importorskip("pandas")
    frame = momentum.read(sim["free2"], pandas=True)
    observed = momentum.observe(arm, frame, pandas=True)
    expected = momentum.read(sim["free2_observed"])
    assert list(observed.columns) == expected.columns
    for name in expected.columns:
        assert same_bits(observed[name].to_numpy(), expected[name]), name


def test_calibrate_equals_mo_calibrate(arm, sim, tmp_path, capfd):
    """The thresholds Python writes into the profile are mo-calibrate's, and so is the report,
    which comes back as text: nothing is written to the process's standard output."""
    profile = tmp_path / "arm.json"
    shutil.copy(arm, profile)
    shutil.copy(arm.parent / "paper-arm.urdf", tmp_path / "paper-arm.urdf")
    paths = [str(sim["free1_observed"]), str(sim["free2_observed"])]
    sets = [momentum.read(p) for p in paths]
    capfd.readouterr()
    result = momentum.calibrate(profile, sets, names=paths)
    assert capfd.readouterr().out == ""
    written = profile_document(profile)["thresholds"]
    expected = profile_document(sim["calibrated"])["thresholds"]
    assert written == expected
    assert result.thresholds == expected
    assert set(result.thresholds) == {"mu", "r"}
    assert result.report == sim["calibrate_report"]
    assert result.rows == sum(s.rows for s in sets)
    # Thresholds are above what the collision-free residuals reached while moving.
    for j in (1, 2, 3):
        moving = result.thresholds["mu"]["joints"][j - 1]["moving"]
        assert 0 < moving < 100


def test_calibrate_dry_run_writes_nothing(arm, sim, tmp_path):
    profile = tmp_path / "arm.json"
    shutil.copy(arm, profile)
    shutil.copy(arm.parent / "paper-arm.urdf", tmp_path / "paper-arm.urdf")
    before = profile.read_bytes()
    result = momentum.calibrate(profile, [sim["free1_observed"], sim["free2_observed"]], dry_run=True)
    assert profile.read_bytes() == before
    assert result.thresholds["mu"] == profile_document(sim["calibrated"])["thresholds"]["mu"]


def test_calibrate_too_few_rows_fails_as_the_tool(arm, sim, tmp_path):
    few = momentum.read(sim["free1_observed"])
    short = {name: few[name][:50] for name in few.columns}
    with pytest.raises(momentum.Error, match="a calibration needs at least 100"):
        momentum.calibrate(None, [short])


def tool_events(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def test_detect_equals_mo_detect(sim):
    residuals = momentum.read(sim["hits_observed"])
    events = momentum.detect(sim["calibrated"], residuals)
    expected = tool_events(sim["events"])
    assert len(expected) >= 2, "the simulated collisions give events"
    assert len(events) == len(expected)
    for got, want in zip(events, expected):
        assert list(got) == list(want)
        for key, text in want.items():
            value = got[key]
            if key in ("joints", "link_set"):
                assert ";".join(map(str, value)) == text, key
            elif key == "links":
                assert value == {int(k): float(p) for k, p in (i.split(":") for i in text.split(";") if i)}, key
            elif isinstance(value, float):
                assert (math.isnan(value) and text == "") or value == float(text), key
            else:
                assert str(value) == text, key
    assert events.summary["collisions"] == sum(e["kind"] == "onset" for e in events)
    # Every event is detected after its onset estimate, and each onset has its end row.
    for e in events:
        assert e["t_onset_estimate"] <= e["t_detect"]
    assert [e["event"] for e in events if e["kind"] == "end"] == [e["event"] for e in events if e["kind"] == "onset"]


def test_detect_constant_threshold_no_identify(sim, tmp_path):
    out = tmp_path / "events.csv"
    run(tool("mo-detect"), "--threshold", "5", "--no-identify", "--signal", "r", sim["hits_observed"], "-o", out,
        ok=(0, 1))
    events = momentum.detect(None, sim["hits_observed"], threshold=5, identify=False, signal="r")
    expected = tool_events(out)
    assert len(events) == len(expected) > 0
    assert "class" not in events[0]
    for got, want in zip(events, expected):
        assert got["t_detect"] == float(want["t_detect"]) and got["link"] == int(want["link"])
        assert [got[f"peak{j}"] for j in (1, 2, 3)] == [float(want[f"peak{j}"]) for j in (1, 2, 3)]


def test_whole_pipeline_from_arrays(arm, sim):
    """read -> observe -> detect in Python equals the tools' chain."""
    observed = momentum.observe(arm, momentum.read(sim["hits"]))
    events = momentum.detect(sim["calibrated"], observed)
    assert [e["t_detect"] for e in events] == [float(e["t_detect"]) for e in tool_events(sim["events"])]


def test_calls_from_threads_agree(arm, sim):
    """The binding releases the GIL and serialises the library's process-wide state: calls
    from several threads give each the tool's numbers."""
    from concurrent.futures import ThreadPoolExecutor

    log = momentum.read(sim["free1"])
    expected = momentum.read(sim["free1_observed"])
    with ThreadPoolExecutor(4) as pool:
        results = list(pool.map(lambda _: momentum.observe(arm, log), range(4)))
    for observed in results:
        assert_same_columns(observed, expected)

"""share/momentum/examples/python/log_to_plot.py runs: its numbers (without matplotlib) are
observe's, its events detect's, and with matplotlib it writes a PNG."""
import importlib.util
import re
import runpy
import sys

import numpy as np
import pytest

import momentum
from conftest import ROOT

EXAMPLE = ROOT / "share" / "momentum" / "examples" / "python" / "log_to_plot.py"


def run_example(args, capsys, block_matplotlib):
    saved = sys.argv, sys.modules.get("matplotlib")
    sys.argv = [str(EXAMPLE), *map(str, args)]
    if block_matplotlib:
        sys.modules["matplotlib"] = None  # import matplotlib raises ImportError
    try:
        with pytest.raises(SystemExit) as done:
            runpy.run_path(str(EXAMPLE), run_name="__main__")
    finally:
        sys.argv = saved[0]
        if block_matplotlib:
            if saved[1] is None:
                del sys.modules["matplotlib"]
            else:
                sys.modules["matplotlib"] = saved[1]
    assert done.value.code == 0
    return capsys.readouterr().out


def test_without_matplotlib_writes_the_numbers(sim, tmp_path, capsys):
    out = run_example([sim["calibrated"], sim["hits"], tmp_path / "hits.png"], capsys, block_matplotlib=True)
    numbers = momentum.read(tmp_path / "hits.csv")
    observed = momentum.observe(sim["calibrated"], sim["hits"])
    assert numbers.columns == ["t", "mu1", "mu2", "mu3"]
    for name in numbers.columns:
        assert np.array_equal(numbers[name], observed[name], equal_nan=True), name
    events = momentum.detect(sim["calibrated"], observed)
    onsets = [e for e in events if e["kind"] == "onset"]
    assert f"{len(onsets)} events in {observed.rows} rows" in out
    printed = [float(t) for t in re.findall(r"t = ([0-9.]+) s", out)]
    assert printed == pytest.approx([e["t_detect"] for e in onsets], abs=5e-4)
    assert not (tmp_path / "hits.png").exists()


def test_with_matplotlib_writes_a_png(sim, tmp_path, capsys):
    if importlib.util.find_spec("matplotlib") is None:
        pytest.skip("matplotlib is not installed")
    png = tmp_path / "hits.png"
    out = run_example([sim["calibrated"], sim["hits"], png], capsys, block_matplotlib=False)
    assert "plot written" in out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

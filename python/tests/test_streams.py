"""momentum.read and momentum.write: round trips to the bit, the tools' encodings, columns by name."""
import math
import pathlib

import numpy as np
import pytest

import momentum
from conftest import run, tool


def bits(a):
    return np.ascontiguousarray(a, dtype=np.float64).view(np.uint64)


# Values whose text forms are hard: subnormals, the extremes, -0, 0.1 + 0.2, NaN and infinities.
AWKWARD = np.array([0.0, -0.0, 5e-324, 2.2250738585072014e-308, 1.7976931348623157e308, 0.1 + 0.2,
                    1 / 3, -1e-300, math.pi * 1e22, float("inf"), float("-inf"), float("nan")])


@pytest.mark.parametrize("encoding", ["csv", "binary"])
def test_round_trip_is_exact(tmp_path, encoding):
    rng = np.random.default_rng(7)
    columns = {"t": np.arange(len(AWKWARD)) * 0.001, "q1": AWKWARD, "dq1": rng.standard_normal(len(AWKWARD)) * 1e-9}
    path = tmp_path / f"s.{encoding}"
    momentum.write(path, columns, encoding=encoding, comments=["made by a test"])
    back = momentum.read(path)
    assert back.columns == ["t", "q1", "dq1"]
    assert back.rows == len(AWKWARD)
    assert back.comments == ["made by a test"]
    assert back.encoding == ("csv" if encoding == "csv" else "bin")
    for name, values in columns.items():
        assert np.array_equal(bits(back[name]), bits(values)), name


def test_csv_text_is_what_the_format_says(tmp_path):
    path = tmp_path / "s.csv"
    momentum.write(path, {"t": [0.0, 0.001], "q1": [0.1 + 0.2, -0.0]})
    lines = [l for l in path.read_text().splitlines() if not l.startswith("#")]
    assert lines[0] == "t,q1"
    assert [float(x) for x in lines[1].split(",")] == [0.0, 0.1 + 0.2]
    assert lines[1].split(",")[1] == repr(0.1 + 0.2)  # shortest text that reads back exactly


def test_reads_what_the_tools_write(sim):
    """mo-sim's CSV and mo-cat's binary conversion of it read to the same numbers; the columns
    are the file's header, in order."""
    csv_path = sim["free1"]
    binary = sim["folder"] / "free1-cat.bin"
    run(tool("mo-cat"), csv_path, "-o", binary, "--output-format", "bin")
    a, b = momentum.read(csv_path), momentum.read(binary)
    header = next(l for l in pathlib.Path(csv_path).read_text().splitlines() if not l.startswith("#"))
    assert a.columns == header.split(",") == b.columns
    rows = [l for l in pathlib.Path(csv_path).read_text().splitlines() if not l.startswith("#")][1:]
    assert a.rows == b.rows == len(rows) > 9000  # 20 s at 500 Hz, every line a row
    for name in a.columns:
        assert np.array_equal(bits(a[name]), bits(b[name])), name
    # The numbers are the file's: the third row's text parsed by Python.
    third = [float(x) for x in rows[2].split(",")]
    assert [a[name][2] for name in a.columns] == third


def test_written_by_python_reads_in_the_tools(tmp_path, sim):
    """A stream momentum.write makes is one mo-cat reads: its --stats count the rows and
    columns, and its CSV conversion holds the same numbers."""
    path = tmp_path / "p.bin"
    q1 = np.sin(np.arange(250))
    momentum.write(path, {"t": np.arange(250) * 0.004, "q1": q1}, encoding="binary")
    stats = run(tool("mo-cat"), "--stats", path).stdout.splitlines()
    assert stats[0].split() == ["rows", "250"] and stats[1].split() == ["columns", "2"]
    text = run(tool("mo-cat"), path, "--output-format", "csv").stdout
    rows = [l for l in text.splitlines() if not l.startswith("#")][1:]
    assert [float(r.split(",")[1]) for r in rows] == q1.tolist()


def test_pandas(tmp_path):
    pandas = pytest.importorskip("pandas")
    path = tmp_path / "s.csv"
    momentum.write(path, {"t": [0.0, 0.5, 1.0], "q1": [1.0, 2.0, 3.0]})
    frame = momentum.read(path, pandas=True)
    assert isinstance(frame, pandas.DataFrame)
    assert list(frame.columns) == ["t", "q1"]
    assert frame["q1"].tolist() == [1.0, 2.0, 3.0]
    # A DataFrame goes back in as columns.
    momentum.write(tmp_path / "again.bin", frame, encoding="binary")
    assert momentum.read(tmp_path / "again.bin").to_pandas().equals(frame)


def test_headerless_names(tmp_path):
    path = tmp_path / "export.csv"
    path.write_text("0,1.5,9\n0.001,2.5,9\n")
    c = momentum.read(path, names=["t", "q1", "_"])
    assert c.columns == ["t", "q1"]
    assert c["q1"].tolist() == [1.5, 2.5]

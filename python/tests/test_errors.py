"""Bad input raises momentum.Error with the library's `file:line: message`; skipped rows warn."""
import numpy as np
import pytest

import momentum


def test_bad_row_strict_raises_with_file_and_line(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("t,q1\n0,1\n0.001,oops\n0.002,3\n")
    with pytest.raises(momentum.Error) as e:
        momentum.read(path, strict=True)
    assert str(e.value).startswith(f"{path}:3: ")
    assert "oops" in str(e.value) or "number" in str(e.value)


def test_bad_row_skipped_with_a_warning(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("t,q1\n0,1\n0.001,oops\n0.002,3\n")
    with pytest.warns(momentum.MomentumWarning) as caught:
        c = momentum.read(path)
    assert c["q1"].tolist() == [1.0, 3.0]
    messages = [str(w.message) for w in caught]
    assert any(m.startswith(f"{path}:3: ") for m in messages)
    assert "1 bad row skipped: 1 bad number" in messages


def test_many_bad_rows_are_summed_up(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("t,q1\n" + "".join(f"{i},x\n" for i in range(12)) + "12,1\n")
    with pytest.warns(momentum.MomentumWarning) as caught:
        momentum.read(path)
    messages = [str(w.message) for w in caught]
    assert sum(m.startswith(f"{path}:") for m in messages) == 5
    assert "7 more 'bad number' warnings not shown" in messages
    assert "12 bad rows skipped: 12 bad number" in messages


def test_missing_file(tmp_path):
    with pytest.raises(momentum.Error, match=r"nothing\.csv: cannot open: No such file"):
        momentum.read(tmp_path / "nothing.csv")


def test_bad_profile_names_file_and_line(tmp_path):
    path = tmp_path / "arm.json"
    path.write_text('{\n  "urdf": "x.urdf",\n  "root": ,\n}\n')
    with pytest.raises(momentum.Error) as e:
        momentum.Profile(path)
    assert str(e.value).startswith(f"{path}:3")


def test_observe_missing_column(arm):
    columns = {"t": np.arange(10) * 0.002, "q1": np.zeros(10), "q2": np.zeros(10), "q3": np.zeros(10)}
    with pytest.raises(momentum.Error, match=r"<columns>: missing column 'dq1'"):
        momentum.observe(arm, columns)


def test_bad_option_is_a_value_error(arm):
    with pytest.raises(ValueError, match="k2 and k3 need order 2"):
        momentum.observe(arm, {"t": [0.0]}, order=1, k2=3)


def test_write_refuses_ragged_columns(tmp_path):
    with pytest.raises(ValueError, match="different lengths"):
        momentum.write(tmp_path / "x.csv", {"t": [0.0, 1.0], "q1": [1.0]})


def test_observe_bad_row_strict_names_file_and_line(arm, tmp_path):
    path = tmp_path / "log.csv"
    header = "t,q1,q2,q3,dq1,dq2,dq3,i1,i2,i3\n"
    rows = [f"{k * 0.002},0,0.7,1,0,0,0,0,0,0\n" for k in range(5)]
    rows[3] = "0.006,0,0.7,1,0,0,0,0,zero,0\n"
    path.write_text(header + "".join(rows))
    with pytest.raises(momentum.Error) as e:
        momentum.observe(arm, path, strict=True)
    assert str(e.value).startswith(f"{path}:5: ")
    # Without strict, the row is skipped with a warning and the others observed.
    with pytest.warns(momentum.MomentumWarning, match=f"{path}:5: "):
        observed = momentum.observe(arm, path)
    assert observed.rows == 4


def test_detect_without_thresholds_names_the_profile(arm, sim):
    with pytest.raises(momentum.Error, match=str(arm)):
        momentum.detect(arm, sim["free1_observed"])

"""The README's Python example runs as written, on the logs its text tells mo-sim to make, and
prints the onsets mo-observe | mo-calibrate | mo-detect find."""
import contextlib
import csv
import io
import os
import re
import shutil

from conftest import ARM, ROOT, run, tool


def readme_python():
    text = (ROOT / "README.md").read_text()
    section = text[text.index("\n## Python\n"):]
    section = section[:section.index("\n## ", 1)]
    return section, re.search(r"```python\n(.*?)```", section, re.S).group(1)


def test_readme_example(tmp_path):
    section, code = readme_python()
    assert len(code.strip().splitlines()) == 6
    words = " ".join(section.split())
    assert "`mo-sim -p paper-arm.json --seed 3 --duration 20 -o free.csv`" in words
    assert "the same with `--seed 5 --collisions 4` into `hits.csv`" in words
    shutil.copy(ARM / "paper-arm.json", tmp_path)
    shutil.copy(ARM / "paper-arm.urdf", tmp_path)
    mo_sim = tool("mo-sim")
    run(mo_sim, "-p", "paper-arm.json", "--seed", "3", "--duration", "20", "-o", "free.csv", cwd=tmp_path)
    run(mo_sim, "-p", "paper-arm.json", "--seed", "5", "--duration", "20", "--collisions", "4", "-o", "hits.csv",
        cwd=tmp_path)
    printed = io.StringIO()
    here = os.getcwd()
    os.chdir(tmp_path)
    try:
        with contextlib.redirect_stdout(printed):
            exec(compile(code, "README.md", "exec"), {})
    finally:
        os.chdir(here)
    onsets = eval(printed.getvalue())

    # The same with the tools.
    run(tool("mo-observe"), "-p", "paper-arm.json", "free.csv", "-o", "free-r.bin", cwd=tmp_path)
    run(tool("mo-calibrate"), "-p", "paper-arm.json", "-o", "tools.json", "free-r.bin", cwd=tmp_path)
    run(tool("mo-observe"), "-p", "paper-arm.json", "hits.csv", "-o", "hits-r.bin", cwd=tmp_path)
    run(tool("mo-detect"), "-p", "tools.json", "hits-r.bin", "-o", "events.csv", ok=(0, 1), cwd=tmp_path)
    with open(tmp_path / "events.csv", newline="") as f:
        rows = list(csv.DictReader(line for line in f if not line.startswith("#")))
    expected = [(float(r["t_detect"]), int(r["link"])) for r in rows if r["kind"] == "onset"]
    assert onsets == expected
    assert len(onsets) >= 2

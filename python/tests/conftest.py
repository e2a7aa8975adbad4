"""Shared data for the package's tests: simulated logs of the paper arm (mo-sim) and what the
tools make of them, in one temporary folder per session.

The tools are found through MOMENTUM_BIN (the CMake build's bin folder; scripts/test.sh sets
it); without it, the tests that compare with the tools are skipped, and say so."""
import json
import os
import pathlib
import re
import shutil
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
ARM = ROOT / "share" / "momentum" / "robots" / "paper-arm"


def tool(name):
    folder = os.environ.get("MOMENTUM_BIN")
    if not folder:
        pytest.skip("MOMENTUM_BIN is not set: no tools to compare with")
    path = pathlib.Path(folder) / name
    if not path.is_file():
        pytest.fail(f"MOMENTUM_BIN={folder}: no {name} there")
    return str(path)


def run(*args, ok=(0,), **kwargs):
    """Runs a tool; returns its completed process, failing the test on an unexpected status."""
    done = subprocess.run([str(a) for a in args], capture_output=True, text=True, **kwargs)
    if done.returncode not in ok:
        pytest.fail(f"{' '.join(map(str, args))}: status {done.returncode}\n{done.stderr}")
    return done


def profile_document(path):
    text = pathlib.Path(path).read_text()
    return json.loads(re.sub(r"^\s*//.*$", "", text, flags=re.M))


@pytest.fixture(scope="session")
def arm(tmp_path_factory):
    """The paper arm with its true LuGre friction as the profile's friction model, so that
    mo-observe writes mu as well as r: a folder with arm.json and the URDF."""
    folder = tmp_path_factory.mktemp("arm")
    shutil.copy(ARM / "paper-arm.urdf", folder / "paper-arm.urdf")
    document = profile_document(ARM / "paper-arm.json")
    document["friction"] = document["simulation"]["friction"]
    (folder / "arm.json").write_text(json.dumps(document, indent=2))
    return folder / "arm.json"


@pytest.fixture(scope="session")
def sim(arm, tmp_path_factory):
    """Two collision-free logs (20 s at 500 Hz, seeds 3 and 4), a log with 4 collisions, their
    residuals from mo-observe, a profile calibrated on the free ones by mo-calibrate, and
    mo-detect's events on the collisions."""
    folder = tmp_path_factory.mktemp("sim")
    mo_sim, mo_observe = tool("mo-sim"), tool("mo-observe")
    files = {}
    for name, extra in (("free1", ["--seed", "3"]), ("free2", ["--seed", "4"]),
                        ("hits", ["--seed", "5", "--collisions", "4", "--truth", folder / "truth.csv"])):
        log = folder / f"{name}.csv"
        run(mo_sim, "-p", arm, "--duration", "20", "--rate", "500", "-o", log, *extra)
        observed = folder / f"{name}-observed.bin"
        run(mo_observe, "-p", arm, log, "-o", observed, "--output-format", "bin")
        files[name], files[name + "_observed"] = log, observed
    calibrated = folder / "calibrated.json"
    report = run(tool("mo-calibrate"), "-p", arm, "-o", calibrated, files["free1_observed"], files["free2_observed"])
    files["calibrated"], files["calibrate_report"] = calibrated, report.stdout
    events = folder / "events.csv"
    run(tool("mo-detect"), "-p", calibrated, files["hits_observed"], "-o", events, ok=(0, 1))
    files["events"] = events
    files["folder"] = folder
    return files

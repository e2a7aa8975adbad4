#!/usr/bin/env bash
# Makes a Python virtual environment for the package in python/ and installs, from PyPI, what
# building it and running its tests need: the build backend (scikit-build-core) and pybind11,
# NumPy, pytest, and pandas and matplotlib, whose paths the tests cover (read(pandas=True), the
# example's plot). Python itself and its headers come from Debian (scripts/setup.sh).
#   scripts/python-setup.sh [VENV_DIR]   (default: build/python-venv)
set -euo pipefail
cd "$(dirname "$0")/.."
venv=${1:-build/python-venv}
[[ -x $venv/bin/python ]] || python3 -m venv "$venv"
"$venv/bin/python" -m pip install -q --disable-pip-version-check \
  'scikit-build-core>=0.9' 'pybind11>=2.11' numpy pytest pandas matplotlib

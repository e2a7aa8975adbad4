#!/usr/bin/env bash
# Sets everything up and runs the main job on the built-in example.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh build >/dev/null
export PATH=$PWD/build/bin:$PATH
mo-cat --stats share/momentum/examples/sample.csv

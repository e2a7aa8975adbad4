#!/usr/bin/env bash
# Installs everything momentum needs from Debian's packages, then configures and builds it.
#   scripts/setup.sh [--target T]... [BUILD_DIR [extra cmake args...]]   (default build dir: build)
# With --target, builds only those targets (scripts/demo.sh: the tools it runs); else everything.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(build-essential cmake ninja-build pkg-config python3 git
  libeigen3-dev libceres-dev libnlopt-cxx-dev libnlopt-dev liburdfdom-dev nlohmann-json3-dev
  libcli11-dev libgtest-dev libbenchmark-dev scdoc groff-base gnuplot-nox valgrind zsh
  libzstd-dev liblz4-dev  # chunks of ROS 2 bags (MCAP)
  jq parallel  # the fleet example (share/momentum/examples/fleet/) and its test
  slurm-wlm munge  # its Slurm array on a one-node cluster (tests/nightly/slurm_test.sh)
  python3-venv python3-dev  # the Python package (python/; PyPI packages: scripts/python-setup.sh)
  clang-14 libclang-rt-14-dev)  # clang: the sanitizer build and the libFuzzer targets

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  sudo=""
  [[ $(id -u) -eq 0 ]] || sudo="sudo"
  echo "setup: installing ${missing[*]}" >&2
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

targets=()
while [[ ${1:-} == --target ]]; do
  targets+=(--target "${2:?setup: --target needs a name}")
  shift 2
done
build=${1:-build}
shift || true
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo "$@" >/dev/null
cmake --build "$build" -j"$(nproc)" "${targets[@]}"

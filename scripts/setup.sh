#!/usr/bin/env bash
# Installs what is missing from Debian's packages (apt-get update once, then apt-get install),
# then configures and builds alphainv (Release, tests, benchmarks, apps) into build/release.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  build-essential cmake ninja-build pkg-config
  libeigen3-dev libceres-dev libsundials-dev libnlopt-dev libnlopt-cxx-dev libhidapi-dev
  libgtest-dev libgmock-dev libbenchmark-dev nlohmann-json3-dev libcli11-dev libspdlog-dev
  gnuplot-nox rt-tests
  pybind11-dev python3-dev python3-numpy python3-pytest python3-distributed python3-pandas
  python3-matplotlib
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}"
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y --no-install-recommends "${missing[@]}"
fi

cmake --preset release
cmake --build --preset release

# The bundled dataset (41 MB, too large to commit) is generated from the virtual Omni, seed 1:
# deterministic, bit for bit (data/README.md).
if [ ! -f data/omni_yaw_sim/dataset.json ]; then
  ./build/release/apps/omni_gen/omni_gen paper -o data/omni_yaw_sim --seed 1
fi

#!/usr/bin/env bash
# Installs the built package into a temporary prefix and builds examples/ against it, as a consumer
# of find_package(alphainv) would, then runs both examples.
set -euo pipefail
cd "$(dirname "$0")/.."
prefix=$(mktemp -d)
trap 'rm -rf "$prefix" build/examples' EXIT
cmake --install build/release --prefix "$prefix" > /dev/null
cmake -S examples -B build/examples -G Ninja -DCMAKE_PREFIX_PATH="$prefix" > /dev/null
cmake --build build/examples -j2
./build/examples/01_evaluate_model
./build/examples/02_simulate_step
echo "check-install: the installed package builds and runs the examples"

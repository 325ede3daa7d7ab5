#!/usr/bin/env bash
# Installs the built package into a temporary prefix and builds examples/ against it, as a consumer
# of find_package(alphainv) would, then runs the examples. The core example is built a second time
# asking for the core component alone, with Ceres, SUNDIALS, NLopt, nlohmann_json and hidapi made
# unfindable: a core-only consumer needs Eigen and nothing else.
set -euo pipefail
cd "$(dirname "$0")/.."
prefix=$(mktemp -d)
trap 'rm -rf "$prefix" build/examples build/examples-core' EXIT
cmake --install build/release --prefix "$prefix" > /dev/null
cmake -S examples -B build/examples -G Ninja -DCMAKE_PREFIX_PATH="$prefix" > /dev/null
cmake --build build/examples -j2
./build/examples/01_evaluate_model
./build/examples/02_simulate_step
no_deps=(-DCMAKE_DISABLE_FIND_PACKAGE_Ceres=ON -DCMAKE_DISABLE_FIND_PACKAGE_SUNDIALS=ON
         -DCMAKE_DISABLE_FIND_PACKAGE_NLopt=ON -DCMAKE_DISABLE_FIND_PACKAGE_nlohmann_json=ON
         -DCMAKE_DISABLE_FIND_PACKAGE_PkgConfig=ON -DCMAKE_DISABLE_FIND_PACKAGE_Threads=ON)
# The switches bite: asking for every component with them must fail to configure.
if cmake -S examples -B build/examples-core -G Ninja -DCMAKE_PREFIX_PATH="$prefix" --no-warn-unused-cli \
     "${no_deps[@]}" > /dev/null 2>&1; then
  echo "check-install: find_package(alphainv) with Ceres & co. disabled should have failed" >&2
  exit 1
fi
rm -rf build/examples-core
cmake -S examples -B build/examples-core -G Ninja -DCMAKE_PREFIX_PATH="$prefix" --no-warn-unused-cli \
  -DALPHAINV_EXAMPLES_CORE_ONLY=ON "${no_deps[@]}" > /dev/null
cmake --build build/examples-core -j2
./build/examples-core/01_evaluate_model > /dev/null
echo "check-install: the installed package builds and runs the examples; alphainv::core alone needs only Eigen"

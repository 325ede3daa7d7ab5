#!/usr/bin/env bash
# The main job: sets up (scripts/setup.sh), then runs omni_fit on the bundled model and experiment
# plan. Until the bundled dataset and the fit pipeline land, this is the paper's model simulated on
# the paper's experiment plan (`omni_fit demo`); the command stays the same.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
./build/release/apps/omni_fit/omni_fit demo "$@"

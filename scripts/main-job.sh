#!/usr/bin/env bash
# The main job: sets up (scripts/setup.sh, which also generates the bundled dataset from the virtual
# Omni), then fits the bundled dataset with omni_fit: model.json and report.md in out/omni_yaw_sim.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
./build/release/apps/omni_fit/omni_fit fit data/omni_yaw_sim -o out/omni_yaw_sim "$@"

#!/usr/bin/env bash
# Identify, deploy and verify in one loop, on the virtual device with effects the tools are not
# told (docs/compensation.md):
#   1. record the identification plan (the paper's sine frequencies, a square wave) with omni_ctl;
#   2. omni_fit fit; 3. omni_fit diagnose (names the effects, model.json with them);
#   4. run the same references (the sines and a step) with --compensate none, effects,
#      feedforward, all; 5. omni_fit validate on the uncompensated and the compensated runs;
#   6. robustness (the model's effect sizes 30 % too high and too low), a 30 s hold, free motion
#      (kp 0, a hand pushing at 0.2 rad/s); 7. the tables and the tracking plots.
# Usage: scripts/closed-loop.sh [OUT]   (default /tmp/closed-loop; about 10 minutes: every run
# is real time at 1 kHz, plus diagnose's run time). Environment: BUILD (default build/release),
# HIDDEN (the plant's effects, omni_ctl --sim-effect specs separated by spaces), SIM_NOISE and
# SIM_SEED (the encoder's noise [rad] and its seed), DIAGNOSE_OPTS (omni_fit diagnose's options),
# COMP_DAMPING (free motion: --compensate-damping, default 0.5),
# MODEL (the model deployed, default the diagnosed one), PHASES (default "all", else some of
# "record fit diagnose eval robust hold free figures"; "identify" = record fit diagnose).
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
BUILD=${BUILD:-$ROOT/build/release}
OUT=${1:-/tmp/closed-loop}
CTL=$BUILD/apps/omni_ctl/omni_ctl
FIT=$BUILD/apps/omni_fit/omni_fit
PY=/usr/bin/python3
HELP="$ROOT/scripts/closed_loop_figures.py"
HIDDEN=${HIDDEN:-"coulomb_friction:coulomb_v=0.02 offset_torque:offset_v=0.01 deadzone:deadzone_v=0.01 cogging:cogging_v=0.01,cogging_period_rad=0.016,cogging_phase_rad=1.1"}
PHASES=${PHASES:-all}
SIM_NOISE=${SIM_NOISE:-5e-5}
SIM_SEED=${SIM_SEED:-7}
DIAGNOSE_OPTS=${DIAGNOSE_OPTS:-"--max-effects 4 --fit-runs 5"}
FREQS="1.5 2 2.5 3 3.5 4 5 6 7"  # the paper's sine plan (Table 1) [Hz]
MODES="none effects feedforward all"

for tool in "$CTL" "$FIT"; do
  [[ -x $tool ]] || { echo "closed-loop.sh: $tool not built" >&2; exit 1; }
done
mkdir -p "$OUT"
sim_effects=(--sim-noise "$SIM_NOISE" --sim-seed "$SIM_SEED")
for spec in $HIDDEN; do sim_effects+=(--sim-effect "$spec"); done
# One run on the virtual device; a fault (exit 3) keeps its recording and is reported.
ctl() {
  local rc=0
  "$CTL" --joint yaw --device sim --local "${sim_effects[@]}" "$@" \
    2> "$OUT/last_ctl.log" || rc=$?
  [[ $rc == 0 || $rc == 3 ]] || { cat "$OUT/last_ctl.log" >&2; exit $rc; }
  [[ $rc == 0 ]] || echo "  (run ended with a fault: $(grep -m1 FAULT "$OUT/last_ctl.log"))"
}
phase() {
  [[ $PHASES == all || " $PHASES " == *" $1 "* ]] && return 0
  [[ " $PHASES " == *" identify "* && " record fit diagnose " == *" $1 "* ]]
}
# The references of step 4: the sines (6 s) and a step (3 s), as NAME:ARGS.
eval_runs() {
  for f in $FREQS; do echo "sine_${f}Hz:--sine ${f}Hz --duration 6s"; done
  echo "step:--step --duration 3s"
}
# Runs every reference with --compensate $1 and model $2 into $OUT/eval/$3.
run_eval() {
  local mode=$1 model=$2 dir=$OUT/eval/$3 name args folders=()
  while IFS=: read -r name args; do
    # shellcheck disable=SC2086
    ctl $args --model "$model" --compensate "$mode" --record "$dir/$name"
    folders+=("$dir/$name")
  done < <(eval_runs)
  $PY "$HELP" merge "$OUT/eval/$3.dataset" "${folders[@]}"
}

echo "closed-loop: the virtual plant's hidden effects: $HIDDEN"
if phase record; then
  echo "1. recording the identification plan"
  folders=()
  for f in $FREQS; do
    ctl --sine "${f}Hz" --duration 6s --record "$OUT/id/sine_${f}Hz"
    folders+=("$OUT/id/sine_${f}Hz")
  done
  ctl --square 0.25Hz --duration 8s --record "$OUT/id/square"
  folders+=("$OUT/id/square")
  $PY "$HELP" merge "$OUT/identification" "${folders[@]}"
fi
if phase fit; then
  echo "2. omni_fit fit"
  "$FIT" fit "$OUT/identification" -o "$OUT/fit" --json > "$OUT/fit.json"
fi
if phase diagnose; then
  echo "3. omni_fit diagnose $DIAGNOSE_OPTS"
  # shellcheck disable=SC2086
  /usr/bin/time -f "diagnose: %e s wall, %U s user" \
    "$FIT" diagnose "$OUT/identification" --model "$OUT/fit/model.json" -o "$OUT/diagnose" \
    $DIAGNOSE_OPTS --json > "$OUT/diagnose.json"
  jq -c '{named: [.named[]?.effect], effect, verdict}' "$OUT/diagnose.json" 2>/dev/null || true
fi
MODEL=${MODEL:-$OUT/diagnose/model.json}
if phase eval; then
  echo "4. the same references with --compensate none, effects, feedforward, all"
  for mode in $MODES; do run_eval "$mode" "$MODEL" "$mode"; done
  echo "5. omni_fit validate"
  for mode in none all; do
    "$FIT" validate "$MODEL" "$OUT/eval/$mode.dataset" -o "$OUT/validate_$mode" --json \
      > "$OUT/validate_$mode.json" || true
    jq -c '{rms, fit_percent}' "$OUT/validate_$mode.json" 2>/dev/null || true
  done
fi
if phase robust; then
  echo "6a. robustness: the model's effect sizes x1.3 and x0.7 with --compensate all"
  $PY "$HELP" scale "$MODEL" 1.3 "$OUT/model_x1.3.json"
  $PY "$HELP" scale "$MODEL" 0.7 "$OUT/model_x0.7.json"
  run_eval all "$OUT/model_x1.3.json" all_x1.3
  run_eval all "$OUT/model_x0.7.json" all_x0.7
fi
if phase hold; then
  echo "6b. hold 30 s, without and with --compensate all"
  ctl --hold --duration 31s --model "$MODEL" --record "$OUT/hold/none"
  ctl --hold --duration 31s --model "$MODEL" --compensate all --record "$OUT/hold/all"
  if [[ -f $OUT/model_x1.3.json ]]; then
    for x in 1.3 0.7; do
      ctl --hold --duration 31s --model "$OUT/model_x$x.json" --compensate all \
        --record "$OUT/hold/all_x$x"
    done
  fi
fi
PUSH_SPEED=0.2 PUSH_K=2 PUSH_START=0.5
COMP_DAMPING=${COMP_DAMPING:-0.5}  # free motion: the fraction of the model's damping cancelled too
if phase free; then
  echo "6c. free motion: kp 0, a hand moving the joint at +-$PUSH_SPEED rad/s"
  for dir in pos neg; do
    speed=$PUSH_SPEED
    [[ $dir == neg ]] && speed=-$PUSH_SPEED
    push=(--sim-push "hand:$speed,stiffness=$PUSH_K,damping=0.05,start=$PUSH_START")
    ctl --hold --kp 0 --duration 4s --model "$MODEL" "${push[@]}" --record "$OUT/free/none_$dir"
    ctl --hold --kp 0 --duration 4s --model "$MODEL" --compensate effects "${push[@]}" \
      --record "$OUT/free/effects_$dir"
    ctl --hold --kp 0 --duration 4s --model "$MODEL" --compensate effects \
      --compensate-damping "$COMP_DAMPING" "${push[@]}" --record "$OUT/free/damping_$dir"
  done
  ctl --hold --kp 0 --duration 4s --model "$MODEL" --sim-push "ramp:0.02,start=$PUSH_START" \
    --record "$OUT/free/ramp_none"
  ctl --hold --kp 0 --duration 4s --model "$MODEL" --compensate effects \
    --sim-push "ramp:0.02,start=$PUSH_START" --record "$OUT/free/ramp_effects"
fi
if phase figures; then
  echo "7. figures"
  names="$(eval_runs | cut -d: -f1 | tr '\n' ' ') step@0.5"
  {
    echo "## Tracking RMS |r - theta| (sines: t >= 2 s; step: whole run, and settled)"
    $PY "$HELP" tracking "$OUT/eval" "$MODES" "$names" 2 0
    if [[ -d $OUT/eval/all_x1.3 ]]; then
      echo; echo "## Robustness: --compensate all with the model's effects x1.3 / x0.7"
      $PY "$HELP" tracking "$OUT/eval" "none all all_x1.3 all_x0.7" "$names" 2 0
    fi
    echo; echo "## Hold 30 s"
    $PY "$HELP" hold "$OUT"/hold/*
    echo; echo "## Free motion (kp 0): mean hand push over the last 2 s, both directions"
    $PY "$HELP" transparency "$PUSH_SPEED" "$PUSH_K" "$PUSH_START" 2.0 "$OUT/free" "none effects damping"
  } | tee "$OUT/figures.md"
  mkdir -p "$OUT/plots"
  for name in sine_1.5Hz sine_4Hz sine_7Hz step; do
    $PY "$HELP" plot "$OUT/eval" "$MODES" "$name" "$OUT/plots/tracking_$name.png"
  done
  echo "closed-loop: figures in $OUT/figures.md, plots in $OUT/plots/"
fi

#!/usr/bin/env bash
# Install what is missing, build, and run oslam on the shipped `lab` sample.
# Output goes to runs/lab (override with OSLAM_RUN_DIR).
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

oslam_install_missing
oslam_build

run_dir="${OSLAM_RUN_DIR:-$OSLAM_ROOT/runs/lab}"
oslam="$OSLAM_BUILD_DIR/apps/oslam"
"$oslam" simulate "$OSLAM_ROOT/samples/scenes/lab.yaml" -o "$run_dir" --seed 1
oslam_log "sample run folder: $run_dir (frames/, odometry.csv, camera.yaml, classes.yaml, ground_truth/)"

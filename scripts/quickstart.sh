#!/usr/bin/env bash
# Install what is missing, build, and run oslam on the shipped `lab` sample:
# simulate the omnidirectional video (once), learn the class colours and the
# class confusion from the simulated ground truth, then `oslam run` (detect,
# O-SLAM, export, evaluate).
# The O-Map is written to runs/lab_out/map.glb (override the folders with
# OSLAM_RUN_DIR and OSLAM_OUT_DIR). OSLAM_SCENE=long_loop does the same for
# that scene. (house's furniture is not a colour-detector scene: the thesis
# hand-annotated Cogniron, and colour blobs there give thousands of spurious
# detections.)
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

oslam_install_missing
oslam_build

scene="${OSLAM_SCENE:-lab}"
scene_file="$OSLAM_ROOT/samples/scenes/$scene.yaml"
[[ -f "$scene_file" ]] || { echo "quickstart: no scene $scene_file" >&2; exit 1; }
run_dir="${OSLAM_RUN_DIR:-$OSLAM_ROOT/runs/$scene}"
out_dir="${OSLAM_OUT_DIR:-$OSLAM_ROOT/runs/${scene}_out}"
oslam="$OSLAM_BUILD_DIR/apps/oslam"
if [[ ! -f "$run_dir/odometry.csv" ]]; then
  rm -rf "$run_dir"  # an interrupted simulation: start again
  "$oslam" simulate "$scene_file" -o "$run_dir" --seed 1
fi
"$oslam" train-colors "$run_dir/classes.yaml" --from-ground-truth "$run_dir" --quiet
# The class confusion P(detected | true) measured with the learnt colours and
# image shapes (colour alone fires the ball detector on the orange door too).
"$oslam" detect "$run_dir" -o "$run_dir/training_detections.csv" --quiet
"$oslam" eval-detect "$run_dir" --detections "$run_dir/training_detections.csv" \
  --write-confusion "$run_dir/classes.yaml" --quiet
"$oslam" run "$run_dir" -o "$out_dir" --seed 1
oslam_log "O-Map: $out_dir/map.glb (Blender: File > Import > glTF 2.0); report: $out_dir/report.md"

#!/bin/bash
# The Snakemake workflow (workflow/Snakefile) run locally with -j 2 on three
# small simulated recordings: checkerboard pictures and a floor board rendered
# by `oslam simulate` for `oslam calibrate` (once, the mount from the floor
# board), three lab drives (30 fps video, 20 Hz odometry 0.3 s ahead) run by
# `oslam run`, one summary table. Checks the table: one complete row per
# recording, every map finds objects, and a second Snakemake call has nothing
# to do. Exit 77 (skipped) when snakemake is missing and cannot be installed.
# usage: snakemake_workflow_test.sh OSLAM SOURCE_DIR
set -euo pipefail
OSLAM=${1:?usage: snakemake_workflow_test.sh OSLAM SOURCE_DIR}
SOURCE=${2:?usage: snakemake_workflow_test.sh OSLAM SOURCE_DIR}

# Setup: Debian's snakemake, installed here when missing (only this test
# needs it, so it is not in scripts/common.sh's build packages).
if ! command -v snakemake >/dev/null 2>&1; then
  sudo=()
  if [[ "$(id -u)" != 0 ]]; then sudo=(sudo -n); fi
  if ! DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -qq --no-install-recommends \
      snakemake >/dev/null 2>&1; then
    echo "snakemake is not installed and apt-get could not install it: skipped" >&2
    exit 77
  fi
fi

WORK=$(mktemp -d)
[[ -n "${KEEP_WORK:-}" ]] || trap 'rm -rf "$WORK"' EXIT
cd "$WORK"

# One scene per checkerboard picture: the LPA camera (as the lab scene's),
# one board, flat light.
board_scene() {  # x y z yaw pitch roll square
  cat <<SCENE
camera: {preset: lpa}
classes:
  - {name: thing, display_rgb: [200, 30, 30], diameter_mean_m: 0.3, diameter_std_m: 0.1, height_mean_m: 0.5, height_std_m: 0.1}
floor: {colour: [110, 105, 100]}
ceiling: {height_m: 2.4, colour: [170, 170, 165]}
lighting: {ambient: 1.0}
sensor: {noise_std: 2.0}
objects:
  - {shape: checkerboard, position_m: [$1, $2, $3], cols: 8, rows: 7, square_m: $7, yaw_rad: $4, pitch_rad: $5, roll_rad: $6, colour: [235, 235, 235], colour2: [20, 20, 20]}
path: {start_pose: [0, 0, 0], commands: F1}
SCENE
}
mkdir -p boards scenes
for k in $(seq 0 13); do
  read -r x y z yaw pitch roll < <(awk -v k="$k" 'BEGIN {
    pi = atan2(0, -1); bearing = 2 * pi * k / 14
    d = 0.33 + 0.1 * ((k * 7) % 5) / 4; e = -0.7 + 0.7 * ((k * 3) % 7) / 6
    printf "%.6f %.6f %.6f %.6f %.6f %.6f\n", d * cos(bearing), d * sin(bearing),
      0.76 + d * sin(e) / cos(e), bearing + pi / 2, -e + 0.2 * sin(k), 0.3 * cos(2 * k) }')
  board_scene "$x" "$y" "$z" "$yaw" "$pitch" "$roll" 0.03 > "scenes/board_$k.yaml"
  "$OSLAM" simulate "scenes/board_$k.yaml" -o "render_$k" --frames 1 --quiet
  mv "render_$k/frames/000000.png" "$(printf 'boards/view_%02d.png' "$k")"
done
# The floor board: 10 cm squares, flat on the floor 1 m ahead, 0.25 m left,
# its rows turned 0.3 rad.
board_scene 1.0 0.25 0.002 0.3 -1.5707963267948966 0 0.1 > scenes/floor.yaml
"$OSLAM" simulate scenes/floor.yaml -o render_floor --frames 1 --quiet
mv render_floor/frames/000000.png floor_board.png

# Three recordings of the lab, each with its own seed; the colours taught
# from the simulator's ground truth.
mkdir -p recordings
for seed in 1 2 3; do
  "$OSLAM" simulate "$SOURCE/samples/scenes/lab.yaml" -o "recordings/drive_$seed" --frames 40 \
    --seed "$seed" --video 30 --odometry-rate 20 --odometry-offset 0.3 --quiet
  "$OSLAM" train-colors "recordings/drive_$seed/classes.yaml" \
    --from-ground-truth "recordings/drive_$seed" --quiet
  rm "recordings/drive_$seed/camera.yaml"  # the workflow calibrates
done

cat > runs.yaml <<CONFIG
recordings: recordings
out: results
boards: boards
calibrate_args: --pattern 7x6 --square 0.03 --model hyperbolic --mirror-a 0.03929 --mirror-b 0.01965 --floor-board $WORK/floor_board.png --floor-square 0.1 --board-at 1.0,0.25,0.3
run_args: --set frames.time_offset_s=0.3 --quiet
oslam: $OSLAM
threads: 1
CONFIG

if ! snakemake -s "$SOURCE/workflow/Snakefile" --configfile runs.yaml -j 2 --quiet; then
  for log in results/logs/*.log; do echo "--- $log"; tail -n 20 "$log"; done
  exit 1
fi
echo "--- results/summary.csv"
cat results/summary.csv
grep -q "^mount: focus height" results/logs/calibrate.log || {
  echo "calibrate did not report the mount"; cat results/logs/calibrate.log; exit 1; }
grep "^mount:" results/logs/calibrate.log

python3 - results/summary.csv <<'CHECK'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
assert [r["run"] for r in rows] == ["drive_1", "drive_2", "drive_3"], rows
for r in rows:
    assert r["status"] == "complete", r
    assert int(r["frames_kept"]) >= 20, r
    assert int(r["found"]) >= 3 and int(r["true_objects"]) == 7, r
    assert float(r["ate_rmse_m"]) < 0.5, r
    assert float(r["seconds"]) > 0, r
print("summary: 3 complete runs")
CHECK

# Everything is up to date: a second call runs nothing.
if ! snakemake -s "$SOURCE/workflow/Snakefile" --configfile runs.yaml -j 2 -n 2>&1 |
    grep -q "Nothing to be done"; then
  echo "the second call would run jobs again"; exit 1
fi
echo "workflow: OK"

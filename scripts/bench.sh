#!/usr/bin/env bash
# Build if needed, run the benchmarks of docs/benchmarks.md and print their
# tables as Markdown rows, headed by the machine (cores, CPU, OS), the date
# and the commit.
#
#   scripts/bench.sh                 every group except victoria-raw
#   scripts/bench.sh solver sampler  only these groups
#   scripts/bench.sh --list          the groups, what they run, what they need
#
# Options:
#   --min-time S   Google Benchmark's --benchmark_min_time for the micro-benchmarks
#                  (default: the library's 0.5 s)
#   --work DIR     where the `run` and `victoria` groups write their runs
#                  (default: BUILD/bench-runs; simulated runs are kept and reused)
#   --out DIR      where the raw JSON and logs go (default: BUILD/bench-results/DATE)
#
# Figures are only worth publishing from a quiet machine: the script prints the
# load average and warns when other work is running.
#
# Real data: the landmark groups need the Victoria Park files. The benchmark
# programs look for ../shared/data/victoria_park next to the repository (fixed
# at build time); the `victoria` group's commands read OSLAM_DATA_DIR (default
# ../shared/data). Without the data those groups print a message and are
# skipped.
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

ALL_GROUPS=(camera simulator detect solver ceres sampler landmark run export victoria)
EXTRA_GROUPS=(victoria-raw)
DATA_DIR="${OSLAM_DATA_DIR:-$OSLAM_ROOT/../shared/data}"
# Where the compiled landmark benchmarks look (bench/victoria_park_data.h).
BENCH_DATA_FILE="$OSLAM_ROOT/../shared/data/victoria_park/with_ids/victoria_park.txt"

usage() {  # [EXIT_CODE]
  sed -n '2,24p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//' >&2
  exit "${1:-2}"
}

list_groups() {
  cat <<'EOF'
group         runs                                                   needs
camera        build/bench/camera_bench                               -
simulator     build/bench/simulator_bench                            -
detect        build/bench/detect_bench                               -
solver        build/bench/solver_bench (timed cases, not the fixed-count ones)   -
ceres         build/bench/ceres_bench                                libceres-dev at build time
sampler       build/bench/sampler_bench                              -
landmark      build/bench/landmark_bench, landmark_association_bench ../shared/data/victoria_park
              (and rigid_alignment_bench, which needs no data)
run           oslam run on lab and long_loop, oslam slam long runs   - (simulates the runs once)
export        build/bench/export_bench on lab and long_loop          - (runs oslam run once)
victoria      oslam map --landmarks (known, unknown association)     ../shared/data/victoria_park
victoria-raw  oslam map on the raw drive (about 10 min; only when named)  ../shared/data/victoria_park
EOF
}

groups=()
min_time=""
work_dir=""
out_dir=""
while (($#)); do
  case "$1" in
    --list) list_groups; exit 0 ;;
    --min-time) min_time="${2:?--min-time needs seconds}"; shift 2 ;;
    --work) work_dir="${2:?--work needs a folder}"; shift 2 ;;
    --out) out_dir="${2:?--out needs a folder}"; shift 2 ;;
    -h|--help) usage 0 ;;
    -*) echo "bench.sh: unknown option $1" >&2; usage ;;
    *)
      if [[ " ${ALL_GROUPS[*]} ${EXTRA_GROUPS[*]} " != *" $1 "* ]]; then
        echo "bench.sh: unknown group '$1' (scripts/bench.sh --list)" >&2
        exit 2
      fi
      groups+=("$1"); shift ;;
  esac
done
((${#groups[@]})) || groups=("${ALL_GROUPS[@]}")

oslam_install_missing
oslam_build

BENCH="$OSLAM_BUILD_DIR/bench"
OSLAM="$OSLAM_BUILD_DIR/apps/oslam"
stamp="$(date -u +%Y-%m-%dT%H%MZ)"
work_dir="${work_dir:-$OSLAM_BUILD_DIR/bench-runs}"
out_dir="${out_dir:-$OSLAM_BUILD_DIR/bench-results/$stamp}"
mkdir -p "$work_dir" "$out_dir"

# ---------------------------------------------------------------- helpers

# Google Benchmark's JSON (one field per line) -> one line per benchmark run,
# fields "key=value" separated by tabs.
bench_records() {
  awk '
    /"benchmarks": *\[/ { inside = 1; next }
    !inside { next }
    /^[[:space:]]*\][[:space:]]*,?[[:space:]]*$/ { inside = 0; next }
    /^[[:space:]]*\{[[:space:]]*$/ { record = ""; next }
    /^[[:space:]]*\},?[[:space:]]*$/ { print record; next }
    /^[[:space:]]*"[^"]+": / {
      line = $0
      sub(/^[[:space:]]*"/, "", line)
      key = line; sub(/".*/, "", key)
      value = line; sub(/^[^"]*": */, "", value); sub(/,[[:space:]]*$/, "", value)
      gsub(/^"|"$/, "", value)
      record = record (record == "" ? "" : "\t") key "=" value
    }' "$1"
}

# The value of KEY in a record ("" when absent). The last occurrence wins: a
# user counter comes after the standard fields, and solver_bench's counter
# "iterations" (LM iterations) shares its name with the benchmark's own.
get() {
  awk -F'\t' -v key="$2" '{
    value = ""
    for (i = 1; i <= NF; ++i) {
      eq = index($i, "=")
      if (substr($i, 1, eq - 1) == key) value = substr($i, eq + 1)
    }
    print value
  }' <<<"$1"
}

# fmt VALUE DIGITS: fixed-point, "–" when empty.
fmt() {
  if [[ -z "$1" ]]; then printf '–'; else LC_ALL=C printf "%.${2}f" "$1"; fi
}

# to_unit VALUE UNIT TARGET: a Google Benchmark time (UNIT ns, us, ms or s) in TARGET.
to_unit() {
  [[ -n "$1" ]] || return 0
  awk -v v="$1" -v u="$2" -v target="$3" 'BEGIN {
    f["ns"] = 1e-9; f["us"] = 1e-6; f["ms"] = 1e-3; f["s"] = 1
    printf "%.6g", v * f[u] / f[target] }'
}

# Runs a benchmark program: JSON to OUT/NAME.json, console to OUT/NAME.log.
# Returns 1 (with a message) when the program is missing.
run_bench() {
  local name="$1"; shift
  if [[ ! -x "$BENCH/$name" ]]; then
    oslam_log "skipped $name: not built ($BENCH/$name)"
    return 1
  fi
  oslam_log "running $name${*:+ $*}"
  local args=(--benchmark_out="$out_dir/$name.json" --benchmark_out_format=json)
  [[ -n "$min_time" ]] && args+=(--benchmark_min_time="$min_time")
  "$BENCH/$name" "${args[@]}" "$@" >"$out_dir/$name.log" 2>&1 || {
    tail -n 20 "$out_dir/$name.log" >&2
    oslam_log "$name failed; log in $out_dir/$name.log"
    return 1
  }
}

# Every benchmark run of a program whose name matches REGEX (awk syntax).
records_of() {
  bench_records "$out_dir/$1.json" | awk -F'\t' -v re="$2" '{
    split($1, kv, "="); if (kv[2] ~ re) print }'
}

# A skipped benchmark (SkipWithError) leaves error_occurred in its record.
skipped() { [[ "$(get "$1" error_occurred)" == "true" ]]; }

section() { printf '\n### %s\n\n' "$1"; }

have_bench_data() {
  if [[ -f "$BENCH_DATA_FILE" ]]; then return 0; fi
  printf 'Skipped: %s is absent (the Victoria Park data set, see README.md).\n' \
    "$(realpath -m "$BENCH_DATA_FILE")"
  return 1
}

have_cli_data() {
  if [[ -f "$DATA_DIR/victoria_park/with_ids/victoria_park.txt" ]]; then return 0; fi
  printf 'Skipped: %s/victoria_park is absent (set OSLAM_DATA_DIR to the data folder).\n' \
    "$(realpath -m "$DATA_DIR")"
  return 1
}

# cpu_timed LOG COMMAND...: runs COMMAND (output to LOG) under /usr/bin/time and
# prints "WALL CPU" in seconds (CPU = user + system, all threads).
cpu_timed() {
  local log="$1"; shift
  local tfile="$out_dir/.time.$$"
  if /usr/bin/time -f '%e %U %S' -o "$tfile" "$@" >"$log" 2>&1; then
    awk '{ printf "%.2f %.2f", $1, $2 + $3 }' "$tfile"
    rm -f "$tfile"
  else
    rm -f "$tfile"
    tail -n 20 "$log" >&2
    oslam_log "failed: $*; log in $log"
    return 1
  fi
}

# ---------------------------------------------------------------- groups

# What each micro-benchmark times (the "what is timed" column of benchmarks.md).
declare -A WHAT=(
  [BM_ProjectToPixelWithJacobian]="a robot-frame point to a pixel, with its 2 × 3 Jacobian"
  [BM_BackProjectFullFrame]="every pixel of a 640 × 480 frame to a ray (307,200 rays)"
  [BM_PredictSliceWithJacobians]="a cylinder's bounding slice with all its Jacobians"
  [BM_RenderLabFrame]="ray casting, shading, noise, 8-bit output"
  [BM_RenderLabFrameWithGroundTruth]="the same plus the unoccluded footprint of every visible object"
  [BM_RenderLabFrameBruteForce]="every primitive tested for every pixel (no bearing bins)"
  [BM_RendererSetup]="back-projecting every pixel once per camera"
  [BM_ColourBlobDetection640x480/0/0]="no opening, look-alike separation off"
  [BM_ColourBlobDetection640x480/0/1]="no opening, look-alike separation on"
  [BM_ColourBlobDetection640x480/1/1]="opening radius 1, separation on (oslam detect's defaults)"
  [BM_ColourDetectionWithSiftVerification]="colour blobs + SIFT verification"
  [BM_LpaScaleFromOdometry]="cold solve"
  [BM_LpaWarmResolveAfterSplit]="full warm re-solve after a split"
  [BM_LpaWarmResolveSameAssociation]="warm re-solve of the same association"
  [BM_LpaWarmOneLinearStepAfterSplit/0]="one linearised step after a split, linearised afresh"
  [BM_LpaWarmOneLinearStepAfterSplit/1]="one linearised step after a split, linearisations reused"
  [BM_LpaWarmOneLinearStepAfterSplit/2]="the same, kept linearisations forgotten before each solve"
  [BM_LpaProposalsFromOneState/0]="different proposals from one state, automatic ordering"
  [BM_LpaProposalsFromOneState/1]="... with reused linearisations"
  [BM_LpaProposalsFromOneState/2]="... and AMD (the sampler's settings)"
)

# A CPU time as "12.34 ms" or "1.23 s".
cpu_text() {  # VALUE UNIT
  local ms; ms=$(to_unit "$1" "$2" ms)
  if awk -v v="$ms" 'BEGIN { exit !(v >= 1000) }'; then
    echo "$(fmt "$(to_unit "$1" "$2" s)" 2) s"
  else
    echo "$(fmt "$ms" 2) ms"
  fi
}

group_camera() {
  section "Camera model (camera_bench)"
  run_bench camera_bench || return 0
  echo "| benchmark | what is timed | CPU time per call |"
  echo "|---|---|---|"
  while IFS= read -r r; do
    local name cpu unit
    name=$(get "$r" name); cpu=$(get "$r" cpu_time); unit=$(get "$r" time_unit)
    case "$name" in
      *FullFrame*) echo "| \`$name\` | ${WHAT[$name]} | $(fmt "$(to_unit "$cpu" "$unit" ms)" 1) ms |" ;;
      *) echo "| \`$name\` | ${WHAT[$name]} | $(fmt "$(to_unit "$cpu" "$unit" ns)" 0) ns |" ;;
    esac
  done < <(records_of camera_bench .)
}

group_simulator() {
  section "Simulator (simulator_bench)"
  run_bench simulator_bench || return 0
  echo "| benchmark | what is timed | CPU time per frame | frames/s (CPU) |"
  echo "|---|---|---|---|"
  while IFS= read -r r; do
    local name cpu unit per_s
    name=$(get "$r" name); cpu=$(get "$r" cpu_time); unit=$(get "$r" time_unit)
    per_s=$(get "$r" items_per_second)
    echo "| \`$name\` | ${WHAT[$name]} | $(fmt "$(to_unit "$cpu" "$unit" ms)" 1) ms | $(fmt "$per_s" 1) |"
  done < <(records_of simulator_bench .)
}

group_detect() {
  section "Detection (detect_bench)"
  run_bench detect_bench || return 0
  echo "| benchmark | what is timed | detections per frame | CPU time per frame | frames/s |"
  echo "|---|---|---|---|---|"
  while IFS= read -r r; do
    local name cpu unit per_s per_frame
    name=$(get "$r" name); cpu=$(get "$r" cpu_time); unit=$(get "$r" time_unit)
    per_s=$(get "$r" items_per_second)
    per_frame=$(get "$r" detections_per_frame)
    [[ -z "$per_frame" ]] && per_frame=$(get "$r" verified_per_frame)
    echo "| \`$name\` | ${WHAT[$name]} | $(fmt "$per_frame" 1) | $(fmt "$(to_unit "$cpu" "$unit" ms)" 2) ms | $(fmt "$per_s" 0) |"
  done < <(records_of detect_bench .)
}

group_solver() {
  section "Geometric solver (solver_bench)"
  # The timed registrations only: the fixed-count ones (/iterations:100 and
  # :500) are for instruction counts with perf.
  run_bench solver_bench \
    --benchmark_filter='^BM_(LpaScaleFromOdometry|LpaWarm[A-Za-z]*(/[0-9]+)?|LpaProposalsFromOneState/[0-9]+|Growth[A-Za-z]*/[0-9]+|Large[A-Za-z]*(/[0-9]+)?(/iterations:2)?)$' \
    || return 0
  echo "LPA scale:"
  echo
  echo "| benchmark | what is timed | CPU time | LM iterations |"
  echo "|---|---|---|---|"
  while IFS= read -r r; do
    local name; name=$(get "$r" name)
    printf '| `%s` | %s | %s | %s |\n' "$name" "${WHAT[$name]}" \
      "$(cpu_text "$(get "$r" cpu_time)" "$(get "$r" time_unit)")" "$(fmt "$(get "$r" iterations)" 0)"
  done < <(records_of solver_bench '^BM_Lpa')
  echo
  echo "Growth (cold):"
  echo
  echo "| benchmark | poses / objects / detections | CPU time | LM iterations | factorisation per iteration | keyframe start |"
  echo "|---|---|---|---|---|---|"
  while IFS= read -r r; do
    local name k start
    name=$(get "$r" name); k=${name##*/}; start=$(get "$r" start_ms)
    printf '| `%s` | %s / %s / %s | %s | %s | %s ms | %s |\n' "$name" \
      "$(fmt "$(get "$r" poses)" 0)" "$((10 * k))" "$(fmt "$(get "$r" detections)" 0)" \
      "$(cpu_text "$(get "$r" cpu_time)" "$(get "$r" time_unit)")" "$(fmt "$(get "$r" iterations)" 0)" \
      "$(fmt "$(get "$r" factorize_ms_per_iter)" 2)" \
      "$([[ -n "$start" ]] && echo "$(fmt "$start" 0) ms" || echo –)"
  done < <(records_of solver_bench '^BM_Growth')
  echo
  echo "10,000 poses:"
  echo
  echo "| benchmark | CPU time | of which the keyframe start | loop closures | final LM iterations | converged | final cost |"
  echo "|---|---|---|---|---|---|---|"
  while IFS= read -r r; do
    local start; start=$(get "$r" start_ms)
    printf '| `%s` | %s | %s | %s | %s | %s | %s |\n' "$(get "$r" name)" \
      "$(cpu_text "$(get "$r" cpu_time)" "$(get "$r" time_unit)")" \
      "$([[ -n "$start" ]] && echo "$(fmt "$(awk -v v="$start" 'BEGIN { print v / 1000 }')" 2) s" || echo –)" \
      "$(fmt "$(get "$r" start_closures)" 0)" "$(fmt "$(get "$r" iterations)" 0)" \
      "$([[ "$(get "$r" converged)" == 1* ]] && echo yes || echo no)" "$(fmt "$(get "$r" final_cost)" 1)"
  done < <(records_of solver_bench '^BM_Large')
}

group_ceres() {
  section "Against Ceres (ceres_bench)"
  if [[ ! -x "$BENCH/ceres_bench" ]]; then
    echo "Skipped: ceres_bench is not built (apt-get install libceres-dev, then run cmake again)."
    return 0
  fi
  run_bench ceres_bench || return 0
  echo "| benchmark (k / line search) | poses / detections | oslam | Ceres | oslam / Ceres | LM iterations oslam / Ceres | final cost oslam / Ceres |"
  echo "|---|---|---|---|---|---|---|"
  while IFS= read -r r; do
    printf '| `%s` | %s / %s | %s ms | %s ms | %s | %s / %s | %s / %s |\n' \
      "$(get "$r" name)" "$(fmt "$(get "$r" poses)" 0)" "$(fmt "$(get "$r" detections)" 0)" \
      "$(fmt "$(get "$r" oslam_ms)" 1)" "$(fmt "$(get "$r" ceres_ms)" 1)" \
      "$(fmt "$(get "$r" oslam_over_ceres)" 2)" "$(fmt "$(get "$r" oslam_iters)" 0)" \
      "$(fmt "$(get "$r" ceres_iters)" 0)" "$(fmt "$(get "$r" oslam_cost)" 6)" \
      "$(fmt "$(get "$r" ceres_cost)" 6)"
  done < <(records_of ceres_bench .)
}

group_sampler() {
  section "O-SLAM sampler (sampler_bench)"
  run_bench sampler_bench || return 0
  echo "| k | poses / objects / tracks | solves | cold-chain time per proposal | MC³ one after another | MC³ on threads |"
  echo "|---|---|---|---|---|---|"
  local k
  for k in 1 2 4; do
    local seq thr
    seq=$(records_of sampler_bench "/k:$k/threads:0/")
    thr=$(records_of sampler_bench "/k:$k/threads:1/")
    [[ -z "$seq" ]] && continue
    printf '| %s | %s / %s / %s | %s | %s ms | %s s | %s s |\n' "$k" \
      "$(fmt "$(get "$seq" poses)" 0)" "$(fmt "$(get "$seq" objects)" 0)" \
      "$(fmt "$(get "$seq" tracks)" 0)" "$(fmt "$(get "$seq" solves)" 0)" \
      "$(fmt "$(get "$seq" ms_per_proposal)" 1)" "$(fmt "$(get "$seq" mc3_s)" 2)" \
      "$(fmt "$(get "$thr" mc3_s)" 2)"
  done
}

group_landmark() {
  section "RANSAC of the joint re-entry merges (rigid_alignment_bench)"
  if run_bench rigid_alignment_bench; then
    echo "| benchmark (old / recent / clutter) | CPU per call | pairs |"
    echo "|---|---:|---:|"
    while IFS= read -r r; do
      printf '| `%s` | %s ms | %s |\n' "$(get "$r" name)" \
        "$(fmt "$(to_unit "$(get "$r" cpu_time)" "$(get "$r" time_unit)" ms)" 1)" \
        "$(fmt "$(get "$r" pairs)" 0)"
    done < <(records_of rigid_alignment_bench .)
  fi
  section "Landmark SLAM on Victoria Park (landmark_bench)"
  if have_bench_data && run_bench landmark_bench; then
    echo "| benchmark | poses / sightings / landmarks | cold, CPU | staged init | final solve | final LM iterations | χ² per residual |"
    echo "|---|---|---|---|---|---|---|"
    while IFS= read -r r; do
      skipped "$r" && { echo "| \`$(get "$r" name)\` | skipped: $(get "$r" error_message) |"; continue; }
      printf '| `%s` | %s / %s / %s | %s ms | %s ms | %s ms | %s | %s |\n' \
        "$(get "$r" name)" "$(fmt "$(get "$r" poses)" 0)" "$(fmt "$(get "$r" sightings)" 0)" \
        "$(fmt "$(get "$r" landmarks)" 0)" \
        "$(fmt "$(to_unit "$(get "$r" cpu_time)" "$(get "$r" time_unit)" ms)" 0)" \
        "$(fmt "$(get "$r" init_ms)" 0)" "$(fmt "$(get "$r" final_solve_ms)" 0)" \
        "$(fmt "$(get "$r" iterations)" 0)" "$(fmt "$(get "$r" chi2_per_residual)" 2)"
    done < <(records_of landmark_bench KnownAssociation)
    echo
    echo "| benchmark | poses | warm re-solve, CPU | LM iterations | log-evidence change |"
    echo "|---|---|---|---|---|"
    while IFS= read -r r; do
      skipped "$r" && continue
      printf '| `%s` | %s | %s ms | %s | %s |\n' "$(get "$r" name)" "$(fmt "$(get "$r" poses)" 0)" \
        "$(fmt "$(to_unit "$(get "$r" cpu_time)" "$(get "$r" time_unit)" ms)" 1)" \
        "$(fmt "$(get "$r" iterations)" 0)" "$(fmt "$(get "$r" log_evidence_change)" 2)"
    done < <(records_of landmark_bench WarmResolve)
  fi
  section "Landmark association: cost of one proposal (landmark_association_bench)"
  if have_bench_data && run_bench landmark_association_bench; then
    echo "| poses | tracks | marginal (closed form) | local (poses held) | exact (warm re-solve) | full solve of the reference |"
    echo "|---|---|---|---|---|---|"
    local poses
    for poses in 1000 2000 4000 6969; do
      local exact local_ marginal
      exact=$(records_of landmark_association_bench "/poses:$poses/mode:0/")
      local_=$(records_of landmark_association_bench "/poses:$poses/mode:1/")
      marginal=$(records_of landmark_association_bench "/poses:$poses/mode:2/")
      [[ -z "$exact$local_$marginal" ]] && continue
      local any="${exact:-${local_:-$marginal}}"
      skipped "$any" && { echo "| $poses | skipped: $(get "$any" error_message) |"; continue; }
      printf '| %s | %s | %s ms | %s ms | %s ms | %s ms |\n' "$poses" "$(fmt "$(get "$any" tracks)" 0)" \
        "$(fmt "$(to_unit "$(get "$marginal" cpu_time)" "$(get "$marginal" time_unit)" ms)" 3)" \
        "$(fmt "$(to_unit "$(get "$local_" cpu_time)" "$(get "$local_" time_unit)" ms)" 3)" \
        "$(fmt "$(to_unit "$(get "$exact" cpu_time)" "$(get "$exact" time_unit)" ms)" 1)" \
        "$(fmt "$(get "$exact" reference_solve_ms)" 0)"
    done
  fi
}

# Simulates SCENE once into the work folder and prepares it as
# scripts/quickstart.sh does (colours and shapes, measured confusion).
prepare_run() {
  local scene="$1" run="$work_dir/$1"
  if [[ ! -f "$run/odometry.csv" ]]; then
    rm -rf "$run"
    oslam_log "simulating $scene into $run"
    "$OSLAM" simulate "$OSLAM_ROOT/samples/scenes/$scene.yaml" -o "$run" --seed 1 --quiet ||
      return 1
  fi
  if [[ ! -f "$run/.bench-prepared" ]]; then
    "$OSLAM" train-colors "$run/classes.yaml" --from-ground-truth "$run" --quiet || return 1
    "$OSLAM" detect "$run" -o "$run/training_detections.csv" --quiet || return 1
    "$OSLAM" eval-detect "$run" --detections "$run/training_detections.csv" \
      --write-confusion "$run/classes.yaml" --quiet || return 1
    touch "$run/.bench-prepared"
  fi
}

# The stage rows of an `oslam run` report.md: "| detect | 0.68 | 1.28 |".
stage_time() {  # REPORT STAGE -> "WALL (CPU C)"
  awk -F'|' -v stage="$2" '
    { gsub(/ /, "", $2) }
    $2 == stage { gsub(/ /, "", $3); gsub(/ /, "", $4); printf "%s s (CPU %s)", $3, $4; exit }' "$1"
}

# The parts of the export stage (docs/benchmarks.md, "Export") on the runs'
# own O-Maps; CPU time, the steadier measure on a shared machine.
group_export() {
  section "Export (export_bench)"
  echo "| part (CPU per call, ms) | \`lab\` | \`long_loop\` |"
  echo "|---|---|---|"
  local scene rows=()
  for scene in lab long_loop; do
    local run="$work_dir/$scene" out="$work_dir/${scene}_out"
    if [[ ! -f "$out/omap.json" ]]; then
      prepare_run "$scene" || return 0
      "$OSLAM" run "$run" -o "$out" --seed 1 --quiet >"$out_dir/run_$scene.log" 2>&1 || {
        tail -n 20 "$out_dir/run_$scene.log" >&2; return 0; }
    fi
    OSLAM_BENCH_RUN="$run" OSLAM_BENCH_OMAP="$out/omap.json" run_bench export_bench || return 0
    mv "$out_dir/export_bench.json" "$out_dir/export_bench_$scene.json"
  done
  local name label
  for name in BM_RenderView BM_Figures BM_Models BM_Overlay/0 BM_Overlay/1 BM_Overlay/2; do
    case "$name" in
      BM_RenderView) label="perspective view, 800×800 (process CPU)" ;;
      BM_Figures) label="bird's-eye view and error plot" ;;
      BM_Models) label="glTF (both) and PLY bytes" ;;
      BM_Overlay/0) label="one overlay drawn" ;;
      BM_Overlay/1) label="one overlay drawn and encoded as JPEG" ;;
      BM_Overlay/2) label="one overlay drawn and encoded as PNG" ;;
    esac
    local cells=()
    for scene in lab long_loop; do
      local record
      record=$(records_of "export_bench_$scene" "^$name" | head -n 1)
      cells+=("$(fmt "$(to_unit "$(get "$record" cpu_time)" "$(get "$record" time_unit)" ms)" 2)")
    done
    printf '| %s | %s | %s |\n' "$label" "${cells[0]}" "${cells[1]}"
  done
}

group_run() {
  section "oslam run on lab and long_loop"
  local today; today=$(date -u +%Y-%m-%d)
  echo "| run | frames / detections | detect | O-SLAM | export | total | measured |"
  echo "|---|---|---|---|---|---|---|"
  local scene
  for scene in lab long_loop; do
    prepare_run "$scene" || continue
    local run="$work_dir/$scene" out="$work_dir/${scene}_out"
    rm -rf "$out"
    oslam_log "oslam run $scene"
    "$OSLAM" run "$run" -o "$out" --seed 1 >"$out_dir/run_$scene.log" 2>&1 || {
      tail -n 20 "$out_dir/run_$scene.log" >&2; continue; }
    local frames detections
    frames=$(find "$run/frames" -name '*.png' | wc -l)
    detections=$(($(grep -vc '^#' "$out/detections.csv" || true) - 1))
    printf '| `%s` | %s / %s | %s | %s | %s | %s | %s |\n' "$scene" "$frames" "$detections" \
      "$(stage_time "$out/report.md" detect)" "$(stage_time "$out/report.md" o-slam)" \
      "$(stage_time "$out/report.md" export)" "$(stage_time "$out/report.md" total)" "$today"
  done

  section "oslam slam on long_loop"
  local run="$work_dir/long_loop" detections="$work_dir/long_loop_out/detections.csv" t
  if [[ ! -f "$detections" ]]; then
    echo "Skipped: no long_loop detections (the oslam run above failed)."
    return 0
  fi
  echo "| run | wall | CPU | measured |"
  echo "|---|---|---|---|"
  if t=$(cpu_timed "$out_dir/slam_defaults.log" "$OSLAM" slam "$run" --detections "$detections" \
           -o "$work_dir/long_loop_slam.json" --seed 1 --quiet); then
    echo "| defaults, seed 1 | ${t% *} s | ${t#* } s | $today |"
  fi
  if t=$(cpu_timed "$out_dir/slam_long.log" "$OSLAM" slam "$run" --detections "$detections" \
           -o "$work_dir/long_loop_long.json" --seed 1 --hill-climb 400 --samples 2200 \
           --burn-in 200 --quiet); then
    echo "| thesis long run, seed 1 | ${t% *} s | ${t#* } s | $today |"
  fi
  if t=$(cpu_timed "$out_dir/slam_long_sequential.log" "$OSLAM" slam "$run" \
           --detections "$detections" -o "$work_dir/long_loop_long_sequential.json" --seed 1 \
           --hill-climb 400 --samples 2200 --burn-in 200 --sequential --quiet); then
    echo "| thesis long run, \`--sequential\` (chains one after another), seed 1 | ${t% *} s | ${t#* } s | $today |"
  fi
}

group_victoria() {
  section "oslam map --landmarks on Victoria Park"
  have_cli_data || return 0
  local file="$DATA_DIR/victoria_park/with_ids/victoria_park.txt" dir="$work_dir/victoria" t
  local today; today=$(date -u +%Y-%m-%d)
  mkdir -p "$dir"
  echo "| run | wall | CPU | measured |"
  echo "|---|---|---|---|"
  if t=$(cpu_timed "$out_dir/victoria_known.log" "$OSLAM" map --landmarks "$file" \
           -o "$dir/known/omap.json" --quiet); then
    echo "| known association (with covariances) | ${t% *} s | ${t#* } s | $today |"
  fi
  if t=$(cpu_timed "$out_dir/victoria_unknown.log" "$OSLAM" map --landmarks "$file" \
           --unknown-association --odometry-noise-scale 10 -o "$dir/unknown/omap.json"); then
    echo "| ids hidden, defaults (20-pose windows, joint re-entry merges) | ${t% *} s | ${t#* } s | $today |"
    echo
    echo "The association found, against the file's ids (the command's own report):"
    echo
    grep -E "^ *([0-9]+ landmarks from|vs the file's ids|trajectory vs)" \
      "$out_dir/victoria_unknown.log" | sed 's/^ */    /' || true
  fi
}

group_victoria_raw() {
  section "oslam map on the raw Victoria Park drive"
  have_cli_data || return 0
  local raw="$DATA_DIR/victoria_park/detections_no_ids" dir="$work_dir/victoria" t
  mkdir -p "$dir"
  echo "| run | wall | CPU | measured |"
  echo "|---|---|---|---|"
  if t=$(cpu_timed "$out_dir/victoria_raw.log" "$OSLAM" map --preset victoria-raw \
           --landmarks "$raw" --gps "$raw/gps.dat" -o "$dir/raw/omap.json"); then
    echo "| raw drive, the command of docs/benchmarks.md | ${t% *} s | ${t#* } s | $(date -u +%Y-%m-%d) |"
    echo
    grep -E "^ *([0-9]+ landmarks from|vs GPS)" "$out_dir/victoria_raw.log" | sed 's/^ */    /' || true
  fi
}

# ---------------------------------------------------------------- main

cores=$(nproc)
load=$(cut -d' ' -f1 /proc/loadavg)
cpu_model=$(awk -F': ' '/^model name/ { print $2; exit }' /proc/cpuinfo)
os=$(. /etc/os-release 2>/dev/null && echo "$PRETTY_NAME")
commit=$(git -C "$OSLAM_ROOT" rev-parse --short HEAD 2>/dev/null || echo unknown)
dirty=$(git -C "$OSLAM_ROOT" status --porcelain --untracked-files=no 2>/dev/null | head -c1)

echo "## Benchmarks, $(date -u '+%Y-%m-%d %H:%M UTC')"
echo
echo "Machine: ${cores} cores (${cpu_model:-unknown CPU}), ${os:-unknown OS}; build $(awk -F= '/^CMAKE_BUILD_TYPE:/ { print $2 }' "$OSLAM_BUILD_DIR/CMakeCache.txt"), commit ${commit}${dirty:+ (with local changes)}; load average at start ${load}."
if awk -v l="$load" -v c="$cores" 'BEGIN { exit !(l > 0.25 * c) }'; then
  echo
  echo "**The machine is busy (load ${load} on ${cores} cores): do not publish these figures.**"
fi
echo "Raw results: $out_dir"

for group in "${groups[@]}"; do
  "group_${group//-/_}"
done

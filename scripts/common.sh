# Shared by scripts/quickstart.sh and scripts/test.sh: install the Debian
# packages that are missing (and only those), then configure and build.
# Idempotent: a second run with nothing changed installs nothing and rebuilds
# nothing.
set -euo pipefail

OSLAM_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
OSLAM_BUILD_DIR="${OSLAM_BUILD_DIR:-$OSLAM_ROOT/build}"
OSLAM_CMAKE_EXTRA=()  # extra cmake arguments for the first configure

# Everything oslam builds against (Debian 12 names).
OSLAM_PACKAGES=(
  g++ make cmake pkg-config
  libeigen3-dev libopencv-dev libsuitesparse-dev libpng-dev libjpeg-dev
  libtinygltf-dev libstb-dev nlohmann-json3-dev libvtk9-dev
  libgtest-dev libbenchmark-dev
  # Off-screen rendering of the 3D views (perspective.png, oslam view
  # --screenshot) without an X display: Mesa's EGL and its software renderer.
  libegl-dev libegl-mesa0 libgl1-mesa-dri
  # Figures (PNG through PLplot's memory cairo device, SVG).
  libplplot-dev plplot-driver-cairo
  # CHOLMOD's supernodal kernels run on the system BLAS. Debian otherwise
  # picks ATLAS's generic build, which takes about twice as long per
  # LPA-scale factorisation. The threaded OpenBLAS, which the solver limits to one
  # thread: the single-threaded build is not safe to call from O-SLAM's
  # parallel chains (docs/benchmarks.md, "BLAS").
  libopenblas0-pthread
)

oslam_log() { printf '[oslam] %s\n' "$*" >&2; }

oslam_install_missing() {
  local missing=()
  local package
  for package in "${OSLAM_PACKAGES[@]}"; do
    if [[ "$(dpkg-query -W -f='${db:Status-Status}' "$package" 2>/dev/null)" != "installed" ]]; then
      missing+=("$package")
    fi
  done
  if ((${#missing[@]} == 0)); then
    return 0
  fi
  oslam_log "installing missing packages: ${missing[*]}"
  local sudo=()
  if [[ "$(id -u)" != 0 ]]; then sudo=(sudo); fi
  "${sudo[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -qq --no-install-recommends \
    "${missing[@]}" >/dev/null
}

oslam_build() {
  if [[ ! -f "$OSLAM_BUILD_DIR/CMakeCache.txt" ]]; then
    oslam_log "configuring in $OSLAM_BUILD_DIR"
    mkdir -p "$OSLAM_BUILD_DIR"
    # PCL's config prints warnings about optional I/O features; keep them in the log.
    cmake -S "$OSLAM_ROOT" -B "$OSLAM_BUILD_DIR" -DCMAKE_BUILD_TYPE=Release \
      "${OSLAM_CMAKE_EXTRA[@]}" >"$OSLAM_BUILD_DIR/configure.log" 2>&1 || {
      tail -n 40 "$OSLAM_BUILD_DIR/configure.log" >&2
      oslam_log "configure failed; full log in $OSLAM_BUILD_DIR/configure.log"
      return 1
    }
  fi
  oslam_log "building (this takes a few minutes the first time)"
  cmake --build "$OSLAM_BUILD_DIR" -j "$(nproc)" -- --no-print-directory >"$OSLAM_BUILD_DIR/build.log" 2>&1 || {
    tail -n 40 "$OSLAM_BUILD_DIR/build.log" >&2
    oslam_log "build failed; full log in $OSLAM_BUILD_DIR/build.log"
    return 1
  }
}

#!/usr/bin/env bash
# Install what is missing, build, and run the test suite.
#   scripts/test.sh              the default (quick) suite
#   scripts/test.sh --all        also the tests labelled "slow"
#   scripts/test.sh --sanitize   the default suite built with ASan + UBSan (in build-sanitize/)
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

label_filter=(-LE slow)
case "${1:-}" in
  --all) label_filter=() ;;
  --sanitize)
    OSLAM_BUILD_DIR="$OSLAM_ROOT/build-sanitize"
    OSLAM_CMAKE_EXTRA=(-DOSLAM_SANITIZE=ON -DOSLAM_BUILD_BENCH=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo)
    export ASAN_OPTIONS=detect_leaks=0 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
    ;;
  "") ;;
  *) echo "usage: scripts/test.sh [--all | --sanitize]" >&2; exit 2 ;;
esac

oslam_install_missing
oslam_build
oslam_log "running tests"
cd "$OSLAM_BUILD_DIR"
ctest "${label_filter[@]}" --output-on-failure -j "$(nproc)"

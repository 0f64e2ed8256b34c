#!/usr/bin/env bash
# Install what is missing, build, and run the test suite.
#   scripts/test.sh                  the default (quick) suite
#   scripts/test.sh --all            also the tests labelled "slow"
#   scripts/test.sh --sanitize       the default suite built with ASan + UBSan (in build-sanitize/)
#   scripts/test.sh --sanitize --all every test under ASan + UBSan
# Under the sanitizers any report fails the test: UBSan findings are not
# recoverable (-fno-sanitize-recover in the OSLAM_SANITIZE build), ASan stops
# at the first error, and LeakSanitizer is on. The command-line tests run the
# sanitized oslam binary, so the commands are covered too.
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

label_filter=(-LE slow)
for argument in "$@"; do
  case "$argument" in
    --all) label_filter=() ;;
    --sanitize)
      OSLAM_BUILD_DIR="$OSLAM_ROOT/build-sanitize"
      OSLAM_CMAKE_EXTRA=(-DOSLAM_SANITIZE=ON -DOSLAM_BUILD_BENCH=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo)
      export ASAN_OPTIONS="halt_on_error=1:detect_leaks=1"
      export LSAN_OPTIONS="suppressions=$OSLAM_ROOT/scripts/lsan-suppressions.txt:print_suppressions=0"
      export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
      ;;
    *) echo "usage: scripts/test.sh [--all] [--sanitize]" >&2; exit 2 ;;
  esac
done

oslam_install_missing
oslam_build
oslam_log "running tests"
cd "$OSLAM_BUILD_DIR"
ctest "${label_filter[@]}" --output-on-failure -j "$(nproc)"

#!/usr/bin/env bash
# Install what is missing, build, and run the test suite.
#   scripts/test.sh          the default (quick) suite
#   scripts/test.sh --all    also the tests labelled "slow"
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

label_filter=(-LE slow)
if [[ "${1:-}" == "--all" ]]; then label_filter=(); fi

oslam_install_missing
oslam_build
oslam_log "running tests"
cd "$OSLAM_BUILD_DIR"
ctest "${label_filter[@]}" --output-on-failure -j "$(nproc)"

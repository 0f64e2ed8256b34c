#!/usr/bin/env bash
# Rewrites the golden PNGs of tests/export/golden_test.cpp, view_test.cpp
# and (when blender is installed) blender_import_test.cpp on purpose (after
# an intended change to a figure or overlay). Look at every PNG before
# committing: the tests only check that later renders match these.
#   tests/golden/regenerate.sh            # uses $OSLAM_BUILD_DIR or build/
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
build="${OSLAM_BUILD_DIR:-$root/build}"
cmake --build "$build" -j2 --target export_test export_blender_test
OSLAM_REGENERATE_GOLDEN=1 "$build/tests/export_test" \
  --gtest_filter='Golden.*:View.MatchesTheGolden:-Golden.ComparisonRejectsAChangedFigure'
if command -v blender >/dev/null; then
  OSLAM_REGENERATE_GOLDEN=1 "$build/tests/export_blender_test" \
    --gtest_filter='BlenderImport.SceneImportsAsShapesTubesAndFloorAndRendersAsTheGolden'
else
  echo "blender is not installed: tests/golden/blender_workbench.png left as it is" >&2
fi
ls -l "$root"/tests/golden/*.png

#!/bin/sh
# Installs the Khronos glTF validator (npm package gltf-validator) into
# DEST/node_modules for the export tests, outside the source tree. Idempotent:
# does nothing when that version is already there. Exit 0 = installed, 1 = not
# available (no node/npm, or no registry); the tests then skip with a message.
# usage: install_gltf_validator.sh DEST
set -eu
VERSION=2.0.0-dev.3.10
DEST=${1:?usage: install_gltf_validator.sh DEST}
PACKAGE_JSON="$DEST/node_modules/gltf-validator/package.json"

if [ -f "$PACKAGE_JSON" ] && grep -q "\"version\": \"$VERSION\"" "$PACKAGE_JSON"; then
  exit 0
fi
for tool in node npm; do
  if ! command -v "$tool" >/dev/null 2>&1; then
    echo "gltf-validator: $tool not found; glTF validation tests will be skipped" >&2
    exit 1
  fi
done
# Install beside DEST and move into place, so an interrupted install never
# leaves a half-written package that looks installed.
mkdir -p "$(dirname "$DEST")"
STAGING="$DEST.staging.$$"
trap 'rm -rf "$STAGING"' EXIT
mkdir -p "$STAGING"
if ! npm install --prefix "$STAGING" --no-save --no-audit --no-fund --no-package-lock --fetch-retries=1 \
    --fetch-timeout=60000 --loglevel=error "gltf-validator@$VERSION" >"$STAGING.log" 2>&1; then
  echo "gltf-validator: npm install failed (offline?); glTF validation tests will be skipped:" >&2
  tail -n 5 "$STAGING.log" >&2
  rm -f "$STAGING.log"
  exit 1
fi
rm -f "$STAGING.log"
rm -rf "$DEST"
mv "$STAGING" "$DEST"
echo "gltf-validator $VERSION installed in $DEST"

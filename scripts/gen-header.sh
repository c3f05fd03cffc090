#!/usr/bin/env bash
# Writes the C header of the ffi crate, ffi/include/dynotraj.h, from ffi/src with cbindgen
# (scripts/setup.sh installs it). `--check` writes nothing: it fails when the committed header
# is not what the sources make (CI runs it, scripts/test.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
header=ffi/include/dynotraj.h
if ! command -v cbindgen >/dev/null 2>&1; then
  echo "gen-header: cbindgen not found (bash scripts/setup.sh installs it)" >&2
  exit 1
fi
if [ "${1:-}" = "--check" ]; then
  fresh=$(mktemp)
  trap 'rm -f "$fresh"' EXIT
  cbindgen --quiet --config ffi/cbindgen.toml --crate dynotraj-ffi --output "$fresh" ffi
  if ! diff -u "$header" "$fresh"; then
    echo "gen-header: $header is stale; run bash scripts/gen-header.sh and commit it" >&2
    exit 1
  fi
  echo "gen-header: $header is current"
else
  cbindgen --quiet --config ffi/cbindgen.toml --crate dynotraj-ffi --output "$header" ffi
  echo "gen-header: wrote $header"
fi

#!/usr/bin/env bash
# Writes the C header of the ffi crate, ffi/include/dynotraj.h, from ffi/src with cbindgen (a
# library of the ffi crate's tests). `--check` writes nothing: it fails when the committed
# header is not what the sources make, as the test suite does (ffi/tests/header.rs).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/env.sh
if [ "${1:-}" = "--check" ]; then
  cargo test --locked -p dynotraj-ffi --test header --quiet
  echo "gen-header: ffi/include/dynotraj.h is current"
else
  DYNOTRAJ_WRITE_HEADER=1 cargo test --locked -p dynotraj-ffi --test header --quiet
  echo "gen-header: wrote ffi/include/dynotraj.h"
fi

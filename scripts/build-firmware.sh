#!/usr/bin/env bash
# Builds the edge firmware for thumbv7em-none-eabihf (QEMU mps2-an386) into
# $CARGO_TARGET_DIR/thumbv7em-none-eabihf/release/dynotraj-firmware. DYNOTRAJ_FW_MODEL=BLOB[,BLOB]
# links int8 model blobs, one per agent type, into flash (unset: constant-velocity forecasts).
# Without it and without arguments, the image with the default-size models of sim/data/models
# (vehicles and pedestrians) linked in is built first and kept beside it as
# dynotraj-firmware-model (tests/tests/edge_qemu.rs measures its RAM); the second build redoes only the firmware crate. Without arguments the Embassy example
# (dynotraj-embassy, feature `embassy`) is built last.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/env.sh
manifest=edge/firmware/Cargo.toml
release="$CARGO_TARGET_DIR/thumbv7em-none-eabihf/release"
if [ -z "${DYNOTRAJ_FW_MODEL:-}" ] && [ $# -eq 0 ]; then
  DYNOTRAJ_FW_MODEL="$PWD/sim/data/models/default-dims.int8,$PWD/sim/data/models/default-dims-pedestrian.int8" \
    cargo build --locked --release --target thumbv7em-none-eabihf --manifest-path "$manifest" --bin dynotraj-firmware
  cp "$release/dynotraj-firmware" "$release/dynotraj-firmware-model"
fi
cargo build --locked --release --target thumbv7em-none-eabihf --manifest-path "$manifest" "$@"
if [ $# -eq 0 ]; then
  cargo build --locked --release --target thumbv7em-none-eabihf --manifest-path "$manifest" --features embassy --bin dynotraj-embassy
fi

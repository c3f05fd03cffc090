#!/usr/bin/env bash
# Builds the edge firmware for thumbv7em-none-eabihf (QEMU mps2-an386) into
# $CARGO_TARGET_DIR/thumbv7em-none-eabihf/release/dynotraj-firmware. DYNOTRAJ_FW_MODEL=BLOB
# links an int8 model blob into flash (unset: constant-velocity forecasts).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/env.sh
cargo build --release --target thumbv7em-none-eabihf --manifest-path edge/firmware/Cargo.toml "$@"

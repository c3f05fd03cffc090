#!/usr/bin/env bash
# Sets the machine up (idempotent) and runs the main job on the bundled KITTI data:
# the paper's Table I and its Table IV for the GT and GT+EKF sources with the baseline predictors.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
source scripts/env.sh
cargo build --release -p dynotraj-host --bin dynotraj
bin="$CARGO_TARGET_DIR/release/dynotraj"
echo "## Eligible objects and test instances (Table I layout)"
"$bin" dataset --kitti "$DYNOTRAJ_KITTI" "$@"
echo
echo "## Baselines on the paper's test sequences (Table IV layout)"
"$bin" eval --kitti "$DYNOTRAJ_KITTI" --source gt,gt-ekf,gt-rts --predictor cv,ctra "$@"

#!/usr/bin/env bash
# Sets the machine up (idempotent) and runs the main job on the bundled KITTI data:
# the paper's Table I, its Table IV for the baselines, and the leave-one-sequence-out experiment
# for the three arms, Estimated (Ours), GT and GT+EKF (float and int8; about 13 minutes on one
# core the first time, seconds when rerun: trained folds are cached), with its report in
# reports/kitti/REPORT.md (tables as Markdown and CSV, figures as PNG and SVG).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
source scripts/env.sh
cargo build --release -p dynotraj-host --bin dynotraj
bin="$CARGO_TARGET_DIR/release/dynotraj"
echo "## Eligible objects and test instances (Table I layout)"
"$bin" dataset --kitti "$DYNOTRAJ_KITTI" --source gt,estimated "$@"
echo
echo "## Baselines on the paper's test sequences (Table IV layout)"
"$bin" eval --kitti "$DYNOTRAJ_KITTI" --source gt,gt-ekf,gt-rts,estimated,estimated-smoothed --predictor cv,ctra "$@"
echo
echo "## Learned predictor, leave-one-sequence-out (Table IV layout)"
"$bin" experiment --kitti "$DYNOTRAJ_KITTI" --arms estimated,gt,gt-ekf --out "${DYNOTRAJ_OUT:-reports/kitti}" "$@"

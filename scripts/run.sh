#!/usr/bin/env bash
# Sets the machine up (idempotent) and runs the main job on the bundled KITTI data (all
# sixteen sequences): the leave-one-sequence-out experiment on the paper's five test sequences
# for the three arms, Estimated (Ours: each sequence rendered, tracked by the OpenCV front-end,
# estimated by the core), GT and GT+EKF (float and int8), every other sequence training each
# fold, with its report in reports/kitti/REPORT.md (tables as Markdown and CSV, figures as PNG
# and SVG, the run's time); then the paper's Table I and its Table IV for the baselines from
# the same estimates, and Table III for both estimator profiles (host, and the edge's, which
# the ECU runs) with the restarts of object runs by cause. Sequences are rendered and folds
# trained on every core (--jobs); renderings and trained folds are cached in
# reports/kitti/cache, so a rerun takes seconds. The paper's
# nine-sequence setting is the experiment with --sequences 0000,0001,0002,0003,0004,0005,0006,0018,0020
# (reports/kitti-paper9, docs/cli.md).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/phases.sh
# The phase table on stderr, apart from the results.
trap 'phase_table >&2' EXIT
phase "set-up (scripts/setup.sh)" >&2
bash scripts/setup.sh
source scripts/env.sh
phase "build (release)" >&2
cargo build --locked --release -p dynotraj-cli --bin dynotraj
bin="$CARGO_TARGET_DIR/release/dynotraj"
out="${DYNOTRAJ_OUT:-reports/kitti}"
phase "experiment (rendering, tracking, training, report)" >&2
echo "## Learned predictor, leave-one-sequence-out (Table IV layout)"
"$bin" experiment --kitti "$DYNOTRAJ_KITTI" --arms estimated,gt,gt-ekf --out "$out" "$@"
echo
phase "dataset (Table I)" >&2
echo "## Eligible objects and test instances (Table I layout)"
"$bin" dataset --kitti "$DYNOTRAJ_KITTI" --source gt,estimated --estimate-cache "$out/cache" "$@"
echo
phase "estimate (Table III)" >&2
echo "## The estimator from the renderings, host and edge profiles (Table III layout, restarts by cause)"
"$bin" estimate --kitti "$DYNOTRAJ_KITTI" --profile host,edge --estimate-cache "$out/cache" "$@"
echo
phase "eval (baselines)" >&2
echo "## Baselines on the paper's test sequences (Table IV layout)"
"$bin" eval --kitti "$DYNOTRAJ_KITTI" --source gt,gt-ekf,gt-rts,estimated,estimated-smoothed --predictor cv,cv-fit,ctra --estimate-cache "$out/cache" "$@"

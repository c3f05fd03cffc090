#!/usr/bin/env bash
# The pipeline on data the repository ships, with no KITTI download and no embedded toolchain:
# the committed rendered sequence (sim/data/image_sim: 24 stereo frames of the synthetic drive,
# with depth, instance masks and truth) -> the image front-end -> a tracks file -> the
# estimator -> the edge's session in process -> forecasts. Each step says where its output
# went. Outputs go to $DYNOTRAJ_QUICKSTART (default /tmp/dynotraj-quickstart); set-up is the
# host-only one (scripts/setup.sh --host).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh --host
source scripts/env.sh
cargo build --locked --release -p dynotraj-cli --bin dynotraj
bin="$CARGO_TARGET_DIR/release/dynotraj"
out="${DYNOTRAJ_QUICKSTART:-/tmp/dynotraj-quickstart}"
fixture=sim/data/image_sim
rm -rf "$out"
echo "## 1. The image front-end on the committed rendering ($fixture) -> a tracks file"
"$bin" track --kitti "$fixture" --sequences 0000 --out "$out/tracks"
echo
echo "## 2. The estimator on the track-level simulator driven by the fixture's labels and poses, scored"
echo "##    against the simulator's truth (Table III layout)"
"$bin" estimate --kitti "$fixture" --sequences 0000 --ours-input tracks --out "$out/estimate-truth"
echo
echo "## 3. The estimator on the tracks file alone (what a vehicle has: no truth)"
"$bin" estimate --tracks "$out/tracks/0000.dtt" --out "$out/estimate"
echo
echo "## 4. Forecasts from the edge's session in process (constant velocity without --model)"
"$bin" forecast --tracks "$out/tracks/0000.dtt" --out "$out/forecast"
echo
echo "quickstart: outputs in $out (tracks/, estimate-truth/, estimate/, forecast/forecasts.csv)"

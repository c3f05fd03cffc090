#!/usr/bin/env bash
# The pipeline on data the repository ships, with no KITTI download and no embedded toolchain:
# the committed rendered sequence (sim/data/image_sim: 24 stereo frames of the synthetic drive,
# with depth, instance masks and truth) as a ROS 2 bag -> import -> the image front-end -> a
# tracks file -> the estimator -> the edge's session in process -> forecasts, with recordings
# for Foxglove. Each step says where its output went. Outputs go to $DYNOTRAJ_QUICKSTART
# (default /tmp/dynotraj-quickstart); set-up is the host-only one (scripts/setup.sh --host),
# skipped when $DYNOTRAJ_BIN names a built dynotraj.
set -euo pipefail
cd "$(dirname "$0")/.."
if [[ -n "${DYNOTRAJ_BIN:-}" ]]; then
    # A built binary (the test suite runs the quickstart with its own): no set-up, no build.
    bin="$DYNOTRAJ_BIN"
else
    bash scripts/setup.sh --host
    source scripts/env.sh
    cargo build --locked --release -p dynotraj-cli --bin dynotraj
    bin="$CARGO_TARGET_DIR/release/dynotraj"
fi
out="${DYNOTRAJ_QUICKSTART:-/tmp/dynotraj-quickstart}"
fixture=sim/data/image_sim
rm -rf "$out"
echo "## 1. Your drive in: the committed rendering written as a ROS 2 bag (MCAP), as a stereo rig"
echo "##    and a detector record it, then imported to the KITTI layout the front-end reads"
"$bin" export-bag --kitti "$fixture" --sequences 0000 --out "$out/bags"
"$bin" import --bag "$out/bags/0000" --out "$out/imported"
echo
echo "## 2. The image front-end on the imported drive -> a tracks file (frame rate from the bag's stamps)"
"$bin" track --kitti "$out/imported" --sequences 0000 --out "$out/tracks"
echo
echo "## 3. The estimator on the track-level simulator driven by the fixture's labels and poses, scored"
echo "##    against the simulator's truth (Table III layout), with a recording to look at"
"$bin" estimate --kitti "$fixture" --sequences 0000 --ours-input tracks --out "$out/estimate-truth" \
    --record "$out/estimate-truth.mcap"
echo
echo "## 4. The estimator on the tracks file alone (what a vehicle has: no truth)"
"$bin" estimate --tracks "$out/tracks/0000.dtt" --out "$out/estimate"
echo
echo "## 5. Forecasts from the edge's session in process (constant velocity without --model), recorded"
"$bin" forecast --tracks "$out/tracks/0000.dtt" --out "$out/forecast" --record "$out/forecast.mcap"
echo
echo "## 6. The same drive as a camera driver records it (images and camera infos only: no masks, no"
echo "##    detections): the front-end finds the moving objects itself (motion segmentation), then forecasts"
"$bin" export-bag --kitti "$fixture" --sequences 0000 --camera-only --out "$out/camera-bags"
"$bin" import --bag "$out/camera-bags/0000" --out "$out/camera-imported"
"$bin" track --kitti "$out/camera-imported" --sequences 0000 --out "$out/camera-tracks"
"$bin" forecast --tracks "$out/camera-tracks/0000.dtt" --out "$out/camera-forecast"
echo
echo "quickstart: outputs in $out (bags/, imported/, tracks/, estimate-truth/, estimate/, forecast/forecasts.csv;"
echo "camera-bags/ ... camera-forecast/forecasts.csv from the bag without masks or detections);"
echo "open $out/estimate-truth.mcap and $out/forecast.mcap in Foxglove (https://foxglove.dev) to scrub through them"

# Sourced by the scripts: one build cache outside the clone, so CI reruns and fresh clones reuse it.
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/dynotraj-target}"
export CARGO_TERM_COLOR="${CARGO_TERM_COLOR:-never}"
# Real KITTI data for the main job and the tests that use it (never copied into the repo).
export DYNOTRAJ_KITTI="${DYNOTRAJ_KITTI:-$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/../shared/kitti/tracking/training}"
export RAYON_NUM_THREADS="${RAYON_NUM_THREADS:-1}"

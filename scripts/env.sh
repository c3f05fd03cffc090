# Sourced by the scripts: one build cache outside the clone, so CI reruns and fresh clones reuse it.
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/dynotraj-target}"
export CARGO_TERM_COLOR="${CARGO_TERM_COLOR:-never}"
# Real KITTI data for the main job and the tests that use it (never copied into the repo).
export DYNOTRAJ_KITTI="${DYNOTRAJ_KITTI:-$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/../shared/kitti/tracking/training}"
export RAYON_NUM_THREADS="${RAYON_NUM_THREADS:-1}"
# The MCU images name source files in their panic locations: remap the checkout's and cargo's
# absolute paths so that the firmware's bytes (and its memory goldens) do not depend on where
# the repository is cloned or where cargo keeps its registry. Target-specific: host builds are
# left as they are.
_dynotraj_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export CARGO_TARGET_THUMBV7EM_NONE_EABIHF_RUSTFLAGS="${CARGO_TARGET_THUMBV7EM_NONE_EABIHF_RUSTFLAGS:---remap-path-prefix=$_dynotraj_root=/dynotraj --remap-path-prefix=${CARGO_HOME:-$HOME/.cargo}=/cargo}"
unset _dynotraj_root

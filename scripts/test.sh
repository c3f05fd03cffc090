#!/usr/bin/env bash
# Sets the machine up (idempotent) and runs every check of the project: the no_std core built
# for the Cortex-M4F target, the dependency audit, clippy's no-panic rules on core, and the
# whole test suite.
set -euo pipefail

cd "$(dirname "$0")/.."
source scripts/phases.sh
# The run's temporary files: the Python environments' log, the tests' log, and the skips the
# tests record.
envs_log=$(mktemp)
log=$(mktemp)
DYNOTRAJ_SKIP_LOG=$(mktemp)
trap 'rm -f "$envs_log" "$log" "$DYNOTRAJ_SKIP_LOG"; phase_table' EXIT
phase "set-up (scripts/setup.sh)"
bash scripts/setup.sh
source scripts/env.sh
# The tests' Python environments (about 1.2 GB from PyPI on a fresh machine) are made beside
# the compiling instead of by the first test that needs one.
bash scripts/python-env.sh >"$envs_log" 2>&1 &
envs_pid=$!

phase "rustfmt (workspace, firmware, fuzz)"
cargo fmt --all --check
(cd edge/firmware && cargo fmt --all --check)
phase "lock files current (workspace, firmware, fuzz)"
cargo metadata --locked --format-version 1 >/dev/null
(cd edge/firmware && cargo metadata --locked --format-version 1 >/dev/null)
(cd fuzz && cargo metadata --locked --format-version 1 >/dev/null)
(cd fuzz && cargo fmt --all --check)
phase "dependency audit (cargo-deny: licences, bans, sources, advisories)"
# Appending: a plain `tee /dev/stderr` truncates a log file that stderr is redirected to.
audit_line=$(bash scripts/audit.sh | tee -a /dev/stderr | tail -1)
phase "core for thumbv7em-none-eabihf"
cargo build --locked -p dynotraj-core -p dynotraj-edge -p dynotraj-ffi --lib --target thumbv7em-none-eabihf --release
phase "edge firmware for QEMU mps2-an386 (Cortex-M4F)"
bash scripts/build-firmware.sh
cargo clippy --locked --release --target thumbv7em-none-eabihf --manifest-path edge/firmware/Cargo.toml -- -D warnings
cargo clippy --locked --release --target thumbv7em-none-eabihf --manifest-path edge/firmware/Cargo.toml --features embassy -- -D warnings
phase "clippy (core, edge, ffi: no unwrap/expect/panic/indexing)"
cargo clippy --locked -p dynotraj-core -p dynotraj-edge --lib -- -D warnings
cargo clippy --locked -p dynotraj-edge --lib --features async -- -D warnings
cargo clippy --locked -p dynotraj-ffi --all-targets -- -D warnings
cargo clippy --locked -p dynotraj-ffi --target thumbv7em-none-eabihf -- -D warnings
# Every host build from here on compiles the workspace's own crates with clippy-driver, the
# compiler with clippy's lints, so the tests' build is also the workspace's clippy run (every
# target, warnings denied, core's no-panic rules relaxed elsewhere): the dependencies are
# compiled once, where a separate `cargo clippy --workspace` would check all of them first. The
# flags go in RUSTFLAGS only for these host builds: the MCU builds keep their own.
linted() {
  RUSTC_WORKSPACE_WRAPPER="$(rustc --print sysroot)/bin/clippy-driver" \
    RUSTFLAGS="-D warnings -A clippy::unwrap_used -A clippy::expect_used -A clippy::panic -A clippy::indexing_slicing" \
    "$@"
}
phase "tests: building, linted by clippy"
linted cargo nextest run --locked --workspace --all-targets --no-run --cargo-quiet
phase "the host without the image front-end (no OpenCV): builds, and says what it lacks"
linted cargo test --locked -p dynotraj-sources -p dynotraj-eval -p dynotraj-cli --no-default-features --all-targets --no-run --quiet
# The same three packages as the build above, so that the same features are unified and its
# test binaries run as built (sources alone would compile another set of dependencies).
linted cargo test --locked -p dynotraj-sources -p dynotraj-eval -p dynotraj-cli --no-default-features --lib without_images
phase "cargo doc (core, edge, ffi): no warnings"
RUSTDOCFLAGS="-D warnings" cargo doc --locked -p dynotraj-core -p dynotraj-edge -p dynotraj-ffi --no-deps --quiet
phase "the tests' Python environments (what is left of making them)"
if ! wait "$envs_pid"; then
  echo "python environments: not all made; the tests that need one make it again or say why they skip:"
  cat "$envs_log"
fi
phase "tests: running"
export DYNOTRAJ_SKIP_LOG
status=0
# nextest runs every test in a process of its own and keeps both cores busy across test
# binaries (cargo test runs one binary at a time, so a binary with one long test left a core
# idle); it does not run doc-tests, which cargo test does after it. --no-fail-fast: a failing
# test must not hide what the others would say.
linted cargo nextest run --locked --workspace --no-fail-fast --cargo-quiet 2>&1 | tee "$log" || status=$?
linted cargo test --locked --workspace --doc 2>&1 | tee -a "$log" || status=$?
# One closing line for the whole suite: nextest's summary plus the doc-tests'. A test that skips
# (no real data here, say) returns early and is counted as passed; it is counted as skipped
# instead, and named.
skipped=$(awk '{ sub(/:$/, "", $2); print $2 }' "$DYNOTRAJ_SKIP_LOG" | sort -u | grep -c . || true)
awk -v s="$skipped" '
  /tests run:/ { for (i = 1; i < NF; i++) { if ($(i + 1) ~ /^passed/) p += $i; if ($(i + 1) ~ /^failed/) f += $i } }
  /^test result:/ { p += $4; f += $6 }
  END { printf "tests: %d passed, %d failed, %d skipped\n", p - s, f, s }' "$log"
sort -u "$DYNOTRAJ_SKIP_LOG" | sed 's/^/  /'
echo "$audit_line"
exit "$status"

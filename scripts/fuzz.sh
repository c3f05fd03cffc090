#!/usr/bin/env bash
# Runs every cargo-fuzz target of fuzz/ for a budget of executions (default 10 million, capped
# at 30 minutes each), spread over the machine's cores, then minimises each corpus in place.
# The targets are built once, first, and their binaries run (not `cargo fuzz run`, which would
# rebuild from a work tree that may have changed since). A crash input lands in
# fuzz/artifacts/<target>/; keep it in fuzz/regressions/<target>/ once fixed
# (tests/tests/fuzz_corpus_regression.rs replays both folders in every test run).
#
#   bash scripts/fuzz.sh [RUNS] [TARGET...]
#
# Prints one line per target: executions, seconds, crashes, corpus files kept.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/env.sh
runs="${1:-10000000}"
shift || true
command -v cargo-fuzz >/dev/null || cargo install cargo-fuzz --locked
export RUSTC_BOOTSTRAP=1
fuzz_target_dir="${DYNOTRAJ_FUZZ_TARGET:-$HOME/.cache/dynotraj-fuzz-target}"
cd fuzz
# cargo fuzz has no --locked: refuse a stale lock file here instead.
cargo metadata --locked --format-version 1 >/dev/null
targets=("$@")
[ ${#targets[@]} -gt 0 ] || mapfile -t targets < <(cargo fuzz list)
echo "building ${targets[*]} at $(git rev-parse --short HEAD)$(git diff --quiet HEAD -- .. || echo ' (with uncommitted changes)')" >&2
for t in "${targets[@]}"; do cargo fuzz build -s none --target-dir "$fuzz_target_dir" "$t" >&2; done
bin_dir="$fuzz_target_dir/x86_64-unknown-linux-gnu/release"
logs=$(mktemp -d)
run_one() {
    local t=$1 logs=$2 runs=$3 bin_dir=$4
    mkdir -p "corpus/$t" "artifacts/$t"
    if "$bin_dir/$t" "corpus/$t" -artifact_prefix="artifacts/$t/" -runs="$runs" -max_total_time=1800 \
        -print_final_stats=1 >"$logs/$t.log" 2>&1; then
        echo 0 >"$logs/$t.crashes"
    else
        echo 1 >"$logs/$t.crashes"
    fi
}
export -f run_one
printf '%s\n' "${targets[@]}" | xargs -P "$(nproc)" -I{} bash -c 'run_one "$@"' _ {} "$logs" "$runs" "$bin_dir"
echo "target,executions,seconds,crashes,corpus_files"
for t in "${targets[@]}"; do
    # Minimise: merge the corpus into an empty folder, keeping only inputs that add coverage.
    rm -rf "$logs/min" && mkdir "$logs/min"
    "$bin_dir/$t" -merge=1 "$logs/min" "corpus/$t" >"$logs/$t.cmin" 2>&1 && rm -rf "corpus/$t" && mv "$logs/min" "corpus/$t"
    execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$logs/$t.log" | grep -o '[0-9]*$' | tail -1)
    secs=$(grep -o 'Done [0-9]* runs in [0-9]* second' "$logs/$t.log" | grep -o 'in [0-9]*' | grep -o '[0-9]*' | tail -1)
    echo "$t,${execs:-?},${secs:-?},$(cat "$logs/$t.crashes"),$(find "corpus/$t" -type f | wc -l)"
done
rm -rf "$logs"

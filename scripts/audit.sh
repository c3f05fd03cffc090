#!/usr/bin/env bash
# cargo-deny over the workspace, the firmware and the fuzz targets, against deny.toml (its
# comments say why each allowance is there). Licences, duplicate versions and sources need
# only the lock files. Advisories need RustSec's database: fetched from GitHub when it can be
# reached, else the copy an earlier fetch left under $CARGO_HOME/advisory-dbs; with neither,
# they are not checked and the last line says SKIPPED (scripts/test.sh repeats it in its
# summary). The last line is the summary; any finding exits non-zero.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/env.sh
DENY_VERSION=0.20.2
if ! cargo deny --version 2>/dev/null | grep -qx "cargo-deny $DENY_VERSION"; then
  echo "audit: installing cargo-deny $DENY_VERSION"
  # Unoptimised: it compiles in 75 s where the release build took 214-315 s, and checks the
  # three lock files in 4.5 s instead of 1.5 s (docs/decisions.md, "The test build, crate by
  # crate").
  cargo install cargo-deny --locked --version "$DENY_VERSION" --debug --quiet
fi
manifests=(Cargo.toml edge/firmware/Cargo.toml fuzz/Cargo.toml)
cargo deny fetch db >/dev/null 2>&1 || true
db=$(ls -d "${CARGO_HOME:-$HOME/.cargo}"/advisory-dbs/advisory-db-* 2>/dev/null | head -1 || true)
checks=(licenses bans sources)
[ -n "$db" ] && checks+=(advisories)
for m in "${manifests[@]}"; do
  if ! out=$(cargo deny -L error --locked --offline --manifest-path "$m" check "${checks[@]}" 2>&1); then
    echo "$out"
    echo "audit: $m: a finding deny.toml does not allow (above)"
    exit 1
  fi
  echo "audit: $m: $(echo "$out" | tail -1)"
done
if [ -z "$db" ]; then
  echo "audit: licences, bans, sources ok; advisories SKIPPED (RustSec's database could not be fetched and none is cached)"
else
  echo "audit: licences, bans, sources, advisories ok (RustSec database of $(git -C "$db" log -1 --format=%cs 2>/dev/null || echo "an unknown date"))"
fi

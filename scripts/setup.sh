#!/usr/bin/env bash
# Installs what a fresh Debian 12 machine lacks to build, run and test dynotraj.
# Safe to run twice: every step checks before it installs.
# `--host`: only what the host commands need (OpenCV and libclang for the image front-end, a
# font for report figures), not the embedded toolchain (QEMU, arm-none-eabi, the Cortex-M
# target, flip-link) that the firmware, the C example and the test suite need.
set -euo pipefail
host_only=false
[ "${1:-}" = "--host" ] && host_only=true

need_apt=()
pkgs=(libopencv-dev clang libclang-dev pkg-config fonts-dejavu-core)
# qemu-system-arm runs the firmware; gcc-arm-none-eabi, libnewlib-arm-none-eabi, make: the C
# example of the ffi crate, built for the Cortex-M4F and run under QEMU
# (tests/tests/ffi_c_example.rs).
$host_only || pkgs+=(qemu-system-arm gcc-arm-none-eabi libnewlib-arm-none-eabi make)
for pkg in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || need_apt+=("$pkg")
done
if [ ${#need_apt[@]} -gt 0 ]; then
  echo "setup: installing ${need_apt[*]}"
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${need_apt[@]}" >/dev/null
fi

if ! command -v cargo >/dev/null 2>&1; then
  echo "setup: cargo not found; install Rust with rustup first" >&2
  exit 1
fi
if $host_only; then
  echo "setup: ok (host only)"
  exit 0
fi
if command -v rustup >/dev/null 2>&1; then
  rustup target list --installed | grep -qx thumbv7em-none-eabihf || rustup target add thumbv7em-none-eabihf
  rustup component list --installed | grep -q '^llvm-tools' || rustup component add llvm-tools
  rustup component list --installed | grep -q '^clippy' || rustup component add clippy
  rustup component list --installed | grep -q '^rustfmt' || rustup component add rustfmt
fi
# The firmware's linker (.cargo/config.toml): stack overflows fault instead of corrupting statics.
if ! command -v flip-link >/dev/null 2>&1; then
  echo "setup: installing flip-link"
  cargo install flip-link --locked
fi
# The test runner of scripts/test.sh, which spreads test binaries over the cores.
if ! cargo nextest --version >/dev/null 2>&1; then
  echo "setup: installing cargo-nextest"
  cargo install cargo-nextest --locked --quiet
fi
echo "setup: ok"

#!/usr/bin/env bash
# Installs what a fresh Debian 12 machine lacks to build, run and test dynotraj.
# Safe to run twice: every step checks before it installs.
set -euo pipefail

need_apt=()
for pkg in libopencv-dev clang libclang-dev qemu-system-arm pkg-config fonts-dejavu-core; do
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
echo "setup: ok"

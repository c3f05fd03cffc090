#!/usr/bin/env bash
# Runs the edge firmware on QEMU's Cortex-M4F board (mps2-an386) with its UART0 on a loopback
# TCP port: `dynotraj stream --to tcp://127.0.0.1:PORT ...` then talks to it.
#
#   bash scripts/qemu-edge.sh [--port PORT|none] [--elf FILE]
#
# `--port none` runs a program that uses no UART (dynotraj-kernels) with UART0 unconnected.
# QEMU waits for the host to connect before it starts the firmware (wait=on), so no byte is
# lost. -icount shift=0 makes the virtual clock advance exactly 1 ns per instruction: the
# firmware's SysTick then measures compute in instructions (40 per count at 25 MHz). Logs and
# the exit status come through semihosting: 0 after a clean session, 1 after a panic,
# HardFault or failure.
set -euo pipefail

cd "$(dirname "$0")/.."
port=7878
elf="${CARGO_TARGET_DIR:-$HOME/.cache/dynotraj-target}/thumbv7em-none-eabihf/release/dynotraj-firmware"
while [ $# -gt 0 ]; do
    case "$1" in
        --port) port="$2"; shift 2 ;;
        --elf) elf="$2"; shift 2 ;;
        *) echo "usage: $0 [--port PORT|none] [--elf FILE]" >&2; exit 2 ;;
    esac
done
[ -f "$elf" ] || { echo "$elf: no firmware; build it: bash scripts/build-firmware.sh" >&2; exit 2; }
# DYNOTRAJ_QEMU_EXTRA adds QEMU options, e.g. "-d nochain,in_asm,exec -D FILE" to log every
# executed block for scripts/profile-firmware.py.
if [ "$port" = none ]; then
    serial=null
else
    serial="tcp:127.0.0.1:$port,server=on,wait=on"
fi
echo "qemu-edge: firmware $elf, UART0 on $serial" >&2
exec qemu-system-arm -cpu cortex-m4 -machine mps2-an386 -nographic -monitor none \
    -semihosting-config enable=on,target=native \
    -icount shift=0,align=off,sleep=off \
    -serial "$serial" \
    ${DYNOTRAJ_QEMU_EXTRA:-} \
    -kernel "$elf"

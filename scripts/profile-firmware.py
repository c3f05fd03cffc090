#!/usr/bin/env python3
"""Instructions per function of the firmware from a QEMU block log.

Run the firmware with DYNOTRAJ_QEMU_EXTRA="-d nochain,in_asm,exec -D LOG" (scripts/qemu-edge.sh),
then: scripts/profile-firmware.py LOG ELF [TOP] [--blocks NAME]. Each translated block's guest instructions come
from the in_asm part of the log, its executions from the exec part (chaining off, so every
execution is logged); symbols from llvm-nm. Prints executed instructions per function, largest
first; with --blocks, the blocks of the functions whose names contain NAME, by start address
(to read beside `llvm-objdump -d`). A profile, not a benchmark: the instruction totals match QEMU's -icount count.
"""
import collections, re, subprocess, sys, bisect, glob, os

def symbols(elf):
    nm = (glob.glob(os.path.expanduser("~/.rustup/toolchains/*/lib/rustlib/*/bin/llvm-nm")) or ["llvm-nm"])[0]
    out = subprocess.run([nm, "-C", "-S", "--defined-only", elf], capture_output=True, text=True, check=True).stdout
    syms = []
    for line in out.splitlines():
        parts = line.split(None, 3)
        if len(parts) == 4 and parts[2].lower() == "t":
            syms.append((int(parts[0], 16) & ~1, int(parts[1], 16), parts[3]))
    syms.sort()
    return syms

def main():
    args = sys.argv[1:]
    blocks_of = None
    if "--blocks" in args:
        i = args.index("--blocks")
        blocks_of = args[i + 1]
        del args[i:i + 2]
    log, elf = args[0], args[1]
    top = int(args[2]) if len(args) > 2 else 30
    length = {}        # block start pc -> guest instructions
    execs = collections.Counter()
    current, count = None, 0
    insn = re.compile(r"^0x([0-9a-f]+):\s")
    trace = re.compile(r"^Trace \d+: 0x[0-9a-f]+ \[[0-9a-f]+/([0-9a-f]+)/")
    with open(log, errors="replace") as f:
        for line in f:
            m = trace.match(line)
            if m:
                execs[int(m.group(1), 16)] += 1
                continue
            if line.startswith("IN:"):
                if current is not None:
                    length[current] = count
                current, count = None, 0
                continue
            m = insn.match(line)
            if m:
                if current is None:
                    current = int(m.group(1), 16)
                count += 1
    if current is not None:
        length[current] = count
    syms = symbols(elf)
    starts = [s[0] for s in syms]
    per_fn = collections.Counter()
    per_block = collections.Counter()
    total = 0
    for pc, n in execs.items():
        k = length.get(pc, 0) * n
        total += k
        i = bisect.bisect_right(starts, pc) - 1
        name = syms[i][2] if i >= 0 and pc < syms[i][0] + max(syms[i][1], 1) else hex(pc)
        per_fn[re.sub(r"::h[0-9a-f]{16}$", "", name)] += k
        if blocks_of is not None and blocks_of in name:
            per_block[(pc, length.get(pc, 0), n)] += k
    print(f"{total:,} instructions executed")
    for name, k in per_fn.most_common(top):
        print(f"{k:>14,} {100 * k / max(total, 1):5.1f}%  {name}")
    if blocks_of is not None:
        print(f"blocks of *{blocks_of}*: start, instructions, executions")
        for (pc, length_, n), k in per_block.most_common(top):
            print(f"{k:>14,} {100 * k / max(total, 1):5.1f}%  {pc:#x} {length_:>4} x {n:,}")

main()

#!/usr/bin/env python3
"""Instructions per function of the firmware from a QEMU block log.

Run the firmware with DYNOTRAJ_QEMU_EXTRA="-d nochain,in_asm,exec -D LOG" (scripts/qemu-edge.sh),
then: scripts/profile-firmware.py LOG ELF [TOP] [--blocks NAME] [--callers NAME]. Each translated block's guest instructions come
from the in_asm part of the log, its executions from the exec part (chaining off, so every
execution is logged); symbols from llvm-nm. Prints executed instructions per function, largest
first; with --blocks, the blocks of the functions whose names contain NAME, by start address
(to read beside `llvm-objdump -d`); with --callers, the calls into the functions whose names
contain NAME (an execution of their first block) by the block executed just before, i.e. the
call site (to find who copies memory or takes square roots). A profile, not a benchmark: the instruction totals match QEMU's -icount count.
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
    def option(flag):
        if flag not in args:
            return None
        i = args.index(flag)
        value = args[i + 1]
        del args[i:i + 2]
        return value
    blocks_of = option("--blocks")
    callers_of = option("--callers")
    log, elf = args[0], args[1]
    top = int(args[2]) if len(args) > 2 else 30
    length = {}        # block start pc -> guest instructions
    execs = collections.Counter()
    transitions = collections.Counter()  # (previous block, block) -> executions, for --callers
    previous = None
    current, count = None, 0
    insn = re.compile(r"^0x([0-9a-f]+):\s")
    trace = re.compile(r"^Trace \d+: 0x[0-9a-f]+ \[[0-9a-f]+/([0-9a-f]+)/")
    with open(log, errors="replace") as f:
        for line in f:
            m = trace.match(line)
            if m:
                pc = int(m.group(1), 16)
                execs[pc] += 1
                if callers_of is not None:
                    transitions[(previous, pc)] += 1
                    previous = pc
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
    def function_of(pc):
        i = bisect.bisect_right(starts, pc) - 1
        return (i, syms[i][2]) if i >= 0 and pc < syms[i][0] + max(syms[i][1], 1) else (None, hex(pc))
    per_fn = collections.Counter()
    per_block = collections.Counter()
    total = 0
    for pc, n in execs.items():
        k = length.get(pc, 0) * n
        total += k
        name = function_of(pc)[1]
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

    if callers_of is not None:
        calls = collections.Counter()
        for (before, pc), n in transitions.items():
            i, name = function_of(pc)
            if i is None or callers_of not in name or pc != syms[i][0] or before is None:
                continue
            caller = re.sub(r"::h[0-9a-f]{16}$", "", function_of(before)[1])
            calls[(re.sub(r"::h[0-9a-f]{16}$", "", name), caller, before)] += n
        print(f"calls into *{callers_of}*: callee <- caller (call-site block), calls")
        for (callee, caller, site), n in calls.most_common(top):
            print(f"{n:>12,}  {callee} <- {caller} ({site:#x})")
main()

"""Fans the dynotraj benchmark out over a Ray cluster and gathers the same report one machine
would write.

Stages, each a set of Ray tasks running the `dynotraj` binary (present at the same path on
every node, with the data (--kitti or --drives), --store and --out on a file system they all
see):
  1. per drive: `dynotraj dataset --sequences S --source gt,estimated --estimate-cache STORE`:
     imports the drive if it is a bag, then renders and tracks it, tracks its own images, or
     simulates its tracks, into the content-addressed estimate cache;
  2. per training unit: `dynotraj benchmark --shard I/N --out OUT --estimate-cache STORE`: one
     (arm, fold, seed) training into OUT's fold cache;
  3. on the driver: `dynotraj benchmark --out OUT --estimate-cache STORE`, which reads every
     drive and fold from the caches and writes the report.
A task whose worker dies is retried (Ray's max_retries); a half-written unit is never read
(dynotraj writes every cache entry under a temporary name, renamed when whole, and checks a
checksum and its key when reading). At the end a table says where the time went.

    python fleet/dynotraj_fleet.py --address auto --dynotraj BIN (--kitti K | --drives MANIFEST) \\
        --store STORE --out OUT [--sequences 0000,0001] [--units 12] -- [benchmark flags, e.g. --arms gt]
"""
import argparse
import os
import shutil
import socket
import subprocess
import sys
import time

import ray

# One core a task: dynotraj's own parallelism is off, the cluster spreads the tasks.
TASK_ENV = {"RAYON_NUM_THREADS": "1", "DYNOTRAJ_JOBS": "1"}


def run(cmd):
    env = dict(os.environ, **TASK_ENV)
    start = time.monotonic()
    done = subprocess.run(cmd, env=env, capture_output=True, text=True)
    seconds = time.monotonic() - start
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: exit {done.returncode}\n{done.stderr[-2000:]}")
    return seconds


@ray.remote(num_cpus=1, memory=1 << 30, max_retries=3)
def estimate_drive(binary, data, store, sequence, extra):
    cmd = [binary, "dataset"] + data + ["--sequences", sequence, "--source", "gt,estimated",
           "--estimate-cache", store, "--quiet"] + extra
    return ("drive", sequence, run(cmd), os.getpid())


def attempt(store, unit):
    """Notes that this worker process starts `unit`: a unit noted twice was retried."""
    with open(os.path.join(store, "attempts.log"), "a") as log:
        log.write(f"{unit} {os.getpid()}\n")


@ray.remote(num_cpus=1, memory=1 << 30, max_retries=3)
def train_unit(binary, data, store, out, index, count, extra):
    attempt(store, f"unit {index}/{count}")
    cmd = [binary, "benchmark"] + data + ["--estimate-cache", store, "--out", out,
           "--shard", f"{index}/{count}", "--quiet"] + extra
    return ("unit", f"{index}/{count}", run(cmd), os.getpid())


def drive_names(binary, data):
    """The drives of --kitti or --drives, as `dynotraj` reads them."""
    cmd = [binary, "drives"] + (data if data[0] == "--kitti" else data[1:])
    listed = subprocess.run(cmd, capture_output=True, text=True)
    if listed.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)}: {listed.stderr.strip()}")
    return [line.split("\t")[0] for line in listed.stdout.splitlines()]


def wait_all(refs, what):
    results = []
    pending = list(refs)
    while pending:
        ready, pending = ray.wait(pending, num_returns=1)
        results.extend(ray.get(ready))
        print(f"{what}: {len(results)}/{len(refs)} done", flush=True)
    return results


def at_least_one(text):
    """A count of at least 1 (`--units`)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a count of at least 1, found `{text}`")
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a count of at least 1, found {value}")
    return value


def check_inputs(p, a, data, extra):
    """What can be checked before the cluster is used: the binary runs, the benchmark flags
    parse, and the cluster's address answers. Each failure is one line and exit 2."""
    binary = a.dynotraj if os.sep in a.dynotraj else shutil.which(a.dynotraj)
    if not binary or not os.access(binary, os.X_OK):
        p.error(f"--dynotraj {a.dynotraj}: no such program (build it with `cargo build --release --bins`)")
    # clap checks every flag given before --help, and then prints the help instead of running.
    flags = subprocess.run([binary, "benchmark"] + data + extra + ["--help"], capture_output=True, text=True)
    if flags.returncode != 0:
        p.error(f"the benchmark flags {' '.join(extra) or '(none)'}: {flags.stderr.strip().splitlines()[0]}")
    host_port = a.address.removeprefix("ray://")
    if host_port not in ("auto", "local") and ":" in host_port:
        host, port = host_port.rsplit(":", 1)
        try:
            socket.create_connection((host, int(port)), timeout=5).close()
        except (OSError, ValueError) as e:
            p.error(f"--address {a.address}: no Ray cluster answers there ({e})")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--address", default="auto", help="Ray cluster address (auto: the local cluster)")
    p.add_argument("--dynotraj", required=True, help="path of the dynotraj binary on every node")
    data = p.add_mutually_exclusive_group(required=True)
    data.add_argument("--kitti", help="a KITTI tracking folder: its sequences are the drives")
    data.add_argument("--drives", help="a drive manifest, or a folder of layout folders and bags")
    p.add_argument("--store", required=True, help="the shared estimate cache")
    p.add_argument("--out", required=True, help="the report folder (its cache/ holds the folds)")
    p.add_argument("--sequences", help="drives, comma-separated (default: every drive)")
    p.add_argument("--units", type=at_least_one, help="training units (default: 12)")
    p.add_argument("--drive-flags", default="", help="data flags a drive's estimate depends on (--rate, --ours-input, --render-scale, --classes, "
                   "--min-step): given to every stage, so the units find the drives' estimates")
    p.add_argument("benchmark", nargs=argparse.REMAINDER, help="flags after -- go to every benchmark")
    a = p.parse_args()
    # Tasks run in Ray's own working folders: every path they are given is absolute.
    for name in ("kitti", "drives", "store", "out"):
        if getattr(a, name):
            setattr(a, name, os.path.abspath(getattr(a, name)))
    if os.sep in a.dynotraj:
        a.dynotraj = os.path.abspath(a.dynotraj)
    extra = [f for f in a.benchmark if f != "--"]
    drive_extra = a.drive_flags.split()
    data = ["--kitti", a.kitti] if a.kitti else ["--drives", a.drives]
    check_inputs(p, a, data, extra + drive_extra)
    sequences = a.sequences.split(",") if a.sequences else drive_names(a.dynotraj, data)
    if a.sequences:
        extra = ["--sequences", a.sequences] + extra
    units = a.units if a.units is not None else 12
    os.makedirs(a.store, exist_ok=True)
    ray.init(address=a.address, log_to_driver=False)
    start = time.monotonic()
    drives = wait_all([estimate_drive.remote(a.dynotraj, data, a.store, s, drive_extra) for s in sequences],
                      "drives")
    t_drives = time.monotonic() - start
    trained = wait_all([train_unit.remote(a.dynotraj, data, a.store, a.out, i, units, extra + drive_extra)
                        for i in range(units)], "training units")
    t_units = time.monotonic() - start - t_drives
    gather_start = time.monotonic()
    run([a.dynotraj, "benchmark"] + data + ["--estimate-cache", a.store, "--out", a.out, "--quiet"]
        + extra + drive_extra)
    t_gather = time.monotonic() - gather_start
    print("stage | tasks | wall s | task s (sum) | task s (max)")
    for name, rows, wall in [("drives", drives, t_drives), ("training units", trained, t_units)]:
        costs = [r[2] for r in rows]
        print(f"{name} | {len(rows)} | {wall:.1f} | {sum(costs):.1f} | {max(costs):.1f}")
    print(f"gather | 1 | {t_gather:.1f} | {t_gather:.1f} | {t_gather:.1f}")
    with open(os.path.join(a.store, "attempts.log")) as log:
        started = [line.split()[1] for line in log]
    retried = len(started) - len(set(started))
    print(f"retries: {retried} (a unit started again after its worker was lost)")
    print(f"total {time.monotonic() - start:.1f} s; report in {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

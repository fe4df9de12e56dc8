#!/usr/bin/env python3
"""Run a sharded zmp-toolkit command on a Ray cluster: one Ray task per shard.

Each task runs the release xtask binary on its shard (`... --shard i/n`), which writes one
result file per unit into the job folder; when every task is done the driver runs
`xtask merge` on that folder and prints its output. A task whose worker dies (a killed
process, a lost node) is retried by Ray (`--max-retries`); the retry runs the shard again,
taking back the units the dead attempt had begun, so every unit is counted once. A shard that
finishes its part early takes units of other parts that no shard has begun (xtask --steal;
--no-steal turns it off). Each attempt leaves a file in OUT.ray-attempts beside the job
folder, so the retries can be counted.

    python xtask/scale/ray_driver.py --shards 16 -- suite --range development --out /shared/dev
    python xtask/scale/ray_driver.py --address ray://head:10001 --shards 64 \
        --xtask /shared/zmp-toolkit/target/release/xtask -- fleet /shared/robots --out /shared/night

Without --address a local cluster (head and workers on this machine) is started and stopped.
The job folder (--out) and the binary must be at the same path on every node (a shared file
system); see docs/src/scale-out.md.
"""

import argparse
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def default_xtask():
    target = os.environ.get("CARGO_TARGET_DIR") or str(REPO / "target")
    return str(Path(target) / "release" / "xtask")


def parse_args(argv):
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        epilog="Everything after -- is the xtask command to shard (suite, fleet, calibrate-com), "
        "with its --out job folder.",
    )
    p.add_argument("--shards", type=int, required=True, help="number of shards (Ray tasks)")
    p.add_argument(
        "--address",
        help="Ray cluster to join (e.g. ray://head:10001 or auto); default: start a local one",
    )
    p.add_argument("--xtask", default=default_xtask(), help="release xtask binary (default %(default)s)")
    p.add_argument(
        "--cpus-per-task",
        type=int,
        default=1,
        help="CPUs each shard asks Ray for; passed as xtask --threads (units run at once)",
    )
    p.add_argument(
        "--max-retries",
        type=int,
        default=3,
        help="times Ray re-runs a shard whose worker died (default %(default)s)",
    )
    p.add_argument(
        "--no-steal",
        action="store_true",
        help="run each shard's part only; by default a shard done early takes units of other "
        "parts that no shard has begun (xtask --steal: each unit still runs once)",
    )
    p.add_argument("--json", action="store_true", help="print the merge's JSON and the tasks' summary")
    p.add_argument("command", nargs=argparse.REMAINDER, help="-- xtask command and arguments")
    a = p.parse_args(argv)
    cmd = a.command[1:] if a.command[:1] == ["--"] else a.command
    if not cmd:
        p.error("give the xtask command after --, e.g. -- suite --range ci --out DIR")
    if a.shards < 1:
        p.error("--shards must be at least 1")
    if "--shard" in cmd or "--unit" in cmd or "--steal" in cmd:
        p.error(
            "the driver adds --shard and --steal itself; leave --shard, --steal and --unit out "
            "of the command (--no-steal before -- turns stealing off)"
        )
    if "--out" not in cmd or cmd.index("--out") + 1 >= len(cmd):
        p.error("the command needs --out DIR (the job folder the shards share)")
    a.command = cmd
    a.out = Path(cmd[cmd.index("--out") + 1]).resolve()
    cmd[cmd.index("--out") + 1] = str(a.out)
    if not os.access(a.xtask, os.X_OK):
        p.error(f"--xtask {a.xtask}: not an executable (build it: cargo build --release -p xtask)")
    return a


def _die_with_parent():
    # The shard's process goes when its Ray worker goes (Linux): a retried task never races a
    # leftover attempt for the same unit files.
    try:
        import ctypes

        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except OSError:
        pass


def run_shard(xtask, command, threads, index, count, attempts_dir, steal=True):
    """One Ray task: `xtask --threads K COMMAND --shard i/n [--steal] --json`."""
    import socket

    attempts_dir = Path(attempts_dir)
    attempts_dir.mkdir(parents=True, exist_ok=True)
    (attempts_dir / f"shard-{index}-of-{count}.pid-{os.getpid()}").write_text(
        json.dumps({"shard": f"{index}/{count}", "host": socket.gethostname(), "start": time.time()})
    )
    t = time.time()
    argv = [xtask, "--threads", str(threads), *command, "--shard", f"{index}/{count}"]
    argv += ["--steal", "--json"] if steal else ["--json"]
    p = subprocess.run(argv, capture_output=True, text=True, preexec_fn=_die_with_parent)
    try:
        ran = json.loads(p.stdout)
    except ValueError:
        ran = None
    return {
        "shard": f"{index}/{count}",
        "host": socket.gethostname(),
        "seconds": time.time() - t,
        "returncode": p.returncode,
        "ran": ran,
        "stderr": p.stderr[-2000:] if p.returncode else "",
    }


def main(argv):
    a = parse_args(argv)
    try:
        import ray
    except ImportError as e:
        sys.exit(f"ray is not importable ({e}); `cargo xtask setup` installs it into the venv")
    t0 = time.time()
    if a.address:
        ray.init(address=a.address, log_to_driver=False)
    else:
        ray.init(include_dashboard=False, log_to_driver=False)
    started = time.time()
    # One file per task attempt, beside the job folder (which the first shard claims empty).
    attempts = a.out.parent / f"{a.out.name}.ray-attempts"
    task = ray.remote(num_cpus=a.cpus_per_task, max_retries=a.max_retries)(run_shard)
    refs = [
        task.remote(a.xtask, a.command, a.cpus_per_task, i, a.shards, str(attempts), not a.no_steal)
        for i in range(1, a.shards + 1)
    ]
    results = []
    for ref in refs:
        try:
            results.append(ray.get(ref))
        except Exception as e:  # a shard that Ray gave up on (retries spent)
            results.append({"returncode": None, "error": f"{type(e).__name__}: {e}"})
    tasks_s = time.time() - started
    if not a.address:
        ray.shutdown()
    ran_s = time.time() - t0
    tries = {}
    for f in attempts.glob("shard-*.pid-*"):
        shard = f.name.split(".pid-")[0]
        tries[shard] = tries.get(shard, 0) + 1
    for r in results:
        if r.get("returncode") not in (0, None) and not r.get("ran"):
            print(f"shard {r['shard']} on {r['host']} failed:\n{r['stderr']}", file=sys.stderr)
        if r.get("error"):
            print(f"a shard was lost: {r['error']}", file=sys.stderr)
    retried = {k: v for k, v in tries.items() if v > 1}
    print(
        f"ray: {a.shards} shards in {ran_s:.1f} s"
        + (f"; re-run after a worker died: {retried}" if retried else ""),
        file=sys.stderr,
    )
    merge = [a.xtask, "merge", str(a.out)] + (["--json"] if a.json else [])
    m = subprocess.run(merge, capture_output=True, text=True)
    if a.json:
        try:
            out = json.loads(m.stdout)
        except ValueError:
            out = {"merge_stdout": m.stdout}
        # start_s: joining (or starting and stopping) the cluster; tasks_s: the shards' tasks.
        out["ray"] = {
            "shards": results,
            "attempts": tries,
            "seconds": ran_s,
            "start_s": ran_s - tasks_s,
            "tasks_s": tasks_s,
        }
        print(json.dumps(out, indent=2))
    else:
        sys.stdout.write(m.stdout)
    sys.stderr.write(m.stderr)
    return m.returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

"""First-run compile time: ``sogdd demo`` in a fresh environment (an empty numba cache), function by function.

Each round runs two child processes, each with its own empty ``NUMBA_CACHE_DIR``:

* ``python -m sogdd demo``, timed from the outside (wall and CPU seconds, the
  interpreter's start and every import included): what a new user waits for;
* the same command in a process that listens to numba's ``numba:compile`` events
  (:mod:`numba.core.event`) and charges each compiled function its *own* time:
  a callee compiled while its caller is being typed is charged to the callee, not
  twice. Seconds are wall and thread CPU (the compiling thread's own CPU time,
  which other processes' load changes less than the wall); "LLVM" is the part of
  the own wall time spent in LLVM (``numba:llvm_lock``: optimisation and machine
  code), the rest is numba's own typing and lowering in Python.

The table gives, per function, the median over the rounds of its own compile
time and the number of specialisations compiled (signatures); the totals give
the median and the range (min-max) over the rounds. The machine's load moves
the wall times; the CPU times and the signature counts are the steadier figures.

Run: ``python benchmarks/bench_compile.py [--repeat 5] [--preset paper] [--top 25] [--json out.json]``
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections import defaultdict
from pathlib import Path


def _child(preset: str, out: str) -> None:
    """Run the demo with numba's compile events recorded; print one JSON line."""
    import numba.core.event as ev

    own: dict[str, list[float]] = defaultdict(lambda: [0.0, 0.0, 0, 0.0])  # wall, cpu, signatures, llvm
    local = threading.local()

    class Own(ev.Listener):
        """Each compile's time minus the compiles nested in it (per thread: tiles compile in threads)."""

        def on_start(self, event):
            stack = local.__dict__.setdefault("stack", [])
            stack.append([time.perf_counter(), time.thread_time(), 0.0, 0.0, 0.0])

        def on_end(self, event):
            stack = local.stack
            t0, c0, nested_wall, nested_cpu, llvm = stack.pop()
            wall, cpu = time.perf_counter() - t0, time.thread_time() - c0
            f = event.data["dispatcher"].py_func
            row = own[f"{f.__module__}.{f.__qualname__}"]
            row[0] += wall - nested_wall
            row[1] += cpu - nested_cpu
            row[2] += 1
            row[3] += llvm
            if stack:
                stack[-1][2] += wall
                stack[-1][3] += cpu

    class Llvm(ev.Listener):
        """LLVM's time, charged to the innermost compile of its thread."""

        def on_start(self, event):
            local.llvm0 = time.perf_counter()

        def on_end(self, event):
            stack = local.__dict__.get("stack")
            if stack:
                stack[-1][4] += time.perf_counter() - local.llvm0

    ev.register("numba:compile", Own())
    ev.register("numba:llvm_lock", Llvm())
    from sogdd.cli.main import main

    t0, c0 = time.perf_counter(), time.process_time()
    code = main(["demo", "--preset", preset, "--out", out])
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    print(json.dumps({"code": code, "wall": wall, "cpu": cpu, "own": dict(own)}))


def _run(cmd: list[str]) -> tuple[subprocess.CompletedProcess, float, float]:
    """Run ``cmd`` with a fresh, empty numba cache; its wall and CPU seconds (user + system)."""
    with tempfile.TemporaryDirectory(prefix="sogdd-numba-") as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        done = subprocess.run(cmd, env=env, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        sys.exit(f"bench_compile: {' '.join(cmd)} failed:\n{done.stderr}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return done, wall, cpu


def _spread(xs: list[float]) -> str:
    return f"{statistics.median(xs):6.2f} s ({min(xs):.2f}-{max(xs):.2f})"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="rounds (each: one plain and one recorded demo)")
    ap.add_argument("--preset", default="paper", choices=["paper", "authors"], help="the demo's preset")
    ap.add_argument("--top", type=int, default=25, help="functions listed (by own compile CPU time)")
    ap.add_argument("--json", help="also write every round's figures to this file")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        out = str(Path(tmp) / "demo.png")
        if args.child:
            return _child(args.preset, out)
        plain, recorded = [], []
        for _ in range(args.repeat):
            _, wall, cpu = _run([sys.executable, "-m", "sogdd", "demo", "--preset", args.preset, "--out", out])
            plain.append({"wall": wall, "cpu": cpu})
            done, wall, cpu = _run([sys.executable, __file__, "--child", "--preset", args.preset])
            rec = json.loads(done.stdout.strip().splitlines()[-1])
            rec.update(process_wall=wall, process_cpu=cpu)
            recorded.append(rec)
    names = {n for r in recorded for n in r["own"]}
    rows = []
    for n in names:
        got = [r["own"].get(n, [0.0, 0.0, 0, 0.0]) for r in recorded]
        rows.append((statistics.median(g[1] for g in got), statistics.median(g[0] for g in got),
                     statistics.median(g[3] for g in got), max(g[2] for g in got), n))
    rows.sort(reverse=True)
    print(f"sogdd demo --preset {args.preset}, empty numba cache, {args.repeat} rounds "
          f"({os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at the end)")
    print(f"{'own CPU s':>10} {'own wall s':>10} {'LLVM s':>7} {'sigs':>4}  function")
    for cpu, wall, llvm, nsig, n in rows[: args.top]:
        print(f"{cpu:10.2f} {wall:10.2f} {llvm:7.2f} {nsig:4d}  {n}")
    if len(rows) > args.top:
        rest = rows[args.top:]
        print(f"{sum(r[0] for r in rest):10.2f} {sum(r[1] for r in rest):10.2f} {sum(r[2] for r in rest):7.2f}"
              f" {sum(r[3] for r in rest):4d}  ({len(rest)} more)")
    comp_cpu = [sum(v[1] for v in r["own"].values()) for r in recorded]
    comp_wall = [sum(v[0] for v in r["own"].values()) for r in recorded]
    sigs = [sum(v[2] for v in r["own"].values()) for r in recorded]
    print(f"compiled specialisations: {statistics.median(sigs):.0f}")
    print(f"compile time, own CPU:    {_spread(comp_cpu)}")
    print(f"compile time, own wall:   {_spread(comp_wall)}")
    print(f"first sogdd demo, wall:   {_spread([p['wall'] for p in plain])}   <- python -m sogdd demo, "
          "empty cache, the interpreter's start included")
    print(f"first sogdd demo, CPU:    {_spread([p['cpu'] for p in plain])}")
    if args.json:
        Path(args.json).write_text(json.dumps({"plain": plain, "recorded": recorded}, indent=1))


if __name__ == "__main__":
    main()

"""
Benchmark: compiling radiosim's kernels from an empty numba cache (issue: instant in the
user's hands; target ≤ 15 s for all kernels together on 2 cores).

First ``radiosim warmup`` as a user runs it, from an empty ``NUMBA_CACHE_DIR`` (a temporary
folder, removed after): every kernel, one after the other in the command's process (the
target's measure). Then, in one fresh process with another empty cache, the same kernels one
after the other: :func:`radiosim.kernels.warmup` and the segmented chip's moving terms,
recording numba's compile events; it prints the wall time of each step and, per compiled
function, its signatures and its own compile time (nested compilations of the functions it calls subtracted), largest
first: the total CPU the compilation costs, and where. Run on demand:

    python benchmarks/bench_compile.py [--top 25]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _host import speed_probe

CHILD = r"""
import json, sys, time
from numba.core import event

records = []  # (name, signature, own seconds)
stack = []


class Listener(event.Listener):
    def on_start(self, ev):
        stack.append([ev.data["dispatcher"], ev.data["args"], time.perf_counter(), 0.0])

    def on_end(self, ev):
        dispatcher, args, began, nested = stack.pop()
        total = time.perf_counter() - began
        if stack:
            stack[-1][3] += total
        name = getattr(dispatcher, "py_func", dispatcher).__qualname__
        module = getattr(getattr(dispatcher, "py_func", None), "__module__", "?")
        records.append((f"{module}.{name}", str(args), total - nested))


event.register("numba:compile", Listener())
steps = {}
began = time.perf_counter()
import radiosim.kernels as kernels
steps["import"] = time.perf_counter() - began
t = time.perf_counter()
report = kernels.warmup()
steps["integrator kernels (warmup)"] = time.perf_counter() - t
t = time.perf_counter()
from radiosim.scenes import SegmentedChip
chip = SegmentedChip()
middle = tuple(slice(n // 2, n // 2 + 16) for n in chip.shape)
chip.temperature(chip.event_time, middle), chip.regions(chip.event_time, middle)
steps["chip's moving terms"] = time.perf_counter() - t
print(json.dumps({"steps": steps, "records": records, "variants": report["variants"]}))
"""


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--top", type=int, default=25, help="functions to list")
    args = parser.parse_args()
    probe = speed_probe()
    radiosim = [str(Path(sys.executable).with_name("radiosim"))]
    if not Path(radiosim[0]).is_file():
        radiosim = [sys.executable, "-c", "import sys; from radiosim.cli import main; "
                    "sys.exit(main())"]
    with tempfile.TemporaryDirectory(prefix="radiosim-numba-cache-") as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        began = time.perf_counter()
        subprocess.run(radiosim + ["warmup", "-q"], env=env, capture_output=True, check=True)
        warmup = time.perf_counter() - began
    print(f"every kernel, `radiosim warmup` from an empty cache (target <= 15 s): {warmup:.1f} s"
          f" on {os.cpu_count()} cores")
    print(f"host speed probe, sum(range(10**7)): {probe:.3f} s before, {speed_probe():.3f} s "
          "after (about 0.17 s on a quiet host)\n")
    with tempfile.TemporaryDirectory(prefix="radiosim-numba-cache-") as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        out = subprocess.run([sys.executable, "-c", CHILD], env=env, capture_output=True,
                             text=True, check=True)
    result = json.loads(out.stdout.strip().splitlines()[-1])
    print(f"{'one process, step by step (empty cache)':<40}{'time [s]':>10}")
    for name, seconds in result["steps"].items():
        print(f"{name:<40}{seconds:>10.1f}")
    print(f"{'total':<40}{sum(result['steps'].values()):>10.1f}")
    by_function: dict[str, list] = {}
    for name, signature, seconds in result["records"]:
        entry = by_function.setdefault(name, [0, 0.0])
        entry[0] += 1
        entry[1] += seconds
    print(f"\n{'function (own compile time)':<60}{'signatures':>11}{'time [s]':>10}")
    ranked = sorted(by_function.items(), key=lambda item: -item[1][1])
    for name, (count, seconds) in ranked[:args.top]:
        print(f"{name.removeprefix('radiosim.'):<60}{count:>11}{seconds:>10.2f}")
    rest = ranked[args.top:]
    if rest:
        print(f"{f'{len(rest)} more':<60}{sum(c for _, (c, _) in rest):>11}"
              f"{sum(s for _, (_, s) in rest):>10.2f}")
    print(f"{'all':<60}{len(result['records']):>11}"
          f"{sum(s for *_, s in result['records']):>10.1f}")


if __name__ == "__main__":
    main()

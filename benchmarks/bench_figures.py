"""
Benchmark: the paper's figures of ``radiosim run`` (issue 22: ≤ 1.5 s), drawn from a study's
results folder, each figure's build and save timed, best of ``--repeat`` rounds in one process
(the first round includes matplotlib's import, as in a run).

    python benchmarks/bench_figures.py RESULTS_FOLDER [--repeat 3] [--profile N]

``RESULTS_FOLDER`` is the output of ``radiosim run`` (its results.csv, exr/ and
pixel_history.csv); the figures are written into a temporary folder, not into it.
``--profile N`` prints the N costliest functions of one more round (cProfile).
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path


def _round(folder: Path, scene, out: Path) -> dict:
    """One round: every figure of :func:`radiosim.paper.figures.make_figures`, built and saved
    into ``out`` with the garbage collector held as :func:`~radiosim.paper.figures.make_figures`
    holds it (its one pass at the end timed too); seconds [s] per step."""
    from radiosim.paper import figures as F
    from radiosim.plotting import collector_held, load_results, save_figure

    times, cpu = {}, {}
    t0, c0 = time.perf_counter(), time.process_time()
    import matplotlib.figure  # noqa: F401  (the import a run's first figure pays)
    from matplotlib.backends import backend_agg  # noqa: F401

    times["matplotlib import"] = time.perf_counter() - t0
    cpu["matplotlib import"] = time.process_time() - c0
    rows, history = load_results(folder)
    cache: dict = {}
    cases = [r for r in rows if r["sweep"] == "size-of-source" and r["camera"] == "linear"
             and round(r["pixel_samples"], 6) == 9]
    cases += [r for r in rows if r["sweep"] == "integration-time" and r["camera"] == "linear"
              and r["integration_time_us"] in (10, 45, 90)]
    steps = (("fig05_peak", lambda: F.plot_peak(rows)),
             ("fig07_column_I", lambda: F.plot_column_i(rows)),
             ("fig06_profiles", lambda: F.plot_column_profiles(rows, folder, scene,
                                                                cache=cache)),
             ("fig08_long_integration", lambda: F.plot_long_integration(rows, history)),
             ("fig09-11_maps", lambda: F.plot_maps(folder, rows, cases, cache=cache)))
    with collector_held():  # as make_figures
        for name, build in steps:
            t0, c0 = time.perf_counter(), time.process_time()
            fig = build()
            t1, c1 = time.perf_counter(), time.process_time()
            save_figure(fig, out / f"{name}.png")
            times[f"{name}: build"], cpu[f"{name}: build"] = t1 - t0, c1 - c0
            times[f"{name}: save"] = time.perf_counter() - t1
            cpu[f"{name}: save"] = time.process_time() - c1
        del fig
        t0, c0 = time.perf_counter(), time.process_time()
    times["garbage collection, once"] = time.perf_counter() - t0  # collector_held's exit
    cpu["garbage collection, once"] = time.process_time() - c0
    return times, cpu


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folder", type=Path, help="a results folder of `radiosim run`")
    parser.add_argument("--repeat", type=int, default=3, help="rounds; the best is kept")
    parser.add_argument("--profile", type=int, default=0, metavar="N",
                        help="profile one more round and print its N costliest functions")
    args = parser.parse_args(argv)

    from radiosim.study import Study

    scene = Study.preset("msec2009").scene
    scene.temperature(scene.event_time)  # prepared, as after a run's measurements
    out = Path(tempfile.mkdtemp(prefix="bench_figures_"))
    try:
        rounds, cpu = [], []
        for _ in range(args.repeat):
            wall, used = _round(args.folder, scene, out)
            rounds.append(wall)
            cpu.append(used)
        if args.profile:
            import cProfile
            import pstats

            profile = cProfile.Profile()
            profile.runcall(_round, args.folder, scene, out)
            pstats.Stats(profile, stream=sys.stdout).sort_stats("tottime").print_stats(
                args.profile)
    finally:
        shutil.rmtree(out, ignore_errors=True)
    keys = list(rounds[0])
    print(f"| {'step':<32} | {'first [s]':>9} | {'best [s]':>8} | {'CPU, best [s]':>13} |")
    print(f"| {'-' * 32} | {'-' * 9} | {'-' * 8} | {'-' * 13} |")
    for key in keys:
        print(f"| {key:<32} | {rounds[0][key]:>9.3f} | {min(r[key] for r in rounds):>8.3f} | "
              f"{min(c[key] for c in cpu):>13.3f} |")
    totals = [sum(r.values()) for r in rounds]
    print(f"| {'total, round (target <= 1.5 s)':<32} | {totals[0]:>9.3f} | {min(totals):>8.3f} "
          f"| {min(sum(c.values()) for c in cpu):>13.3f} |")
    print("first: the first round, matplotlib's import included, as in a run; best: the "
          "fastest of the rounds (per step and in total); CPU: process time, which a loaded "
          f"host inflates less (load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)")


if __name__ == "__main__":
    main()

"""
Benchmark: one Monte Carlo draw of the shipped ``chip-budget`` study against a nominal
measurement (issue 23's table), from one run.

The ``chip-budget`` study (the nist-ir camera on the segmented chip on the paper's grid, 0.667 µm
and 0.2 µs; emissivity, PSF width, window start and calibration scale uncertain, and the noise)
is propagated in this process (the synchronous scheduler) with ``--draws`` draws in batches of
``--batch``. Reported: the nominal measurement (after a first one that compiles and builds the
geometry); the running sums the draws share (:mod:`radiosim.budget_reuse`, built by the first
batch: its time less that of a later batch); one draw, the mean over the draws after the first
batch (from the progress callback's time stamps); their ratio; 1000 draws extrapolated (the
sums plus 1000 draws), and a whole 1000-draw budget with its default one-input-at-a-time
draws (250 per input and for the noise, and 2 per input for the GUM sensitivities); the peak
resident memory of the process (``ru_maxrss``: the memory-mapped sums count where their pages
are resident) and the load average before the run. With ``--workers N`` the same budget also
runs on a local cluster of N workers (each builds its own sums). Run on demand:

    python benchmarks/bench_uncertainty.py [--draws 40] [--batch 10] [--workers 2]
"""

import argparse
import os
import resource
import time

import numpy as np

from radiosim.study import Study
from radiosim.uncertainty import propagate


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--draws", type=int, default=40)
    parser.add_argument("--batch", type=int, default=10)
    parser.add_argument("--workers", type=int, default=None)
    args = parser.parse_args(argv)
    load = os.getloadavg()
    study = Study.preset("chip-budget")
    spec = study.uncertainty
    camera, scene = study.cameras[spec.camera], study.scene
    camera.measure(scene, spec.integration_time, rng=0)  # compile, build the geometry
    start = time.perf_counter()
    camera.measure(scene, spec.integration_time, rng=0)
    nominal = time.perf_counter() - start

    stamps = []
    start = time.perf_counter()
    propagate(camera, scene, spec.integration_time, spec.inputs, draws=args.draws,
              rng=spec.seed, budget_draws=2, batch=args.batch, scheduler="synchronous",
              progress=lambda done, total: stamps.append((done, time.perf_counter())))
    total = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20  # [GiB]
    (first_done, first_at), (last_done, last_at) = stamps[0], stamps[-1]
    draw = (last_at - first_at) / (last_done - first_done)  # [s]
    sums = (first_at - start) - first_done * draw  # the first batch's extra: nominal + sums
    n_inputs = len(spec.inputs)
    budget_1000 = 1000 + 250 * (n_inputs + 1) + 2 * n_inputs
    print(f"chip-budget: nist-ir on the chip ({scene.shape[1]} × {scene.shape[0]} samples of "
          f"{scene.dx * 1e6:.3g} µm, {scene.dt * 1e6:g} µs frames), "
          f"{spec.integration_time * 1e6:g} µs window, {n_inputs} inputs and the noise; "
          f"{args.draws} draws in this process; load average before {load[0]:.2f}")
    rows = [("nominal measurement", f"{nominal:.2f} s", ""),
            ("running sums + nominal (once per budget)", f"{sums:.1f} s", ""),
            ("one draw (mean over draws after the first batch)", f"{draw:.3f} s",
             f"{draw / nominal:.2f}× nominal"),
            ("1000 draws (sums + 1000 draws)", f"{(sums + 1000 * draw) / 60:.1f} min", ""),
            (f"1000-draw budget ({budget_1000} evaluations with the default budget draws)",
             f"{(sums + budget_1000 * draw) / 60:.1f} min", ""),
            ("this run (whole propagate)", f"{total:.1f} s", ""),
            ("peak resident memory", f"{peak:.2f} GiB", "")]
    width = max(len(r[0]) for r in rows) + 2
    for name, value, ratio in rows:
        print(f"{name:<{width}}{value:>12}  {ratio}")
    if args.workers:
        start = time.perf_counter()
        propagate(camera, scene, spec.integration_time, spec.inputs, draws=args.draws,
                  rng=spec.seed, budget_draws=2, batch=args.batch, workers=args.workers)
        print(f"{'local cluster, ' + str(args.workers) + ' workers (whole propagate)':<{width}}"
              f"{time.perf_counter() - start:>10.1f} s")
    return np.isfinite(draw)


if __name__ == "__main__":
    main()

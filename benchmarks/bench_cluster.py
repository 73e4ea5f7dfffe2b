"""
Benchmark: the paper's study in this process and on a local Dask cluster, against the estimate
``radiosim run --workers N`` decides by (:func:`radiosim.scheduling.worth_a_cluster`).

The constants behind the estimate are measured here, from one run:

- ``SECONDS_PER_SAMPLE``: the study's measurements in this process, warm (kernels compiled and
  loaded, the scene's geometry built: as the second study a session runs), divided by the
  sample-frames they read (``Study._seconds_per_measurement`` × measurements /
  ``SECONDS_PER_SAMPLE``);
- ``CLUSTER_START_SECONDS``: a study of two one-frame measurements (the size-of-source sweep's
  smallest pixel, both cameras) on a local cluster of ``--workers`` processes
  (``cluster="always"``: started, the scene shipped, each worker importing radiosim, loading
  the kernels and building the scene's geometry for its first measurement, closed), minus
  the same study in this process (run a second time: its scene built); with more workers
  than cores this is ``cluster_overhead``, the constant times workers / cores;
- ``STUDY_TASK_FACTOR``: the paper's study on the cluster, minus that start, times the
  workers sharing it (at most its tasks: one a part of a scene's frames), over the study in
  this process (a task measures a scene's cases over one part of its frames in one pass on
  its worker's thread, where this process does the same parts on every core). Before issue 43 each measurement was a task
  making its own frames: ``CLUSTER_TASK_FACTOR``, 12, which budgets' draw batches keep.

It prints both runs, the estimate of each and the choice the estimate makes. The numba cache is
the user's (a warm run); nothing is written to disk but the cache and Dask's scratch folder. Run
on demand, on a quiet host (the host's speed probe is printed beside):

    python benchmarks/bench_cluster.py [--workers 2]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import time

from _host import speed_probe


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args(argv)
    probe_before = speed_probe()

    from radiosim import scheduling
    from radiosim.study import Study

    study = Study.preset("msec2009")
    plan = list(study.plan())
    small = Study.preset("msec2009")  # two one-frame measurements: the cluster's fixed cost
    sweep = next(s for s in small.sweeps if s.name == "size-of-source")
    small.sweeps = [dataclasses.replace(sweep, pixel_samples=sweep.pixel_samples[:1])]
    small.hooks = {}
    timed = {}
    for what, which, workers in (("warm-up", study, None), ("alone", study, None),
                                 ("small warm-up", small, None),  # its own scene built
                                 ("small alone", small, None),
                                 ("small cluster", small, args.workers),
                                 ("cluster", study, args.workers)):
        began = time.perf_counter()
        which.run(None, progress=None, workers=workers, cluster="always")
        timed[what] = time.perf_counter() - began
    alone, cluster = timed["alone"], timed["cluster"]
    began = time.perf_counter()
    run, close = scheduling.connect(None, args.workers)
    started = time.perf_counter()
    close()
    timed["cluster start"], timed["cluster close"] = started - began, time.perf_counter() - started

    n = len(plan)
    each = study._seconds_per_measurement(plan)  # with the current SECONDS_PER_SAMPLE
    samples = each * n / scheduling.SECONDS_PER_SAMPLE
    per_sample = alone / samples
    cores = scheduling._cores()
    tasks = study._tasks(plan)  # one a scene: its cases in one pass on a worker
    share = max(1, min(args.workers, cores, tasks))
    start = timed["small cluster"] - timed["small alone"]
    factor = (cluster - start) * share / alone
    estimate_alone = each * n
    estimate_cluster = (scheduling.cluster_overhead(args.workers, cores)
                        + estimate_alone * scheduling.STUDY_TASK_FACTOR / share)
    gain, reason = scheduling.worth_a_cluster(tasks, estimate_alone / tasks, args.workers,
                                              cores, scheduling.STUDY_TASK_FACTOR, "task")
    probe_after = speed_probe()

    print(f"the paper's study ({n} measurements in {tasks} tasks, {samples:.3g} sample-frames), "
          f"{os.cpu_count()} cores, load average "
          f"{', '.join(f'{x:.1f}' for x in os.getloadavg())}")
    print(f"host speed probe, sum(range(10**7)): {probe_before:.3f} s before, "
          f"{probe_after:.3f} s after (about 0.17 s on a quiet host)")
    width = 44
    print(f"{'':<{width}} {'measured':>9} {'estimate':>9}")
    print(f"{'in this process, warm [s]':<{width}} {alone:9.2f} {estimate_alone:9.2f}")
    print(f"{f'local cluster of {args.workers} workers [s]':<{width}} {cluster:9.2f} "
          f"{estimate_cluster:9.2f}")
    print(f"{'seconds per sample-frame [s]':<{width}} {per_sample:9.2e} "
          f"{scheduling.SECONDS_PER_SAMPLE:9.2e}")
    print(f"{'cluster start, shipping, close [s]':<{width}} {start:9.2f} "
          f"{scheduling.cluster_overhead(args.workers, cores):9.2f}")
    print(f"{'work on the cluster / in this process':<{width}} {factor:9.2f} "
          f"{scheduling.STUDY_TASK_FACTOR:9.2f}")
    print(f"two one-frame measurements: {timed['small alone']:.2f} s in this process, "
          f"{timed['small cluster']:.2f} s on the cluster; an empty cluster: started in "
          f"{timed['cluster start']:.2f} s, closed in {timed['cluster close']:.2f} s")
    print(f"cluster / this process, measured: {cluster / alone:.2f}")
    print(f"the estimate's choice: {'cluster' if gain else 'this process'} ({reason})")


if __name__ == "__main__":
    main()

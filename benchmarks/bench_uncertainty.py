"""
Benchmark: Monte Carlo draws per second of an uncertainty budget, and the speed-up from one to
two Dask workers.

The shipped ``chip-budget`` study (the nist-ir camera on the segmented chip at 2 µm, 1 µs;
emissivity, PSF width, window position and calibration scale uncertain, and the noise) is
propagated with ``--draws`` draws: in this process (the synchronous scheduler), on a local
``distributed`` cluster of one worker process and of two. Each reports draws per second of the
main Monte Carlo (the budget's own one-at-a-time draws are excluded: ``budget_draws`` is the
minimum) and the two-worker speed-up over one worker. Run on demand:

    python benchmarks/bench_uncertainty.py [--draws 200]
"""

import argparse
import time

from radiosim.study import Study
from radiosim.uncertainty import propagate


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--draws", type=int, default=200)
    args = parser.parse_args(argv)
    study = Study.preset("chip-budget")
    spec = study.uncertainty
    camera, scene = study.cameras[spec.camera], study.scene
    camera.measure(scene, spec.integration_time, rng=0)  # compile, build the geometry

    def timed(**engine):
        start = time.perf_counter()
        propagate(camera, scene, spec.integration_time, spec.inputs, draws=args.draws,
                  rng=spec.seed, budget_draws=2, batch=spec.batch, **engine)
        return time.perf_counter() - start

    rows = [("this process (synchronous)", timed(scheduler="synchronous")),
            ("local cluster, 1 worker", timed(workers=1)),
            ("local cluster, 2 workers", timed(workers=2))]
    print(f"chip-budget: {args.draws} draws of nist-ir on the chip "
          f"({scene.shape[1]} × {scene.shape[0]} samples), {len(spec.inputs)} inputs and noise")
    print(f"{'engine':<30}{'wall [s]':>10}{'draws/s':>10}")
    for name, seconds in rows:
        print(f"{name:<30}{seconds:>10.1f}{args.draws / seconds:>10.2f}")
    print(f"speed-up from one to two workers: {rows[1][1] / rows[2][1]:.2f}× "
          "(cluster start-up included)")


if __name__ == "__main__":
    main()

"""
Benchmark: one scene's frames split across Dask workers (issue 43), in one run.

A scene larger than a worker's memory limit — 1024 frames of 512 × 512 float32 samples
(1 GiB) in a NetCDF file chunked by 16 frames, opened with xarray as Dask arrays
(``FrameStack.from_xarray``) — measured by ``nist-ir`` (Planck response, 2 µm pixels on 1 µm
samples) over the whole scene: six parts (``part_frames``: 192 frames, the last 64). The
measurement runs in this process, on a local cluster of one single-thread worker and on one of
two (each worker's memory limit 768 MiB, three quarters of the scene's size; a worker holds
about 160 MiB once it has imported radiosim), the clusters started and warmed (a first
measurement) before the clock. It
prints each time, two workers' speed-up over one (issue 43 asks at least 1.5×), each worker's
peak resident memory against its limit, and whether the three results are the same bits.

    python benchmarks/bench_split.py
"""

import os
import resource
import tempfile
import time
from pathlib import Path

import numpy as np

import radiosim as rs

FRAMES, SIDE, CHUNK = 1024, 512, 16
LIMIT = 768 * 2**20


def write_scene(path: Path) -> None:
    import xarray as xr

    rng = np.random.default_rng(1)
    data = xr.DataArray(np.zeros((FRAMES, SIDE, SIDE), np.float32), dims=("time", "y", "x"))
    ds = xr.Dataset({"T": data})
    ds["T"].attrs["units"] = "K"
    ds["time"] = ("time", np.arange(FRAMES) * 1e-6, {"units": "s"})
    ds["x"] = ("x", (np.arange(SIDE) + 0.5) * 1e-6, {"units": "m"})
    ds["y"] = ("y", (np.arange(SIDE) + 0.5) * 1e-6, {"units": "m"})
    encoding = {"T": {"chunksizes": (CHUNK, SIDE, SIDE)}}
    ds.to_netcdf(path, engine="h5netcdf", encoding=encoding, compute=True)
    import h5py

    with h5py.File(path, "r+") as f:  # the frames, a chunk at a time
        for start in range(0, FRAMES, CHUNK):
            y, x = np.mgrid[0:SIDE, 0:SIDE]
            block = 500.0 + 300.0 * rng.random((CHUNK, 1, 1)) * np.exp(
                -((x - SIDE / 2) ** 2 + (y - SIDE / 2) ** 2) / (2 * 80.0 ** 2))
            f["T"][start:start + CHUNK] = block.astype(np.float32)


def peak_rss() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def main():
    import xarray as xr
    from distributed import Client, LocalCluster

    camera = rs.Camera.preset("nist-ir")
    camera = camera.replace(fpa=camera.fpa.__class__(**{**camera.fpa.__dict__, "shape": None,
                                                        "pixel_pitch": 2e-6}))
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "scene.nc"
        write_scene(path)
        print(f"scene: {FRAMES} frames of {SIDE} × {SIDE} float32, "
              f"{path.stat().st_size / 2**20:.0f} MiB on disk, chunks of {CHUNK} frames")

        def measure(scheduler=None):
            with xr.open_dataset(path, engine="h5netcdf", chunks={"time": CHUNK}) as ds:
                scene = rs.FrameStack.from_xarray(ds["T"])
                start = time.perf_counter()
                m = camera.measure(scene, FRAMES * 1e-6, 0.0, rng=1, scheduler=scheduler)
                return m, time.perf_counter() - start

        measure()  # kernels compiled and cached
        here, t_here = measure()
        print(f"this process                 {t_here:7.2f} s")
        results = {}
        for workers in (1, 2):
            with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                              memory_limit=LIMIT, dashboard_address=None) as cluster, \
                    Client(cluster) as client:
                measure(client)  # each worker: radiosim imported, its kernels loaded
                m, seconds = measure(client)
                peaks = client.run(peak_rss)
                results[workers] = (m, seconds)
                print(f"{workers} single-thread worker{'s' if workers > 1 else ' '}     "
                      f"{seconds:7.2f} s   peak resident memory "
                      + ", ".join(f"{p / 2**20:.0f} MiB" for p in peaks.values())
                      + f" (limit {LIMIT / 2**20:.0f} MiB)")
        print(f"two workers over one: {results[1][1] / results[2][1]:.2f}×")
        same = all(np.array_equal(getattr(results[w][0], name), getattr(here, name),
                                  equal_nan=True)
                   for w in results for name in ("counts", "tensor_mean", "tensor_std",
                                                 "tensor_max", "signal_mean"))
        print("the same bits here and on 1 and 2 workers:", same)


if __name__ == "__main__":
    os.environ.setdefault("PYTHONHASHSEED", "0")
    main()

"""A scene from a chunked, Dask-backed xarray variable (issue 43's first part): read a time chunk
at a time, the same bits as the frames in memory, pickled as its file, and measured inside a
single-thread cluster worker without waiting on itself."""

import pickle

import numpy as np
import pytest
import xarray as xr

import radiosim as rs
from radiosim.scenes.framestack import _LazyFrames


@pytest.fixture
def stored(tmp_path):
    """40 frames of 24 × 30 samples in a NetCDF file, and the same frames in memory."""
    rng = np.random.default_rng(4)
    frames = 600.0 + 300.0 * rng.random((40, 24, 30))
    coords = {"time": ("time", np.arange(40) * 1e-6, {"units": "s"}),
              "y": ("y", np.arange(24) * 1e-6, {"units": "m"}),
              "x": ("x", np.arange(30) * 1e-6, {"units": "m"})}
    path = tmp_path / "frames.nc"
    xr.Dataset({"T": (("time", "y", "x"), frames, {"units": "K"})}, coords=coords).to_netcdf(
        path, engine="h5netcdf")
    return path, frames


def measure(scene):
    return rs.Camera.linear_ideal(3e-6).measure(scene, 17.5e-6, t_start=3.25e-6)


def test_a_chunked_variable_reads_a_chunk_at_a_time_with_the_same_bits(stored, monkeypatch):
    """Chunks of 8 frames; the window (3.25–20.75 µs) touches frames 3–20, chunks 0–2: three
    reads, not eighteen; the measurement equals the one of the frames in memory, bit for
    bit."""
    path, frames = stored
    loads = []
    original = _LazyFrames._load
    monkeypatch.setattr(_LazyFrames, "_load",
                        lambda self, key: loads.append(key) or original(self, key))
    with xr.open_dataset(path, engine="h5netcdf", chunks={"time": 8}) as ds:
        lazy = rs.FrameStack.from_xarray(ds["T"])
        m = measure(lazy)
    reference = measure(rs.FrameStack(frames, dt=1e-6, dx=1e-6))
    np.testing.assert_array_equal(m.apparent_temperature, reference.apparent_temperature)
    np.testing.assert_array_equal(m.tensor_max, reference.tensor_max)
    assert len(loads) == 3, loads


def test_a_chunked_scene_pickles_as_its_file_not_its_frames(stored):
    path, frames = stored
    with xr.open_dataset(path, engine="h5netcdf", chunks={"time": 8}) as ds:
        scene = rs.FrameStack.from_xarray(ds["T"])
        data = pickle.dumps(scene)
        assert len(data) < frames.nbytes / 4  # the graph and the path, not 230 kB of frames
        back = pickle.loads(data)
        assert isinstance(back._stack, _LazyFrames)
        np.testing.assert_array_equal(measure(back).apparent_temperature,
                                      measure(scene).apparent_temperature)


def test_a_chunked_scene_is_measured_inside_single_thread_workers(stored):
    """A worker with one thread measures the scene (its reads on Dask's synchronous scheduler:
    they used to submit to the worker's own cluster and wait on themselves)."""
    from distributed import Client, LocalCluster

    path, frames = stored
    reference = measure(rs.FrameStack(frames, dt=1e-6, dx=1e-6)).apparent_temperature
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        with xr.open_dataset(path, engine="h5netcdf", chunks={"time": 8}) as ds:
            scene = rs.FrameStack.from_xarray(ds["T"])
            future = client.submit(lambda s: measure(s).apparent_temperature, scene)
            got = future.result(timeout=120)
    np.testing.assert_array_equal(got, reference)

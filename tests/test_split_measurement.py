"""One window's frames integrated in parts (acquisition.split_statistics): the parts merged in
order give the window's statistics (against a naive weighted reference), and the same bits in
this process and on a Dask cluster's workers, however many, a worker killed or not."""

import dataclasses
import os
import signal
import threading

import numpy as np
import pytest

import radiosim as rs
from radiosim.acquisition import FRAME_CHUNK, frame_ranges, merge_statistics
from radiosim.integrator import TensorStatistics
from radiosim.scenes import FrameStack

N_FRAMES = 2 * FRAME_CHUNK + 37  # three parts, the last one shorter


@pytest.fixture(autouse=True)
def parts_of_one_chunk(monkeypatch):
    """These scenes are small: parts of FRAME_CHUNK frames all the same (the parts are
    decided in this process and sent to the workers as frame ranges)."""
    import radiosim.acquisition

    monkeypatch.setattr(radiosim.acquisition, "PART_SAMPLES", 1)


def test_a_part_holds_enough_sample_frames_to_pay_for_its_task(monkeypatch):
    import radiosim.acquisition
    from radiosim.acquisition import part_frames

    monkeypatch.setattr(radiosim.acquisition, "PART_SAMPLES", 5e7)  # radiosim's own

    assert part_frames(1113 * 1440) == FRAME_CHUNK  # the paper's chip: 64 frames a part
    assert part_frames(512 * 512) == 3 * FRAME_CHUNK  # 5e7 sample-frames: 191 frames, up
    assert part_frames(81) % FRAME_CHUNK == 0 and part_frames(81) * 81 >= 5e7


def stack(rows=12, cols=15, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(400.0, 900.0, (N_FRAMES + 4, rows, cols))


def test_a_long_window_is_split_into_fixed_parts_from_its_first_frame():
    scene = FrameStack(stack(), dt=1e-6, dx=1e-6)
    window = rs.Camera.linear_ideal(1e-6).window(scene, N_FRAMES * 1e-6, 2e-6)
    assert frame_ranges(scene, window) == [(2, 2 + FRAME_CHUNK),
                                           (2 + FRAME_CHUNK, 2 + 2 * FRAME_CHUNK),
                                           (2 + 2 * FRAME_CHUNK, 2 + N_FRAMES)]


def test_the_merged_parts_are_the_windows_weighted_statistics():
    """One sample a pixel, a window starting mid-frame (its first and last frames weighted by
    the share they hold): the mean, population standard deviation and maximum of each pixel
    over the frames with their weights, computed here in plain numpy."""
    frames = stack()
    scene = FrameStack(frames, dt=1e-6, dx=1e-6)
    camera = rs.Camera.linear_ideal(1e-6)
    start, duration = 1.25e-6, (N_FRAMES - 1) * 1e-6
    m = camera.measure(scene, duration, start)
    k = np.arange(frames.shape[0])
    overlap = np.clip(np.minimum((k + 1) * 1e-6, start + duration) - np.maximum(k * 1e-6, start),
                      0.0, None)
    w = overlap / duration
    mean = np.tensordot(w, frames, axes=1)
    std = np.sqrt(np.tensordot(w, (frames - mean) ** 2, axes=1))
    np.testing.assert_allclose(m.tensor_mean, mean, rtol=1e-12)
    np.testing.assert_allclose(m.tensor_std, std, rtol=1e-9)
    np.testing.assert_array_equal(m.tensor_max, frames[w > 0].max(axis=0))
    assert m.n_frames == int(np.sum(w > 0))


def test_merging_is_chans_parallel_update():
    """Two parts of one and two frames (weights 1/3, 2/3) merged: the three frames' statistics."""
    a = np.array([[1.0]]); b = np.array([[4.0]]); c = np.array([[7.0]])
    first = TensorStatistics(a / 3, a, np.zeros((1, 1)), a, 1)
    second = TensorStatistics((b + c) / 3, (b + c) / 2, np.abs(c - b) / 2, c, 2)
    merged = merge_statistics([(first, 1 / 3), (second, 2 / 3)])
    assert merged.mean[0, 0] == pytest.approx(4.0)
    assert merged.signal_mean[0, 0] == pytest.approx(4.0)
    assert merged.std[0, 0] == pytest.approx(np.std([1.0, 4.0, 7.0]))
    assert merged.max[0, 0] == 7.0 and merged.n_frames == 3


def _psf_camera():
    camera = rs.Camera.preset("nist-ir-psf")
    return camera.replace(fpa=dataclasses.replace(camera.fpa, shape=None))


def _fields(m):
    return {name: getattr(m, name) for name in ("counts", "apparent_temperature", "electrons",
                                                "tensor_mean", "tensor_std", "tensor_max",
                                                "signal_mean")}


def test_two_workers_measure_a_scene_to_the_bit(tmp_path):
    """nist-ir-psf (its image formed per sub-band) and a linear ideal camera, the window in
    three parts: on two single-thread workers (a Client, then the scheduler's address) the
    measurement is the one this process makes, to the bit."""
    from distributed import Client, LocalCluster

    scene = FrameStack(stack(24, 30), dt=1e-6, dx=2e-6)
    cameras = [(_psf_camera(), 6e-6), (rs.Camera.linear_ideal(4e-6), 0.0)]
    here = [camera.measure(scene, N_FRAMES * 1e-6, 0.0, rng=7) for camera, _ in cameras]
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        for (camera, _), local in zip(cameras, here):
            for scheduler in (client, cluster.scheduler_address):
                there = camera.measure(scene, N_FRAMES * 1e-6, 0.0, rng=7, scheduler=scheduler)
                for name, value in _fields(local).items():
                    np.testing.assert_array_equal(getattr(there, name), value, err_msg=name)


def test_one_of_two_workers_killed_mid_measurement_is_replaced_and_the_bits_hold():
    """Two single-thread workers; while the window's parts run, one worker's process dies
    (SIGKILL). Its nanny starts another, the scheduler gives its parts to the workers left,
    and the measurement is the one this process makes."""
    from distributed import Client, LocalCluster

    scene = FrameStack(stack(60, 60), dt=1e-6, dx=2e-6)
    camera = _psf_camera()
    local = camera.measure(scene, N_FRAMES * 1e-6, 0.0, rng=3)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        pids = client.run(os.getpid)  # each worker's process
        result = {}
        thread = threading.Thread(target=lambda: result.update(m=camera.measure(
            scene, N_FRAMES * 1e-6, 0.0, rng=3, scheduler=client)))
        thread.start()
        victim = None
        for _ in range(600):  # until a part runs on a worker
            busy = [w for w, tasks in client.processing().items() if tasks]
            if busy:
                victim = busy[0]
                break
            threading.Event().wait(0.01)
        assert victim is not None
        os.kill(pids[victim], signal.SIGKILL)
        thread.join(timeout=300)
        assert not thread.is_alive()
        client.wait_for_workers(2, timeout=120)  # the nanny's new worker
        assert pids[victim] not in client.run(os.getpid).values()
    for name, value in _fields(local).items():
        np.testing.assert_array_equal(getattr(result["m"], name), value, err_msg=name)


@pytest.mark.parametrize("stop", ["SIGSTOP", "SIGKILL"])
def test_a_scheduler_that_stops_answering_mid_measurement_never_answers_in_one_line(
        monkeypatch, tmp_path, stop):
    """A real ``dask scheduler`` and ``dask worker`` (processes of their own); the scheduler is
    stopped (SIGSTOP) or killed (SIGKILL) while the window's parts run: the measurement ends
    in one error line naming its address within about twice the scheduler timeout (2 s
    here), not never and not in a traceback."""
    import socket
    import subprocess
    import sys
    import time

    from radiosim import scheduling
    from radiosim.errors import RadiosimError

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, "cwd": tmp_path}
    scheduler = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler",
                                  "--host", "127.0.0.1", "--port", str(port),
                                  "--dashboard-address", ":0"], **quiet)
    worker = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address,
                               "--nthreads", "1", "--nworkers", "1", "--no-dashboard"],
                              **quiet)
    try:
        from distributed import Client

        with Client(address, timeout=60) as client:
            client.wait_for_workers(1, timeout=60)
        monkeypatch.setattr(scheduling, "SCHEDULER_TIMEOUT", 2.0)
        scene = FrameStack(stack(90, 90), dt=1e-6, dx=2e-6)
        errors = []

        def run():
            try:
                _psf_camera().measure(scene, N_FRAMES * 1e-6, 0.0, rng=1, scheduler=address)
            except RadiosimError as exc:
                errors.append((str(exc), time.monotonic()))

        thread = threading.Thread(target=run)
        thread.start()
        time.sleep(1.0)  # connected, the parts submitted
        scheduler.send_signal(getattr(signal, stop))
        stopped = time.monotonic()
        thread.join(timeout=30)
        assert not thread.is_alive()
        assert errors, "the measurement finished before the scheduler was stopped"
        text, when = errors[0]
        assert when - stopped < 2 * 2.0 + 4.0
        assert "\n" not in text and address in text
        assert ("did not answer" if stop == "SIGSTOP" else "scheduler") in text
    finally:
        scheduler.send_signal(signal.SIGCONT)
        for process in (worker, scheduler):
            process.terminate()
        for process in (worker, scheduler):
            try:
                process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                process.kill()


@pytest.mark.parametrize("response", ["planck", "linear", "maker-curve"])
def test_the_parts_merge_to_the_whole_windows_statistics_for_every_response(response):
    """The parts' statistics (the engine's for responses with a signal table, numpy's
    accumulator for the maker's curve, which has none) merged against the whole window
    integrated in one pass: the same to rounding."""
    from radiosim.acquisition import split_statistics, tensor_statistics

    # the maker's curve: exiftool's PlanckR1, R2, B, F, O of the FLIR test frame, at 10 µs
    curve = {"maker_curve": (17096.453, 0.046642166, 1428.0, 1.0, -6201.0),
             "maker_curve_time": 10e-6} if response == "maker-curve" else {}
    camera = rs.Camera.preset("nist-ir").replace(response=response, **curve)
    camera = camera.replace(fpa=dataclasses.replace(camera.fpa, shape=None, pixel_pitch=2e-6))
    scene = FrameStack(stack(8, 8, seed=4)[:, :8, :8], dt=1e-6, dx=1e-6)
    window = camera.window(scene, (N_FRAMES - 2) * 1e-6, 1.5e-6)
    exposure = camera.exposure(scene, window)
    whole = tensor_statistics(scene, [exposure])[0]
    split = split_statistics(scene, exposure)
    for name in ("mean", "std", "max", "signal_mean"):
        np.testing.assert_allclose(getattr(split, name), getattr(whole, name), rtol=1e-12,
                                   err_msg=name)
    assert split.n_frames == whole.n_frames

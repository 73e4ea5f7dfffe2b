"""Compiling in other processes: the wait before a launch, and stopping what still runs."""

import json
import os
import subprocess
import sys
import time

import numpy as np

from radiosim.kernels import background, compiling


def _sleeper(seconds: float) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-c", f"import time; time.sleep({seconds})"])


def _registered_sleeper(seconds: float, **flags) -> subprocess.Popen:
    """A stand-in compiling process, registered, with the attributes ``flags`` (with_bands,
    with_chip, aside: what it compiles)."""
    process = _sleeper(seconds)
    for name, value in flags.items():
        setattr(process, name, value)
    background.register(process)
    return process


def test_a_launch_waits_for_the_compiling_processes_to_end():
    processes = [_sleeper(0.3), _sleeper(0.1)]
    for process in processes:
        background.register(process)
    began = time.perf_counter()
    background.wait_for_background()
    # Both have ended (their exit codes are known) and none is waited for any more.
    assert all(p.poll() == 0 for p in processes)
    assert time.perf_counter() - began >= 0.1 and not background._RUNNING
    background.wait_for_background()  # none left: returns at once


def test_processes_still_running_at_exit_are_stopped():
    process = _sleeper(60)
    background.register(process)
    began = time.perf_counter()
    background.stop_all()  # what atexit and an interrupted command's exit run
    assert process.poll() is not None and process.returncode != 0
    assert time.perf_counter() - began < 10 and not background._RUNNING


def test_nothing_is_started_for_variants_the_cache_holds():
    # Compile float64's variants here (or load them), then ask for them in the background.
    compiling.warmup(frame_dtypes=("float64",), bands=True)
    assert not compiling.compile_pending(("float64",))
    assert compiling.compile_in_background(("float64",), bands=True) == []
    assert not background._RUNNING


def test_one_process_at_most_compiles_the_integrator_and_the_sub_band_kernel(monkeypatch):
    # One entry point serves both frame dtypes, and the sub-band kernel has one variant: two
    # processes compiling either would write one cache index at once. One process compiles
    # what the cache lacks (launching every asked dtype), and none when it holds both.
    pending = True
    fresh = []
    monkeypatch.setattr(compiling, "compile_pending", lambda d, **k: pending)
    monkeypatch.setattr(compiling, "_fresh_signatures", lambda d: list(fresh))
    both = ("float32", "float64")
    assert compiling._pending_work(both, True) == (both, True)
    assert compiling._pending_work(both, False) == (both, False)
    assert compiling._pending_work(("float64", np.float64), True) == (("float64",), True)
    pending = False  # the integrator cached: the sub-band kernel alone
    assert compiling._pending_work(both, True) == (both, True)
    assert compiling._pending_work(both, False) is None
    fresh = ["a signature"]  # both cached: nothing to start
    assert compiling._pending_work(both, True) is None
    assert compiling._pending_work((), True) is None


def test_both_frame_dtypes_launch_one_compiled_kernel():
    # float32 and float64 frames go through one entry point and one signature; a float32
    # frame gives the same bits as its float64 copy (the kernel widens each sample, exactly).
    from radiosim.kernels import SignalTable, accumulate, pixel_mean
    from radiosim.kernels.rows import ACCUMULATE_KERNELS, accumulate_kernel
    from radiosim.radiometry import BandRadianceTable

    assert set(ACCUMULATE_KERNELS) == {"float32", "float64"}
    assert all(k is accumulate_kernel for k in ACCUMULATE_KERNELS.values())
    rows, cols = compiling._tiny_axis(4), compiling._tiny_axis(6)
    table = SignalTable(BandRadianceTable(temperature_range=(200.0, 800.0), per_octave=16),
                        grey=0.9)
    rng = np.random.default_rng(11)
    frame = (300.0 + 400.0 * rng.random((rows.extent, cols.extent))).astype(np.float32)
    sums, signatures = {}, []
    for dtype in (np.float64, np.float32):
        block = frame.astype(dtype)
        shape = (rows.n_pixels, cols.n_pixels)
        reference = pixel_mean(block, rows, cols)
        dev, sq, signal, tmax = (np.zeros(shape), np.zeros(shape), np.zeros(shape),
                                 np.full(shape, -np.inf))
        accumulate(block, rows, cols, 0.5, reference, dev, sq, tmax, signal, table)
        sums[dtype] = np.stack([reference, dev, sq, signal, tmax])
        signatures.append(len(accumulate_kernel.signatures))
    assert sums[np.float32].tobytes() == sums[np.float64].tobytes()
    assert signatures[1] == signatures[0]  # float32 frames compiled nothing more


def test_float32_frames_take_the_sub_band_kernel_widened():
    # One compiled variant (float64 frames): float32 frames give the same sums as their
    # float64 copy (the widening is exact) and as the numpy reference, within its tolerance.
    from radiosim.kernels.bands import accumulate_bands, band_kernel
    from radiosim.kernels.reference import accumulate_bands_reference
    from radiosim.kernels.table import SignalTable
    from radiosim.radiometry import BandRadianceTable

    table = SignalTable(BandRadianceTable(temperature_range=(200.0, 800.0), per_octave=16),
                        grey=0.9)
    rng = np.random.default_rng(5)
    frames = (300.0 + 400.0 * rng.random((3, 7, 11))).astype(np.float32)
    weights = np.array([0.2, 0.5, 0.3])
    sums = {}
    for dtype in (np.float32, np.float64):
        out = np.zeros((2, 7, 11))
        status, rows = accumulate_bands(frames.astype(dtype), weights, [table, table], out)
        assert status == 0 and rows.size == 0
        sums[dtype] = out
    assert np.array_equal(sums[np.float32], sums[np.float64])
    reference = np.zeros((2, 7, 11))
    accumulate_bands_reference(frames, weights, [table, table], reference)
    np.testing.assert_allclose(sums[np.float32], reference, rtol=1e-12)
    assert len(band_kernel.signatures) == 1


def test_a_failing_compiling_process_leaves_the_work_to_this_one(monkeypatch):
    # The other process fails at once; the launch still runs (compiling here if it must).
    monkeypatch.setattr(compiling, "_pending_work",
                        lambda dtypes, bands: (("float64",), False))
    monkeypatch.setattr(compiling, "_CHILD", "import sys; sys.exit(3)")
    started = compiling.compile_in_background(("float64",))
    assert len(started) == 1
    report = compiling.warmup(frame_dtypes=("float64",), bands=False)  # waits, then launches
    assert started[0].returncode == 3 and report["variants"] == 10


def test_a_new_process_loads_the_cached_kernels_on_a_thread_without_compiling():
    compiling.warmup(frame_dtypes=("float64",), bands=False)  # cached (or loaded) here first
    code = ("from radiosim.kernels.compiling import load_in_background; "
            "from radiosim.kernels.rows import ACCUMULATE_KERNELS as K; d = K['float64']; "
            "t = load_in_background([d]); t.join(); "
            "print(len(d.signatures), sum(d.stats.cache_hits.values()), "
            "sum(d.stats.cache_misses.values()), load_in_background([d]))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    loaded, hits, misses, again = out.stdout.split()
    # Every cached variant loaded from the cache, none compiled; then nothing left to load.
    assert int(loaded) >= 1 and int(hits) == int(loaded) and misses == "0" and again == "None"


def test_an_interrupted_command_stops_the_compiling_processes(tmp_path):
    # An interrupted command ends without the interpreter's exit handlers
    # (radiosim.errors.exit_interrupted): its children are ended on the way out all the same.
    # Killed at once (a handler may run while the process is being waited for) and reaped,
    # its working folder removed.
    from radiosim import errors

    process, folder = _sleeper(60), tmp_path / "work"
    folder.mkdir()
    background.register(process, str(folder))
    began = time.perf_counter()
    errors._end_children()
    assert time.perf_counter() - began < 2 and not background._RUNNING
    assert not folder.exists()
    try:
        os.kill(process.pid, 0)
    except ProcessLookupError:
        pass  # ended and reaped
    else:
        raise AssertionError("the compiling process still runs")


def test_a_compiling_process_ends_with_the_process_that_started_it(tmp_path):
    # Its parent killed (no exit handler ran), the compiling process does not go on alone.
    # (The parent killed 1 s in: the compiling process may still be importing radiosim.)
    code = ("import os, subprocess, sys; p = subprocess.Popen([sys.executable, '-c', "
            "'import sys, time; from radiosim.kernels import compiling; "
            "compiling.warmup = lambda **k: time.sleep(60); "
            "sys.exit(compiling._main(sys.argv[1:]))', 'float64', '--parent', "
            "str(os.getpid())]); print(p.pid, flush=True); import time; time.sleep(60)")
    parent = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    child = int(parent.stdout.readline())
    time.sleep(1.0)
    parent.kill()
    parent.wait()
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        try:
            with open(f"/proc/{child}/stat") as stat:  # ended: gone, or a zombie not yet
                if stat.read().rsplit(")", 1)[1].split()[0] == "Z":  # reaped by its new parent
                    break
        except FileNotFoundError:
            break
        time.sleep(0.2)
    else:
        os.kill(child, 9)
        raise AssertionError("the compiling process outlived its parent by 10 s")


def test_a_launch_waits_for_the_threads_loading_kernels():
    # numba's typing is not thread-safe while another thread loads from the cache: a launch
    # (wait_for_background) and a scene's own kernels (wait_for_loaders) wait for the loader.
    import threading

    for wait in (background.wait_for_background, background.wait_for_loaders):
        done = []
        loader = threading.Thread(target=lambda: (time.sleep(0.3), done.append(1)))
        background.register_loader(loader)
        loader.start()
        wait()
        assert done == [1] and not background._LOADING


def test_the_sub_band_kernel_waits_for_a_process_compiling_it_and_for_no_other():
    # radiosim warmup compiles the sub-band kernel here without waiting for the processes
    # compiling the integrator, but waits for one that compiles the sub-band kernel too.
    compiling.warmup_bands()  # compiled (or loaded) here first: the launches below are quick
    other = _registered_sleeper(30, with_bands=False)
    try:
        compiling.warmup_bands(wait_for_processes=False)
        assert other.poll() is None and background._RUNNING  # not waited for
    finally:
        background.stop_all(at_once=True)
    compiler = _registered_sleeper(1.5, with_bands=True)
    compiling.warmup_bands(wait_for_processes=False)
    assert compiler.returncode == 0 and not background._RUNNING  # waited for


def test_the_compiling_process_launches_every_frame_dtype_when_given_none(monkeypatch):
    # radiosim warmup starts it with no dtype (before this process could import the list).
    asked = []
    monkeypatch.setattr(compiling, "warmup", lambda **k: asked.append(k) or {})
    parent = str(os.getppid())  # the watch ends the process unless its parent is this one's
    assert compiling._main(["--parent", parent]) == 0
    assert compiling._main(["float64", "--bands", "--parent", parent]) == 0
    assert asked[0]["frame_dtypes"] == ["float32", "float64"] and not asked[0]["bands"]
    assert asked[1]["frame_dtypes"] == ["float64"] and asked[1]["bands"]


def test_warmup_interrupted_while_importing_ends_its_compiling_process(tmp_path, monkeypatch):
    # radiosim warmup starts the compiling process before it imports the kernels: if the
    # import is interrupted (or fails), the process is ended and its folder removed.
    import argparse

    from radiosim import compiling_process, warmup

    folder = tmp_path / "work"
    folder.mkdir()
    process = _sleeper(60)
    monkeypatch.setattr(compiling_process, "start", lambda *a, **k: (process, str(folder)))
    monkeypatch.setitem(sys.modules, "radiosim.kernels.background", None)  # its import fails
    try:
        warmup.warmup_command(argparse.Namespace(quiet=True))
    except ImportError:
        pass
    else:
        raise AssertionError("the failed import was not raised")
    assert process.returncode is not None and not folder.exists()
    assert not background._RUNNING


def test_the_chip_waits_for_a_process_compiling_its_kernels_and_the_integrator_does_not():
    # radiosim run compiles the integrator's kernel here while another process compiles the
    # chip's: the integrator's launches do not wait for that process, the chip's frames do.
    from radiosim.scenes import SegmentedChip

    chip = SegmentedChip()
    region = tuple(slice(n // 2, n // 2 + 8) for n in chip.shape)
    chip.temperature(chip.event_time, region)  # compiled (or loaded) here first
    compiling.warmup(frame_dtypes=("float64",), bands=False)
    rows, cols = compiling._tiny_axis(2), compiling._tiny_axis(3)
    frame = np.full((rows.extent, cols.extent), 300.0)
    chip_compiler = _registered_sleeper(30, with_chip=True, aside=True)
    try:
        from radiosim.kernels import pixel_mean

        pixel_mean(frame, rows, cols)
        assert chip_compiler.poll() is None and background._RUNNING  # not waited for
    finally:
        background.stop_all(at_once=True)
    chip_compiler = _registered_sleeper(1.5, with_chip=True, aside=True)
    chip.temperature(chip.event_time + 1e-6, region)
    assert chip_compiler.returncode == 0 and not background._RUNNING  # waited for
    # A process compiling the integrator's last helpers only (radiosim measure, or a run
    # whose chip kernels are cached): neither the integrator's launches nor the chip's frames
    # wait for it.
    helpers = _registered_sleeper(30, aside=True, with_chip=False)
    try:
        pixel_mean(frame, rows, cols)
        chip.temperature(chip.event_time + 2e-6, region)
        assert helpers.poll() is None and background._RUNNING  # not waited for
    finally:
        background.stop_all(at_once=True)


def test_a_cold_run_on_the_chip_compiles_the_integrator_here_and_the_chip_aside(monkeypatch):
    # The integrator's kernel (the longer compile) here, at once; another process compiles
    # its last helpers ahead of it, then the chip's kernels (or loads them: it starts whenever
    # the integrator compiles); nothing when the integrator is cached.
    import radiosim.kernels as kernels
    from radiosim import compiling_process, warmup
    from radiosim.scenes import FrameStack, SegmentedChip

    pending = {"integrator": True, "chip": True}
    calls = []
    monkeypatch.setattr(kernels, "compile_pending", lambda dtypes=("float64",), also=(), **k:
                        pending["chip" if also else "integrator"])
    monkeypatch.setattr(kernels, "warmup", lambda **k: calls.append(("here", k)))
    monkeypatch.setattr(compiling_process, "start", lambda *a, **k: calls.append(
        ("aside", k.get("child"), k.get("helpers_only"))))
    chip = SegmentedChip()
    warmup.compile_for_run(chip)
    assert calls == [("aside", compiling_process.CHIP_CHILD, False),
                     ("here", {"frame_dtypes": ("float64",), "bands": False})]
    calls.clear()
    pending["chip"] = False  # cached: the other process compiles the helpers only
    warmup.compile_for_run(chip)
    assert [c[0] for c in calls] == ["aside", "here"] and calls[0][2] is True
    calls.clear()
    pending["integrator"] = False
    warmup.compile_for_run(chip)
    warmup.compile_for_run(FrameStack(np.full((2, 4, 4), 300.0), 1e-6, 1e-6))
    assert calls == []


def test_a_cold_measurement_has_another_process_compile_the_helpers_only(monkeypatch):
    # radiosim measure: another process compiles the integrator's last helpers (not the
    # chip's kernels) while this one checks the inputs and compiles at its first launch;
    # nothing when the integrator's kernel is cached. That process runs the helpers only.
    import radiosim.kernels as kernels
    from radiosim import compiling_process, warmup
    from radiosim.scenes import FrameStack

    pending = [True]
    started = []
    monkeypatch.setattr(kernels, "compile_pending", lambda *a, **k: pending[0])
    monkeypatch.setattr(compiling_process, "start", lambda *a, **k: started.append(k))
    stack = FrameStack(np.full((2, 4, 4), 300.0), 1e-6, 1e-6)
    warmup.compile_helpers_aside(stack)
    assert started == [{"child": compiling_process.CHIP_CHILD, "helpers_only": True}]
    pending[0] = False
    warmup.compile_helpers_aside(stack)
    assert len(started) == 1
    ran = []
    monkeypatch.setattr(compiling, "compile_helpers_ahead",
                        lambda count=None: ran.append("helpers"))
    monkeypatch.setattr(warmup, "warmup_chip", lambda: ran.append("chip"))
    assert warmup.chip_main(["--helpers-only", "--parent", str(os.getppid())]) == 0
    assert warmup.chip_main(["--parent", str(os.getppid())]) == 0
    assert ran == ["helpers", "helpers", "chip"]


def test_helpers_compiled_ahead_are_those_the_entry_point_loads(tmp_path):
    # One process compiles the integrator's last helpers ahead into an empty cache; another,
    # as the other process of radiosim warmup or run does, compiles the entry point. If a
    # helper's types differed from the entry point's call, or its cache were not found, the
    # second process would compile it again (numba's compile events) instead of loading it
    # (the dispatcher's cache hits).
    ahead = ("_commit_row", "_pixel_sums", "_pixel_sums_regular", "_pixel_done", "_signal_row",
             "_signal_one", "_cubic_rows")  # every AHEAD helper, by its Python function
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    first = subprocess.run(
        [sys.executable, "-c", "from radiosim.kernels import compiling; "
                               "compiling.compile_helpers_ahead()"],
        env=env, capture_output=True, text=True, timeout=600)
    assert first.returncode == 0, first.stderr[-2000:]
    script = (
        "import json\n"
        "from numba.core import event\n"
        "from radiosim.kernels import compiling, radiance\n"
        "seen = []\n"
        "class Listener(event.Listener):\n"
        "    def on_start(self, ev): seen.append(ev.data['dispatcher'].py_func.__name__)\n"
        "    def on_end(self, ev): pass\n"
        "event.register('numba:compile', Listener())\n"
        "compiling.warmup(frame_dtypes=('float64',), bands=False)\n"
        "loaded = [d for d, _ in compiling._helpers_ahead()] + [radiance._signal_one]\n"
        "print(json.dumps({'seen': seen, 'loaded': {d.py_func.__name__: [\n"
        "    len(d.signatures), sum(d.stats.cache_hits.values())] for d in loaded}}))\n")
    second = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True,
                            text=True, timeout=600)
    assert second.returncode == 0, second.stderr[-2000:]
    report = json.loads(second.stdout.splitlines()[-1])
    assert "accumulate_kernel" in report["seen"]  # the entry point compiled there
    assert not set(ahead) & set(report["seen"])  # ... and none of the helpers again
    assert report["loaded"] == {name: [1, 1] for name in ("_commit_row", "_pixel_sums",
                                                          "_pixel_sums_regular", "_signal_row",
                                                          "_signal_one")}

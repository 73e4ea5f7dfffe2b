"""Interrupting ``radiosim run`` (Ctrl-C, SIGTERM): exit 130, one line, no litter.

Each run is a real ``python -m radiosim.cli`` process on a study long enough to be interrupted
part way: the signal is sent as soon as the staging folder holds a finished EXR file (the run
then still has more than a hundred to write). Afterwards no temporary file (a FILE whose name
ends in ``.partial``) may be left anywhere, every EXR file left reads back whole, no folder is
left empty, and the destination folder exists only if the run completed. The staging FOLDER
``DIR.partial`` may remain as the clearly named partial result.
"""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from conftest import frames_study
from radiosim.io import read_exr

# 121 measurements (1 to 4 µs in steps of 25 ns) of a 120 × 120-sample frames scene with 1 µm
# pixels: each writes an EXR file of 14 400 pixels, so the EXR files appear over more than a
# second whether the measurements are made one by one or in one pass over the frames. If a run
# ends before its signal arrives, make this longer (more times, bigger frames); never skip.
LONG_STUDY = frames_study([1 + 0.025 * i for i in range(121)], 1.0, name="long",
                          camera="linear", sweep="integration-time")
FIRST_EXR_TIMEOUT = 120.0  # s: start-up and the first measurements (slow on a loaded machine)
SIGNALS = {"SIGINT": signal.SIGINT, "SIGTERM": signal.SIGTERM}


def _start(root: Path) -> subprocess.Popen:
    y, x = np.mgrid[0:120, 0:120]
    frame = 600.0 + 200.0 * np.sin(x / 9.0) * np.cos(y / 7.0)
    np.save(root / "frames.npy", np.stack([frame + 10.0 * k for k in range(8)]))
    (root / "long.toml").write_text(LONG_STUDY)
    return subprocess.Popen(
        [sys.executable, "-m", "radiosim.cli", "run", str(root / "long.toml"), "--out",
         str(root / "results"), "--no-figures", "--quiet"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=root,
        env=dict(os.environ, PYTHONUNBUFFERED="1"))


@pytest.fixture(scope="module")
def interrupted(tmp_path_factory):
    """Both runs, started together; each gets its signal the moment its first EXR file is
    complete. Returns signal name → dict(root, proc, signalled, stdout, stderr)."""
    runs = {}
    for name in SIGNALS:
        root = tmp_path_factory.mktemp(f"interrupt-{name}")
        runs[name] = {"root": root, "proc": _start(root), "signalled": False}
    try:
        deadline = time.monotonic() + FIRST_EXR_TIMEOUT
        waiting = dict(runs)
        while waiting and time.monotonic() < deadline:
            for name, run in list(waiting.items()):
                if run["proc"].poll() is not None:
                    del waiting[name]  # ended by itself: the test reports it
                elif any((run["root"] / "results.partial" / "exr").glob("*.exr")):
                    run["proc"].send_signal(SIGNALS[name])
                    run["signalled"] = True
                    del waiting[name]
            time.sleep(0.005)  # the poll's period, no delay: the handshake is the EXR file
        for run in runs.values():
            if run["proc"].poll() is None and not run["signalled"]:
                run["proc"].kill()  # no EXR file in time
            run["stdout"], run["stderr"] = run["proc"].communicate(timeout=120)
    finally:
        for run in runs.values():
            if run["proc"].poll() is None:
                run["proc"].kill()
                run["proc"].communicate()
    return runs


@pytest.mark.parametrize("name", list(SIGNALS))
def test_interrupted_run_exits_130_and_leaves_no_litter(interrupted, name):
    run = interrupted[name]
    root, proc = run["root"], run["proc"]
    err = run["stderr"].decode("utf-8", "replace")
    if not run["signalled"]:
        pytest.fail(f"the run was not interrupted: exit {proc.returncode} before any EXR file "
                    "appeared, or none within the time-out; if it completed, make the study "
                    f"longer.\nstderr:\n{err}")
    out = root / "results"
    staging = root / "results.partial"

    # Exit code and message: one line saying it was interrupted, at most one more naming the
    # partial folder; no traceback.
    assert proc.returncode == 130, (
        f"exit {proc.returncode} (0: the run completed before the signal arrived; make the "
        f"study longer)\nstderr:\n{err}")
    assert "Traceback" not in err, err
    lines = [line for line in err.splitlines() if line.strip()]
    interrupted_lines = [line for line in lines
                         if "interrupt" in line.replace(str(root), "<tmp>").lower()]
    assert len(interrupted_lines) == 1, err
    assert len(lines) <= 2, err
    for line in lines:
        if line not in interrupted_lines:
            assert staging.name in line, err

    # No temporary FILE named *.partial anywhere (the partial FOLDER may stay).
    stray = [p for p in root.rglob("*") if p.name.endswith(".partial") and not p.is_dir()]
    assert not stray, f"temporary files left behind: {stray}"

    # The destination exists only if the run completed: it did not.
    assert not out.exists(), f"{out} exists although the run was interrupted"

    # No empty folder anywhere.
    empty = [p for p in root.rglob("*") if p.is_dir() and not any(p.iterdir())]
    assert not empty, f"empty folders left behind: {empty}"

    # Every EXR file left reads back completely; the partial table names only files that exist.
    exr_files = sorted(root.rglob("*.exr"))
    for path in exr_files:
        m = read_exr(path)
        assert m.apparent_temperature.shape == m.tensor_max.shape == (120, 120)
        assert np.isfinite(m.apparent_temperature).all()
    if staging.exists():
        assert exr_files, f"{staging} was kept but holds no finished measurement"
        table = staging / "results.csv"
        if table.exists():
            rows = list(csv.DictReader(table.open(encoding="utf-8")))
            assert rows, f"{table} is empty"
            for row in rows:
                if row.get("exr"):
                    assert (staging / row["exr"]).is_file(), row["exr"]


def test_an_interrupt_raised_in_a_callback_from_c_is_sent_again_not_reported(capfd,
                                                                             monkeypatch):
    # A signal handled while C calls back into Python (llvmlite's object cache, as numba
    # compiles or loads a kernel): the handler's exception cannot unwind through C, and
    # Python would print "Exception ignored" and its traceback. The command's hook prints
    # nothing and sends the signal again, to be handled once back in Python.
    import ctypes
    import signal
    import threading
    import time

    from radiosim import cli_signals, interrupts

    got = []
    arrived = threading.Event()  # the handshake: set by the handler when the signal arrives

    def handler(signum, frame):
        got.append(signum)
        arrived.set()

    previous = signal.signal(signal.SIGUSR1, handler)
    monkeypatch.setattr(interrupts.command_state, "interrupted", True)
    monkeypatch.setattr(interrupts.command_state, "signum", signal.SIGUSR1)
    monkeypatch.setattr(sys, "unraisablehook", cli_signals.on_unraisable)

    raised = []

    @ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p)
    def compare(a, b):  # on_interrupt's raise, once, inside the callback
        if not raised:
            raised.append(1)
            raise KeyboardInterrupt
        return 0

    values = (ctypes.c_int * 3)(3, 1, 2)
    try:
        ctypes.CDLL(None).qsort(values, 3, ctypes.sizeof(ctypes.c_int), compare)
        # Sent again from a timer thread: wait for the handler to say it ran, generously for a
        # loaded machine. The wait is sliced: Python runs a handler in the main thread between
        # bytecodes, so a signal the kernel gives another thread is handled at the next slice.
        deadline = time.monotonic() + 30
        while not arrived.wait(0.05) and time.monotonic() < deadline:
            pass
        assert arrived.is_set(), "the signal was not sent again within 30 s"
    finally:
        signal.signal(signal.SIGUSR1, previous)
    assert got == [signal.SIGUSR1]
    assert capfd.readouterr().err == ""
    # Anything else is Python's own report.
    monkeypatch.setattr(interrupts.command_state, "interrupted", False)
    reported = []
    monkeypatch.setattr(sys, "__unraisablehook__", reported.append)
    cli_signals.on_unraisable(type("Unraisable", (), {"exc_value": KeyboardInterrupt()})())
    assert len(reported) == 1


@pytest.mark.parametrize("name, raised", [("Ctrl-C", KeyboardInterrupt),
                                          ("SIGTERM", "Interrupted")])
def test_an_interrupt_the_work_swallowed_is_raised_again_between_steps(tmp_path, monkeypatch,
                                                                       name, raised):
    # The command received a signal, but the exception it raised was swallowed where it
    # arrived (a library catching everything there): the work would go on until the cleanup's
    # 15 s limit ended the process in the middle of an EXR write (a .partial file left, seen
    # once in CI). The study's loop and the integrator's raise it again at their next step:
    # nothing is measured, nothing is written, no temporary file is left.
    from radiosim import errors, integrator, interrupts
    from radiosim.kernels import set_engine
    from radiosim.scenes import UniformBlackbody
    from radiosim.study import Study

    if raised == "Interrupted":
        raised = errors.Interrupted
    y, x = np.mgrid[0:40, 0:40]
    np.save(tmp_path / "frames.npy", np.stack([600.0 + x + y + k for k in range(8)]))
    (tmp_path / "small.toml").write_text(frames_study([1, 2, 3], 1.0))
    study = Study.from_toml(tmp_path / "small.toml")
    camera = next(iter(study.plan())).camera  # the study's linear ideal camera
    monkeypatch.setattr(interrupts.command_state, "active", True)  # the command's work
    monkeypatch.setattr(interrupts.command_state, "interrupted", False)
    interrupts.raise_if_interrupted()  # no signal: nothing
    monkeypatch.setattr(interrupts.command_state, "interrupted", True)
    monkeypatch.setattr(interrupts.command_state, "signal_name", name)
    # The study's own steps (the integrator's checks off).
    with monkeypatch.context() as only_the_study:
        only_the_study.setattr(integrator, "raise_if_interrupted", lambda: None)
        with pytest.raises(raised):
            study.run(tmp_path / "results")
    assert not (tmp_path / "results").exists()
    assert not [p for p in tmp_path.rglob("*") if p.name.endswith(".partial")
                and not p.is_dir()]
    assert not list(tmp_path.rglob("*.exr"))
    # The integrator's loops: blocks of a stored stack and frame by frame (compiled), and
    # the numpy engine's.
    uniform = UniformBlackbody(600.0, shape=(40, 40), dt=1e-6, dx=1e-6)
    for scene, engine in ((study.scene, "compiled"), (uniform, "compiled"),
                          (study.scene, "numpy")):
        set_engine(engine)
        try:
            with pytest.raises(raised):
                camera.measure(scene, 3e-6)
        finally:
            set_engine(None)
    # The image stage's pass over the frames (the frame sums an uncertainty budget reuses),
    # and each task of an engine's run (a Monte Carlo draw: before it samples anything).
    from radiosim import imaging, scheduling

    with pytest.raises(raised):
        imaging.sample_signals(study.scene, camera.window(study.scene, 3e-6),
                               [camera.response_model])
    run, close = scheduling.connect("synchronous")
    try:
        with pytest.raises(raised):
            scheduling.recording_run(run, {})(pytest.fail, [("a task ran",)])
    finally:
        close()
    monkeypatch.setattr(interrupts.command_state, "active", False)  # not the command's work: a
    camera.measure(study.scene, 3e-6)  # library caller's measurement is not interrupted
    assert imaging.sample_signals(study.scene, camera.window(study.scene, 3e-6),
                                  [camera.response_model]).shape[0] == 1


def test_the_writes_under_way_are_removed_if_the_cleanup_runs_out_of_time(tmp_path):
    # The cleanup's time limit ends the command without unwinding: the temporary files of
    # the atomic writes still open are removed first, so a write is complete or absent.
    script = f"""
import sys
from radiosim import cli_signals, files
with files.atomic_write({str(tmp_path / "a.txt")!r}) as handle:
    handle.write("half")
    handle.flush()
    with files.atomic_path({str(tmp_path / "b.exr")!r}) as temporary:
        temporary.write_text("half")
        assert len(files._OPEN_TEMPORARIES) == 2
        cli_signals._give_up(2)
"""
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 130, done.stderr
    assert "the cleanup did not finish within 15 s, ended" in done.stderr
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("closed", ["stdout", "stdout and stderr"])
def test_a_reader_that_leaves_does_not_end_the_run(tmp_path, closed):
    # `radiosim run | head -1` (and `2>&1 | head`): the reader closes the pipe before the
    # command's first line; the run still completes, its files committed, exit 0, no error.
    np.save(tmp_path / "frames.npy", np.full((6, 24, 24), 650.0))
    (tmp_path / "s.toml").write_text(frames_study([1, 2, 3], 4.0))
    read, write = os.pipe()
    os.close(read)  # the reader has gone before the command starts
    try:
        done = subprocess.run(
            [sys.executable, "-m", "radiosim.cli", "run", "s.toml", "--out", "out",
             "--no-figures"], stdout=write, cwd=tmp_path, timeout=300,
            stderr=write if closed == "stdout and stderr" else subprocess.PIPE)
    finally:
        os.close(write)
    assert done.returncode == 0, done.stderr
    if done.stderr is not None:  # the progress lines, and nothing else
        lines = done.stderr.decode().splitlines()
        assert lines and all(line.startswith("[") for line in lines), done.stderr
    with open(tmp_path / "out" / "results.csv", newline="") as table:
        assert len(list(csv.DictReader(table))) == 3
    assert sorted(p.name for p in tmp_path.iterdir()) == ["frames.npy", "out", "s.toml"]

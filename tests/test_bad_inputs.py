"""Bad inputs, through the Python API and the ``radiosim`` command.

Five classes of failure, one section each:

1. raw tracebacks (or raw library errors) instead of one clean line;
2. silent garbage: a wrong input accepted and turned into numbers;
3. data loss and litter: files overwritten, empty folders or temporary files left behind;
4. valid input refused;
5. misleading text.

Every command-line case checks the exit code (2 input, 1 runtime, 130 interrupt), exactly one
line on stderr naming the offending value or file, no traceback, and that nothing was written
or overwritten. Every Python API case checks for a :class:`RadiosimError` (never a raw numpy,
scipy, OSError, KeyError or TypeError) naming the offending value.

The 36 cases that exposed bugs when written are fixed; every case is a plain check.
"""

from __future__ import annotations

import csv
import io
import json
import os
import re
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from hypothesis.configuration import set_hypothesis_home_dir

import radiosim
from radiosim import Camera, FrameStack
from radiosim.cli import main
from radiosim.errors import RadiosimError, RadiosimWarning
from conftest import frames_study
from radiosim.io import read_exr, read_fea_nodes, read_frames
from radiosim.study import Study

OpenEXR = pytest.importorskip("OpenEXR")

# Hypothesis keeps its caches outside the repository, and no example database.
if not os.environ.get("HYPOTHESIS_STORAGE_DIRECTORY"):
    set_hypothesis_home_dir(Path(tempfile.gettempdir()) / "radiosim-tests-hypothesis")
BOUNDED = settings(max_examples=30, deadline=None, database=None,
                   suppress_health_check=[HealthCheck.too_slow])


# -- helpers ------------------------------------------------------------------------------------


def cli(argv, capture):
    """Run the command in-process; returns (exit code, stdout, stderr)."""
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:  # argparse errors exit from parse_args
        code = exc.code
    out, err = capture.readouterr()
    return code, out, err


_TEMPORARY = [tempfile.gettempdir()]  # and pytest's base folder (see _in_tmp)


def without_paths(text: str) -> str:
    """``text`` with the temporary paths replaced by ``<TMP>``: the tests' folder names hold
    words (``..._a_list_...``) that must not count as the message naming them."""
    for base in sorted(set(_TEMPORARY), key=len, reverse=True):
        text = re.sub(re.escape(base) + r"[^\s'\"]*", "<TMP>", text)
    return text


def names(text: str, name) -> bool:
    """Whether ``text`` names ``name``: a path or file name anywhere, a word outside the paths."""
    if isinstance(name, Path) or re.search(r"\.[A-Za-z]+$", str(name)):
        return str(name) in text
    return str(name) in without_paths(text)


def one_line(err: str, *expected) -> str:
    """The single ``radiosim: error:`` line of ``err``, which names every one of ``expected``;
    returned without its temporary paths."""
    assert "Traceback" not in err, err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, f"expected exactly one line on stderr, got {len(lines)}:\n{err}"
    line = lines[0]
    assert line.startswith("radiosim: error:"), line
    assert "internal error" not in line, line
    for name in expected:
        assert names(line, name), f"{name!r} is not named in: {line}"
    return without_paths(line)


def snapshot(root) -> dict:
    """Every file (bytes) and folder under ``root``."""
    root = Path(root)
    return {str(p.relative_to(root)): (None if p.is_dir() else p.read_bytes())
            for p in sorted(root.rglob("*"))}


def assert_unchanged(before: dict, root):
    after = snapshot(root)
    added = sorted(set(after) - set(before))
    removed = sorted(set(before) - set(after))
    changed = sorted(k for k in set(before) & set(after) if before[k] != after[k])
    assert not (added or removed or changed), (
        f"files changed: added {added}, removed {removed}, modified {changed}")


def api_error(exc_info, *expected) -> str:
    """The message of a RadiosimError, naming every one of ``expected``; returned without its
    temporary paths."""
    message = str(exc_info.value)
    assert isinstance(exc_info.value, RadiosimError), type(exc_info.value)
    for name in expected:
        assert names(message, name), f"{name!r} is not named in: {message}"
    return without_paths(message)


def write_frames_npy(path, shape=(20, 24, 24), value=500.0):
    np.save(path, np.full(shape, value))
    return Path(path)


VALID_STUDY = frames_study([2, 4], 3.0)


def write_study(folder, text=VALID_STUDY, name="study.toml", frames=None) -> Path:
    """A small, fast frames study (and its frames.npy) in ``folder``."""
    folder = Path(folder)
    if not (folder / "frames.npy").exists():
        np.save(folder / "frames.npy", np.full((20, 24, 24), 500.0) if frames is None else frames)
    (folder / name).write_text(text)
    return folder / name


def measure_args(scene, *extra):
    return ["measure", scene, "--camera", "linear-ideal", "--pixel-pitch", "3um", "--dx", "1um",
            "--dt", "1us", "--units", "K", "--integration-time", "2us", *extra]


FEA_UNITS = "# units: time=us, length=um, temperature=C\n"
FEA_HEADER = "time,x,y,temperature\n"


def fea_rows(steps=3, n=5, pitch=2.0):
    return [[t, x * pitch, y * pitch, 500.0 + x + y + t]
            for t in range(steps) for x in range(n) for y in range(n)]


def fea_text(rows, units=FEA_UNITS, header=FEA_HEADER) -> str:
    return units + header + "".join(",".join(f"{v:g}" for v in row) + "\n" for row in rows)


def exr_header(**attributes):
    return {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, **attributes}


def write_exr_frames(folder, n=3, shape=(12, 12), channel="temperature", **attributes):
    """EXR frames ``frame_0.exr`` … with the given header attributes."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    for k in range(n):
        pixels = np.full(shape, 500.0 + k, dtype=np.float32)
        OpenEXR.File(exr_header(**attributes), {channel: pixels}).write(
            str(folder / f"frame_{k}.exr"))
    return folder


def double(value):
    """A header value as radiosim stores doubles (see radiosim/io/exr.py ``_typed``)."""
    return np.array([value], dtype=np.float64)


def valid_npy_bytes() -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, np.full((4, 6, 6), 500.0))
    return buffer.getvalue()


def valid_exr_bytes() -> bytes:
    with tempfile.TemporaryDirectory() as folder:
        path = write_exr_frames(folder, n=1, dt_s=1e-6, dx_m=1e-6,
                                temperature_unit="K") / "frame_0.exr"
        return path.read_bytes()


def assert_linear_fea_field(scene):
    """``fea_rows``' field, T = 500 °C + x/2 + y/2 + t [µm, µs], is linear in x and y, so
    linear interpolation over the mesh reproduces it exactly at every pixel centre
    (x = j + ½, y = 7½ − i µm on the 1 µm grid of the 8 µm × 8 µm mesh, row 0 on top)."""
    assert scene.n_frames == 3 and scene.dt == pytest.approx(1e-6, rel=1e-12)
    i, j = np.mgrid[0:8, 0:8]
    for t in range(3):
        expected = 273.15 + 500.0 + t + ((j + 0.5) + (7.5 - i)) / 2
        np.testing.assert_allclose(scene.frame(t), expected, rtol=0, atol=1e-9)


def consume(scene, n=3):
    """Read the first frames of a scene (errors in the data surface only when read)."""
    for k in range(min(scene.n_frames or 1, n)):
        scene.frame(k)


def no_litter(root):
    """No temporary FILE named *.partial and no empty folder under ``root``."""
    root = Path(root)
    stray = [p for p in root.rglob("*") if p.name.endswith(".partial") and not p.is_dir()]
    assert not stray, f"temporary files left: {stray}"
    empty = [p for p in root.rglob("*") if p.is_dir() and not any(p.iterdir())]
    assert not empty, f"empty folders left: {empty}"


def is_root_proof_readonly(folder: Path) -> bool:
    """True if ``folder`` really cannot be written (root ignores permission bits)."""
    if os.access(folder, os.W_OK):
        return False
    try:
        (folder / ".probe").write_text("x")
    except OSError:
        return True
    (folder / ".probe").unlink()
    return False


@pytest.fixture
def readonly(tmp_path):
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o500)
    try:
        if not is_root_proof_readonly(folder):
            pytest.skip("permissions are not enforced for this user (root): a chmod 0o500 "
                        "folder is writable")
        yield folder
    finally:
        folder.chmod(0o700)


@pytest.fixture(autouse=True)
def _in_tmp(tmp_path, monkeypatch, tmp_path_factory):
    monkeypatch.chdir(tmp_path)  # default output names land in the test's folder
    base = str(tmp_path_factory.getbasetemp())
    if base not in _TEMPORARY:
        _TEMPORARY.append(base)


# -- the command as a real process (run concurrently, once) ----------------------------------------


SUBPROCESS_CASES = {
    # name: the arguments after "radiosim" ({study}, {root}, {afile}, {npz}: the case's files);
    # "dev-full" runs with its stdout on /dev/full (every write fails: ENOSPC)
    "out-is-file": ["run", "{study}", "--out", "{afile}", "--quiet", "--no-figures"],
    "progress": ["run", "{study}", "--out", "{root}/progress-out", "--no-figures"],
    "npz": ["measure", "{npz}", "--camera", "linear-ideal", "--pixel-pitch", "3um", "--dx", "1um",
            "--dt", "1us", "--units", "K", "--integration-time", "2us"],
    "dev-full": ["run", "{study}", "--out", "{root}/full-out", "--quiet", "--no-figures"],
    "bad-seed": ["run", "{study}", "--out", "{root}/seed-out", "--seed", "-1", "--quiet"],
}


@pytest.fixture(scope="module")
def processes(tmp_path_factory):
    """Each case of SUBPROCESS_CASES run by ``python -m radiosim.cli`` in its own folder, all at
    once; returns name → (exit code, stdout bytes, stderr bytes, folder, snapshot before)."""
    running = {}
    for name, argv in SUBPROCESS_CASES.items():
        root = tmp_path_factory.mktemp(name)
        study = write_study(root)
        (root / "afile").write_text("a user's file\n")
        np.savez_compressed(root / "c.npz", a=np.full((6, 12, 12), 500.0))
        args = [a.format(study=study, root=root, afile=root / "afile", npz=root / "c.npz")
                for a in argv]
        before = snapshot(root)
        stdout = subprocess.PIPE
        if name == "dev-full":
            if not os.path.exists("/dev/full"):
                running[name] = None
                continue
            stdout = open("/dev/full", "w")
        proc = subprocess.Popen([sys.executable, "-m", "radiosim.cli", *args], cwd=root,
                                stdout=stdout, stderr=subprocess.PIPE)
        running[name] = (proc, root, before, stdout)
    results = {}
    try:
        for name, item in running.items():
            if item is None:
                results[name] = None
                continue
            proc, root, before, stdout = item
            out, err = proc.communicate(timeout=120)
            results[name] = (proc.returncode, out or b"", err, root, before)
    finally:
        for item in running.values():
            if item is not None:
                proc, stdout = item[0], item[3]
                if proc.poll() is None:
                    proc.kill()
                    proc.communicate()
                if stdout is not subprocess.PIPE:
                    stdout.close()
    return results


# =================================================================================================
# 1. Raw tracebacks from the command line (and raw library errors from the Python API)
# =================================================================================================


@pytest.fixture
def unwritable():
    """A folder that even root cannot write in: /proc (nothing can be created there)."""
    folder = Path("/proc")
    if not (folder / "self").is_dir():
        pytest.skip("no /proc file system here")
    try:
        with open(folder / "radiosim-probe", "x"):
            pass
    except OSError:
        return folder
    (folder / "radiosim-probe").unlink()
    pytest.skip("/proc is writable here")


@pytest.fixture(params=["readonly", "unwritable"])
def blocked(request):
    """A folder nothing can be written in: a chmod 0o500 one (skipped as root, which writes
    anyway) or /proc (even root cannot)."""
    return request.getfixturevalue(request.param)


# A write the system refuses is a failure while running (exit 1), not an input mistake.


def test_cli_run_into_a_blocked_folder(tmp_path, blocked, capsys):
    study = write_study(tmp_path)
    before = snapshot(tmp_path)
    out = blocked / "radiosim-test-out"
    code, _, err = cli(["run", study, "--out", out, "--quiet", "--no-figures"], capsys)
    assert code == 1
    one_line(err, blocked)
    assert_unchanged(before, tmp_path)
    assert not out.exists()


def test_cli_readonly_folder_itself_as_out(tmp_path, readonly, capsys):
    study = write_study(tmp_path)
    before = snapshot(tmp_path)
    code, _, err = cli(["run", study, "--out", readonly, "--quiet", "--no-figures"], capsys)
    assert code in (1, 2)
    one_line(err, readonly)
    assert_unchanged(before, tmp_path)


@pytest.mark.parametrize("command, name", [
    (lambda npy, out: ["scene", "preview", "--out", out], "x.png"),
    (lambda npy, out: measure_args(npy, "--out", out), "m.exr"),
], ids=["preview", "measure"])
def test_cli_write_into_a_blocked_folder(tmp_path, blocked, capsys, command, name):
    npy = write_frames_npy(tmp_path / "s.npy")
    before = snapshot(tmp_path)
    code, _, err = cli(command(npy, blocked / name), capsys)
    assert code == 1
    one_line(err, blocked / name)
    assert_unchanged(before, tmp_path)


def test_cli_out_is_an_existing_file(tmp_path, capsys):
    study = write_study(tmp_path)
    afile = tmp_path / "afile"
    afile.write_text("a user's file\n")
    before = snapshot(tmp_path)
    code, _, err = cli(["run", study, "--out", afile, "--quiet", "--no-figures"], capsys)
    assert code == 2
    one_line(err, afile)
    assert_unchanged(before, tmp_path)


def test_cli_out_is_an_existing_file_real_process(processes):
    code, out, err, root, before = processes["out-is-file"]
    assert code == 2
    one_line(err.decode(), root / "afile")
    assert_unchanged(before, root)


@pytest.mark.parametrize("seed", ["-1", "-3", "1.5", "abc", "1e3"])
@pytest.mark.parametrize("command", ["run", "measure"])
def test_cli_bad_seed(tmp_path, capsys, command, seed):
    study = write_study(tmp_path)
    npy = write_frames_npy(tmp_path / "s.npy")
    before = snapshot(tmp_path)
    argv = (["run", study, "--out", tmp_path / "out", "--quiet"] if command == "run"
            else measure_args(npy, "--out", tmp_path / "m.exr"))
    code, _, err = cli([*argv, f"--seed={seed}"], capsys)
    assert code == 2
    one_line(err, seed, "--seed")
    assert_unchanged(before, tmp_path)


def test_cli_negative_seed_real_process(processes):
    code, out, err, root, before = processes["bad-seed"]
    assert code == 2
    one_line(err.decode(), "-1", "--seed")
    assert_unchanged(before, root)


@pytest.mark.parametrize("option, value, named", [
    ("--integration-time", "10", "10"),       # no unit
    ("--integration-time", "-1us", "-1us"),
    ("--integration-time", "0us", "0us"),
    ("--integration-time", "nanus", "nanus"),
    ("--dx", "0um", "0um"),
    ("--dt", "1 parsec", "1 parsec"),
    ("--pixel-pitch", "6", "6"),
    ("--fill", "-5K", "-5K"),
    ("--units", "F", "F"),
    ("--start", "-3us", "-3 µs"),              # named in the unit typed, not 3e-06 s
])
def test_cli_bad_option_value(tmp_path, capsys, option, value, named):
    npy = write_frames_npy(tmp_path / "s.npy")
    before = snapshot(tmp_path)
    code, _, err = cli([*measure_args(npy, "--out", tmp_path / "m.exr"), f"{option}={value}"],
                       capsys)
    assert code == 2
    one_line(err, named)
    assert_unchanged(before, tmp_path)


@pytest.mark.parametrize("content", [
    pytest.param(np.array([]), id="empty-1d"),
    pytest.param(np.zeros((0, 12, 12)), id="empty-3d"),
    pytest.param(None, id="zero-bytes"),
])
def test_cli_empty_npy(tmp_path, capsys, content):
    path = tmp_path / "empty.npy"
    if content is None:
        path.write_bytes(b"")
    else:
        np.save(path, content)
    before = snapshot(tmp_path)
    code, _, err = cli(measure_args(path, "--out", tmp_path / "m.exr"), capsys)
    assert code == 2
    one_line(err, path)
    assert_unchanged(before, tmp_path)


@pytest.mark.parametrize("key, text", [
    ("pixel_pitch_um", '"6"'),
    ("f_number", '"2.5"'),
    ("fill_factor", '"1"'),
    ("read_noise_e", '"0"'),
    ("assumed_emissivity", '"1"'),
    ("calibration_range_K", '["150", "3000"]'),
])
def test_cli_camera_toml_number_as_string(tmp_path, capsys, key, text):
    toml = Camera.linear_ideal(3e-6).to_toml()
    toml, n = re.subn(rf"(?m)^{key} = .*$", f"{key} = {text}", toml)
    assert n == 1
    camera = tmp_path / "camera.toml"
    camera.write_text(toml)
    npy = write_frames_npy(tmp_path / "s.npy")
    before = snapshot(tmp_path)
    argv = ["measure", npy, "--camera", camera, "--dx", "1um", "--dt", "1us", "--units", "K",
            "--integration-time", "2us", "--out", tmp_path / "m.exr"]
    code, _, err = cli(argv, capsys)
    assert code == 2
    one_line(err, key, camera)
    assert_unchanged(before, tmp_path)


@pytest.mark.parametrize("step", [0, 1])
def test_cli_fea_collinear_step_is_one_clean_line(tmp_path, capfd, step):
    rows = [r for r in fea_rows() if r[0] != step]
    rows += [[step, 2.0 * i, 2.0 * i, 500.0] for i in range(5)]  # on the diagonal: collinear
    rows.sort(key=lambda r: r[0])
    path = tmp_path / "nodes.csv"
    path.write_text(fea_text(rows))
    before = snapshot(tmp_path)
    argv = ["measure", path, "--camera", "linear-ideal", "--pixel-pitch", "3um", "--dx", "1um",
            "--integration-time", "3us", "--start", "0us", "--out", tmp_path / "m.exr"]
    code, out, err = cli(argv, capfd)  # capfd: qhull writes at the C level
    assert code == 2
    line = one_line(err, path.name, "collinear")
    assert "QH" not in line and "qhull" not in line.lower()
    assert "QH" not in out and "qhull" not in out.lower()
    assert_unchanged(before, tmp_path)


@pytest.mark.parametrize("step", [0, 2])
def test_api_fea_collinear_step_is_a_radiosim_error(tmp_path, capfd, step):
    rows = [r for r in fea_rows() if r[0] != step]
    rows += [[step, 2.0 * i, 0.0, 500.0] for i in range(5)]  # on one line y = 0
    rows.sort(key=lambda r: r[0])
    path = tmp_path / "nodes.csv"
    path.write_text(fea_text(rows))
    with pytest.raises(RadiosimError) as info:
        consume(read_fea_nodes(path, dx=1e-6))
    message = api_error(info, path.name, f"step {step}")
    assert "\n" not in message and "QH" not in message, message
    out, err = capfd.readouterr()
    assert "QH" not in out + err and "qhull" not in (out + err).lower()


@pytest.mark.parametrize("cut", [
    pytest.param(16, id="cut-16"),
    pytest.param(24, id="cut-24"),
    pytest.param(100, id="cut-100"),
])
def test_cli_truncated_exr_frame_is_one_clean_line(tmp_path, capfd, cut):
    folder = write_exr_frames(tmp_path / "frames", n=2, dt_s=1e-6, dx_m=1e-6,
                              temperature_unit="K")
    data = (folder / "frame_1.exr").read_bytes()
    (folder / "frame_1.exr").write_bytes(data[:-cut])  # cut inside the chunks
    before = snapshot(tmp_path)
    argv = ["measure", folder, "--camera", "linear-ideal", "--pixel-pitch", "3um",
            "--dx", "1um", "--dt", "1us", "--integration-time", "2us"]
    code, out, err = cli(argv, capfd)  # capfd: the OpenEXR library writes at the C level
    assert code == 2
    one_line(err, "frame_1.exr")
    assert out == "", f"the library wrote on stdout: {out!r}"
    assert_unchanged(before, tmp_path)


@pytest.mark.parametrize("old, new, name", [
    pytest.param('path = "frames.npy"\n', "", "path", id="scene-without-path"),
    pytest.param('path = "frames.npy"', "path = 5", "path", id="scene-path-number"),
    pytest.param("dt_us = 1.0", "dt_us = [1.0]", "dt_us", id="dt-list"),
    pytest.param('[cameras.lin]\npreset = "linear-ideal"\npixel_pitch_um = 3.0',
                 '[cameras]\nlin = "linear-ideal"', "lin", id="camera-not-a-table"),
    pytest.param('[[sweeps]]\nname = "t"\ncameras = ["lin"]\nintegration_time_us = [2, 4]',
                 '[sweeps]\nname = "t"', "sweeps", id="sweeps-not-a-list"),
])
def test_cli_malformed_study_is_one_clean_line(tmp_path, capsys, old, new, name):
    assert old in VALID_STUDY
    study = write_study(tmp_path, VALID_STUDY.replace(old, new))
    before = snapshot(tmp_path)
    code, _, err = cli(["run", study, "--out", tmp_path / "out", "--quiet", "--no-figures"],
                       capsys)
    assert code == 2
    one_line(err, name)
    assert_unchanged(before, tmp_path)


def _scene():
    return FrameStack(np.full((5, 12, 12), 500.0), dt=1e-6, dx=1e-6)


@pytest.mark.parametrize("rng", [
    pytest.param(-1),
    pytest.param(1.5),
    pytest.param("abc"),
])
def test_api_bad_seed(rng):
    with pytest.raises(RadiosimError) as info:
        Camera.linear_ideal(3e-6).measure(_scene(), 2e-6, rng=rng)
    api_error(info, repr(rng) if isinstance(rng, str) else rng)


@pytest.mark.parametrize("call, name", [
    pytest.param(lambda: Camera.linear_ideal(3e-6).measure(_scene(), 1e-6, t_start="1us"),
                 "'1us'", id="t_start-string"),
    pytest.param(lambda: FrameStack(np.full((5, 12, 12), 500.0), dt=1e-6, dx=1e-6,
                                    event_time="a"), "event_time", id="event_time-string"),
    pytest.param(lambda: read_fea_nodes(_fea_file(), dx=1e-6, fill="20C"), "fill",
                 id="fea-fill-string"),
    pytest.param(lambda: read_fea_nodes(_fea_file(), dx=1e-6, dt="1us"), "dt",
                 id="fea-dt-string"),
    pytest.param(lambda: Camera.linear_ideal("6"), "'6'", id="pixel_pitch-string"),
    pytest.param(lambda: Camera.linear_ideal(3e-6).measure(_scene(), "10us"), "'10us'",
                 id="integration_time-string"),
    pytest.param(lambda: FrameStack(np.full((5, 12, 12), 500.0), dt="0.2", dx=1e-6), "'0.2'",
                 id="dt-string"),
    pytest.param(lambda: read_frames("nope.npy", dt=1e-6, dx=1e-6, units="K"), "nope.npy",
                 id="missing-npy"),
    pytest.param(lambda: read_fea_nodes("nope.csv", dx=1e-6), "nope.csv", id="missing-csv"),
])
def test_api_bad_argument_is_a_radiosim_error(tmp_path, call, name):
    with pytest.raises(RadiosimError) as info:
        call()
    api_error(info, name)


def _fea_file() -> Path:
    path = Path("nodes.csv")  # in the test's folder (see _in_tmp)
    path.write_text(fea_text(fea_rows()))
    return path


# -- 1b. The importers under random input (hypothesis): a RadiosimError or a correct read,
#        never another exception -------------------------------------------------------------


def _read_npy_or_error(data: bytes):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "s.npy"
        path.write_bytes(data)
        try:
            consume(read_frames(path, dt=1e-6, dx=1e-6, units="K"))
        except RadiosimError:
            pass


def _read_csv_or_error(data: bytes):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "nodes.csv"
        path.write_bytes(data)
        try:
            consume(read_fea_nodes(path, dx=1e-6))
        except RadiosimError:
            pass


def _read_exr_or_error(data: bytes):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "frames" / "frame_0.exr"
        path.parent.mkdir()
        path.write_bytes(data)
        try:
            consume(read_frames(path.parent))
        except RadiosimError:
            pass
        try:
            read_exr(path)
        except RadiosimError:
            pass


@BOUNDED
@given(data=st.binary(max_size=512), magic=st.booleans())
def test_random_bytes_as_npy(data, magic):
    _read_npy_or_error((b"\x93NUMPY" if magic else b"") + data)


@BOUNDED
@given(data=st.binary(max_size=512))
@example(data=b"# units: time=us, length=um, temperature=\xb0C\ntime,x,y,temperature\n")
def test_random_bytes_as_csv(data):
    _read_csv_or_error(data)


@BOUNDED
@given(text=st.text(max_size=400))
def test_random_text_as_csv(text):
    _read_csv_or_error(text.encode("utf-8"))


@BOUNDED
@given(cells=st.lists(st.one_of(st.floats(allow_nan=True, allow_infinity=True),
                                st.text(max_size=6), st.integers(-10**30, 10**30)),
                      min_size=4, max_size=4),
       where=st.integers(0, 74))
def test_garbage_cells_in_a_valid_csv(cells, where):
    rows = [[f"{v:g}" for v in row] for row in fea_rows()]
    rows[where] = [str(c) for c in cells]
    text = FEA_UNITS + FEA_HEADER + "".join(",".join(row) + "\n" for row in rows)
    _read_csv_or_error(text.encode("utf-8"))


@BOUNDED
@given(data=st.binary(max_size=512))
def test_random_bytes_as_exr(data):
    _read_exr_or_error(data)


VALID_NPY = valid_npy_bytes()
VALID_CSV = fea_text(fea_rows()).encode()
VALID_EXR = valid_exr_bytes()


@BOUNDED
@given(cut=st.integers(0, len(VALID_NPY) - 1))
def test_truncated_npy(cut):
    _read_npy_or_error(VALID_NPY[:cut])


@BOUNDED
@given(cut=st.integers(0, len(VALID_CSV) - 1))
def test_truncated_csv(cut):
    _read_csv_or_error(VALID_CSV[:cut])


@BOUNDED
@given(cut=st.integers(0, len(VALID_EXR) - 1))
def test_truncated_exr(cut):
    _read_exr_or_error(VALID_EXR[:cut])


WRONG_DTYPES = ["complex64", "complex128", "object", "U5", "S5", "bool", "datetime64[s]"]


@BOUNDED
@given(dtype=st.sampled_from(WRONG_DTYPES),
       shape=st.tuples(st.integers(1, 4), st.integers(1, 6), st.integers(1, 6)))
def test_wrong_dtypes_in_npy_and_framestack(dtype, shape):
    values = np.ones(shape).astype(dtype) if dtype != "object" else np.full(shape, None)
    with pytest.raises(RadiosimError) as info:
        consume(FrameStack(values, dt=1e-6, dx=1e-6))
    message = without_paths(str(info.value))
    assert "object" in message.lower() or np.dtype(dtype).name in message \
        or str(np.dtype(dtype)) in message, message
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "s.npy"
        np.save(path, values, allow_pickle=True)
        with pytest.raises(RadiosimError) as info:
            consume(read_frames(path, dt=1e-6, dx=1e-6, units="K"))
        message = without_paths(str(info.value))
        assert "object" in message.lower() or np.dtype(dtype).name in message \
            or str(np.dtype(dtype)) in message, message


@pytest.mark.parametrize("column", ["time", "x", "y", "temperature"])
@pytest.mark.parametrize("how", ["column-removed", "values-removed"])
def test_fea_csv_with_a_column_removed(tmp_path, column, how):
    names = ["time", "x", "y", "temperature"]
    i = names.index(column)
    rows = [[f"{v:g}" for v in row] for row in fea_rows()]
    header = names if how == "values-removed" else names[:i] + names[i + 1:]
    body = [row[:i] + row[i + 1:] for row in rows]
    path = tmp_path / "nodes.csv"
    path.write_text(FEA_UNITS + ",".join(header) + "\n" + "".join(",".join(r) + "\n"
                                                                    for r in body))
    with pytest.raises(RadiosimError) as info:
        consume(read_fea_nodes(path, dx=1e-6))
    message = api_error(info, path.name)
    assert (column in message) if how == "column-removed" else ("field" in message), message


# =================================================================================================
# 2. Silent garbage
# =================================================================================================


def test_infinite_temperature_through_linear_camera():
    scene = radiosim.FrameStack(np.full((3, 12, 12), np.inf), dt=1e-6, dx=1e-6)
    with pytest.raises(RadiosimError) as info:
        Camera.linear_ideal(3e-6).measure(scene, 2e-6)
    api_error(info, "frame 0", "row 0", "column 0", "inf")


@pytest.mark.parametrize("value, word", [(np.inf, "inf"), (-np.inf, "inf"), (np.nan, "NaN"),
                                         (0.0, "0 K"), (-5.0, "-5 K")])
def test_bad_temperature_names_frame_row_column(value, word):
    stack = np.full((4, 12, 12), 500.0)
    stack[2, 7, 3] = value
    scene = FrameStack(stack, dt=1e-6, dx=1e-6)
    with pytest.raises(RadiosimError) as info:
        Camera.linear_ideal(3e-6).measure(scene, 4e-6)
    api_error(info, "frame 2", "row 7", "column 3", word)


def test_cli_infinite_temperature(tmp_path, capsys):
    stack = np.full((6, 12, 12), 500.0)
    stack[1, 4, 5] = np.inf
    np.save(tmp_path / "hot.npy", stack)
    before = snapshot(tmp_path)
    code, _, err = cli(measure_args(tmp_path / "hot.npy", "--out", tmp_path / "m.exr"), capsys)
    assert code == 2
    one_line(err, "frame 1", "row 4", "column 5", "inf")
    assert_unchanged(before, tmp_path)


def _conflicting_fea(tmp_path) -> Path:
    rows = fea_rows()
    rows.append([1, 2.0, 4.0, 999.0])  # the node (2, 4) at t = 1 µs already has 507 °C
    path = tmp_path / "conflict.csv"
    path.write_text(fea_text(rows))
    return path


def test_fea_conflicting_temperatures_for_one_node(tmp_path):
    path = _conflicting_fea(tmp_path)
    with pytest.raises(RadiosimError) as info:
        consume(read_fea_nodes(path, dx=1e-6))
    message = api_error(info, path.name)
    assert ("x = 2" in message and "y = 4" in message) or "line" in message, message


def test_cli_fea_conflicting_temperatures(tmp_path, capsys):
    path = _conflicting_fea(tmp_path)
    before = snapshot(tmp_path)
    argv = ["measure", path, "--camera", "linear-ideal", "--pixel-pitch", "3um", "--dx", "1um",
            "--integration-time", "2us", "--out", tmp_path / "m.exr"]
    code, _, err = cli(argv, capsys)
    assert code == 2
    one_line(err, path.name, "two temperatures")
    assert_unchanged(before, tmp_path)


def test_fea_identical_duplicate_node_is_merged(tmp_path):
    rows = fea_rows()
    rows.append(list(rows[30]))  # the same node, the same temperature: harmless
    path = tmp_path / "dup.csv"
    path.write_text(fea_text(rows))
    assert_linear_fea_field(read_fea_nodes(path, dx=1e-6))


STRING_NUMBERS = [
    pytest.param("dt_us = 1.0", 'dt_us = "0.2"', "dt_us", id="scene-dt_us"),
    pytest.param("dx_um = 1.0", 'dx_um = "1"', "dx_um", id="scene-dx_um"),
    pytest.param("dt_us = 1.0", "dt_us = true", "dt_us", id="scene-dt_us-bool"),
    pytest.param('units = "K"', 'units = "K"\nevent_time_us = "3"', "event_time_us",
                 id="scene-event_time_us"),
    pytest.param("pixel_pitch_um = 3.0", 'pixel_pitch_um = "3"', "pixel_pitch_um",
                 id="camera-pixel_pitch_um"),
    pytest.param("pixel_pitch_um = 3.0", 'pixel_pitch_um = 3.0\nassumed_emissivity = "0.9"',
                 "assumed_emissivity", id="camera-assumed_emissivity"),
    pytest.param("integration_time_us = [2, 4]", 'integration_time_us = ["2", "4"]',
                 "integration_time_us", id="sweep-integration_time_us"),
]


@pytest.mark.parametrize("old, new, key", STRING_NUMBERS)
def test_study_number_written_as_string_is_refused(tmp_path, old, new, key):
    study = write_study(tmp_path, VALID_STUDY.replace(old, new, 1))
    with pytest.raises(RadiosimError) as info:
        Study.from_toml(study).scene  # noqa: B018 (building the scene is the check)
    api_error(info, key)


def test_cli_study_dt_as_string(tmp_path, capsys):
    study = write_study(tmp_path, VALID_STUDY.replace("dt_us = 1.0", 'dt_us = "0.2"'))
    before = snapshot(tmp_path)
    code, _, err = cli(["run", study, "--out", tmp_path / "out", "--quiet", "--no-figures"],
                       capsys)
    assert code == 2
    one_line(err, "dt_us")
    assert_unchanged(before, tmp_path)


@pytest.mark.parametrize("fill, names", [
    pytest.param('"300"', ["fill_K", "'300'"], id="string"),
    pytest.param("0", ["fill", "0"], id="zero"),
    pytest.param("0.0", ["fill", "0"], id="zero-float"),
    pytest.param("-20", ["fill", "-20"], id="negative"),
])
def test_study_fea_bad_fill_is_refused(tmp_path, fill, names):
    (tmp_path / "nodes.csv").write_text(fea_text(fea_rows()))
    text = VALID_STUDY.replace(
        'type = "frames"\npath = "frames.npy"\ndt_us = 1.0\ndx_um = 1.0\nunits = "K"',
        f'type = "fea"\npath = "nodes.csv"\ndx_um = 1.0\nfill_K = {fill}')
    study = write_study(tmp_path, text)
    with pytest.raises(RadiosimError) as info:
        Study.from_toml(study).scene  # noqa: B018
    api_error(info, *names)


@pytest.mark.parametrize("dx, dt, t_int, word", [
    (0.667, 0.2e-6, 0.2e-6, "dx"),    # metres where µm were meant
    (0.667e-6, 0.2, 1e-6, "dt"),      # seconds where µs were meant
])
def test_unit_slip_is_named(dx, dt, t_int, word):
    scene = FrameStack(np.full((3, 30, 30), 500.0), dt=dt, dx=dx)
    with pytest.raises(RadiosimError) as info:
        Camera.linear_ideal(6e-6).measure(scene, t_int)
    message = api_error(info, word)
    assert "µ" in message and "as" in message  # "was dx given in µm as metres?"


def test_cli_unit_slip_is_named(tmp_path, capsys):
    npy = write_frames_npy(tmp_path / "s.npy", shape=(3, 30, 30))
    before = snapshot(tmp_path)
    argv = ["measure", npy, "--camera", "linear-ideal", "--pixel-pitch", "6um", "--dx", "0.667m",
            "--dt", "0.2us", "--units", "K", "--integration-time", "0.2us"]
    code, _, err = cli(argv, capsys)
    assert code == 2
    one_line(err, "0.667", "dx")
    assert_unchanged(before, tmp_path)


def _gradient(frames=3):
    """300 K to 2500 K across the columns: well inside nist-ir's 150-3000 K calibration."""
    row = np.linspace(300.0, 2500.0, 120)
    return np.broadcast_to(row, (frames, 120, 120)).copy()


def test_near_zero_integration_time_does_not_saturate():
    camera = Camera.preset("nist-ir")
    scene = FrameStack(_gradient(), dt=0.1e-6, dx=1e-6)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RadiosimWarning)  # coarse calibration: expected
        m = camera.measure(scene, 1e-9, rng=0)
    assert m.electrons.max() < 1e-3 * camera.electronics.full_well
    assert not m.saturated.any(), f"{int(m.saturated.sum())} pixels reported saturated"


def test_cli_near_zero_integration_time_does_not_saturate(tmp_path, capsys):
    np.save(tmp_path / "grad.npy", _gradient())
    argv = ["measure", tmp_path / "grad.npy", "--camera", "nist-ir", "--dx", "1um", "--dt",
            "0.1us", "--units", "K", "--integration-time", "1ns"]
    code, out, err = cli(argv, capsys)
    assert code == 0, err
    assert "Traceback" not in err
    assert "saturated 0.0 %" in out, out


def test_timedelta_stack_is_refused(tmp_path):
    values = np.full((3, 6, 6), 500, dtype="timedelta64[s]")
    with pytest.raises(RadiosimError) as info:
        consume(FrameStack(values, dt=1e-6, dx=1e-6))
    api_error(info, "timedelta64")
    np.save(tmp_path / "s.npy", values)
    with pytest.raises(RadiosimError) as info:
        consume(read_frames(tmp_path / "s.npy", dt=1e-6, dx=1e-6, units="K"))
    api_error(info, "timedelta64")


# =================================================================================================
# 3. Data loss and litter
# =================================================================================================


def _first_run(tmp_path, capsys, out):
    study = write_study(tmp_path)
    code, _, err = cli(["run", study, "--out", out, "--quiet", "--no-figures"], capsys)
    assert code == 0, err
    return study


@pytest.mark.parametrize("previous", ["user-files", "radiosim-run"])
def test_run_into_non_empty_folder_refuses_without_overwrite(tmp_path, capsys, previous):
    out = tmp_path / "out"
    if previous == "radiosim-run":
        study = _first_run(tmp_path, capsys, out)
    else:
        study = write_study(tmp_path)
        out.mkdir()
        (out / "thesis.tex").write_text("\\chapter{Results}\n")
        (out / "results.csv").write_text("my own table\n")
    before = snapshot(tmp_path)
    code, _, err = cli(["run", study, "--out", out, "--quiet", "--no-figures"], capsys)
    assert code == 2
    one_line(err, out, "--overwrite")
    assert_unchanged(before, tmp_path)
    assert not (tmp_path / "out.partial").exists()


def test_overwrite_replaces_radiosims_files_and_keeps_the_users(tmp_path, capsys):
    out = tmp_path / "out"
    study = _first_run(tmp_path, capsys, out)
    notes = out / "notes.txt"
    notes.write_text("the user's notes\n")
    os.utime(notes, ns=(1_000_000_000, 1_000_000_000))
    manifest = json.loads((out / "radiosim-manifest.json").read_text())
    ours = {name: (out / name).stat().st_ino for name in manifest["files"]}
    assert "results.csv" in ours and any(name.endswith(".exr") for name in ours)
    code, _, err = cli(["run", study, "--out", out, "--quiet", "--no-figures", "--overwrite"],
                       capsys)
    assert code == 0, err
    assert notes.read_text() == "the user's notes\n"
    assert notes.stat().st_mtime_ns == 1_000_000_000
    for name, inode in ours.items():
        assert (out / name).is_file()
        assert (out / name).stat().st_ino != inode, f"{name} was not replaced"
    assert not (tmp_path / "out.partial").exists()
    no_litter(tmp_path)


def test_overwrite_never_deletes_outside_the_folder(tmp_path, capsys):
    out = tmp_path / "runs" / "out"
    out.parent.mkdir()
    study = _first_run(tmp_path, capsys, out)
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n")
    manifest = out / "radiosim-manifest.json"
    data = json.loads(manifest.read_text())
    data["files"] += ["../../victim.txt"]
    manifest.write_text(json.dumps(data))
    code, _, err = cli(["run", study, "--out", out, "--quiet", "--no-figures", "--overwrite"],
                       capsys)
    assert victim.is_file() and victim.read_text() == "precious\n"


def _nan_late_study(tmp_path, frame=18):
    stack = np.full((20, 24, 24), 500.0)
    stack[frame, 5, 7] = np.nan
    return write_study(tmp_path, VALID_STUDY.replace("[2, 4]", "[2, 4, 19]"), frames=stack)


def test_run_failing_mid_way_leaves_only_a_named_partial_result(tmp_path, capsys):
    study = _nan_late_study(tmp_path)
    out = tmp_path / "out"
    code, _, err = cli(["run", study, "--out", out, "--quiet", "--no-figures"], capsys)
    assert code == 2
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.strip()]
    errors = [line for line in lines if line.startswith("radiosim: error:")]
    assert len(errors) == 1 and "frame 18" in errors[0] and "NaN" in errors[0], err
    partial = tmp_path / "out.partial"
    assert len(lines) <= 2
    for line in lines:
        assert line in errors or str(partial) in line, err
    assert not out.exists()
    no_litter(tmp_path)
    if partial.exists():
        rows = list(csv.DictReader((partial / "results.csv").open(encoding="utf-8")))
        assert [r["integration_time_us"] for r in rows] == ["2.0", "4.0"]
        for row in rows:
            read_exr(partial / row["exr"])


def test_run_failing_at_once_leaves_no_empty_folder(tmp_path, capsys):
    study = _nan_late_study(tmp_path, frame=0)
    out = tmp_path / "new" / "sub" / "out"
    code, _, err = cli(["run", study, "--out", out, "--quiet", "--no-figures"], capsys)
    assert code == 2
    one_line(err, "frame 0", "NaN")
    assert not (tmp_path / "new").exists()
    no_litter(tmp_path)


def test_run_whose_output_fails_leaves_no_empty_partial_folder(processes):
    result = processes["dev-full"]
    if result is None:
        pytest.skip("no /dev/full on this system")
    code, out, err, root, before = result
    assert code == 1, err.decode()
    one_line(err.decode())
    assert not (root / "full-out").exists()
    no_litter(root)


def test_run_refuses_when_an_earlier_partial_result_exists(tmp_path, capsys):
    study = write_study(tmp_path)
    partial = tmp_path / "out.partial"
    partial.mkdir()
    (partial / "results.csv").write_text("an earlier run's rows\n")
    before = snapshot(tmp_path)
    code, _, err = cli(["run", study, "--out", tmp_path / "out", "--quiet", "--no-figures"],
                       capsys)
    assert code == 2
    one_line(err, partial)
    assert_unchanged(before, tmp_path)


def test_preview_refuses_to_overwrite_without_flag(tmp_path, capsys):
    png = tmp_path / "x.png"
    png.write_bytes(b"\x89PNG the user's picture")
    before = snapshot(tmp_path)
    code, _, err = cli(["scene", "preview", "--out", png], capsys)
    assert code == 2
    one_line(err, png, "--overwrite")
    assert_unchanged(before, tmp_path)


@pytest.mark.parametrize("name", ["m.png", "m.txt", "m"])
def test_measure_refuses_an_out_that_is_not_exr(tmp_path, capsys, name):
    npy = write_frames_npy(tmp_path / "s.npy")
    before = snapshot(tmp_path)
    code, _, err = cli(measure_args(npy, "--out", tmp_path / name), capsys)
    assert code == 2
    one_line(err, tmp_path / name, ".exr")
    assert_unchanged(before, tmp_path)


def test_measure_refuses_to_overwrite_an_exr_without_flag(tmp_path, capsys):
    npy = write_frames_npy(tmp_path / "s.npy")
    existing = tmp_path / "m.exr"
    existing.write_bytes(b"the user's measurement")
    before = snapshot(tmp_path)
    code, _, err = cli(measure_args(npy, "--out", existing), capsys)
    assert code == 2
    one_line(err, existing, "--overwrite")
    assert_unchanged(before, tmp_path)


@pytest.mark.parametrize("frame", [
    pytest.param(0, id="fails-at-once"),
    pytest.param(18, id="fails-late"),
])
def test_study_run_api_failure_keeps_only_completed_rows(tmp_path, frame):
    study = Study.from_toml(_nan_late_study(tmp_path, frame))
    with pytest.raises(RadiosimError) as info:
        study.run(tmp_path / "res")
    api_error(info, f"frame {frame}", "NaN")
    table = tmp_path / "res" / "results.csv"
    if table.exists():  # the rows that completed, each with its EXR file
        rows = list(csv.DictReader(table.open(encoding="utf-8")))
        assert rows and all(r["integration_time_us"] in ("2.0", "4.0") for r in rows)
        for row in rows:
            read_exr(tmp_path / "res" / row["exr"])
    no_litter(tmp_path)


# =================================================================================================
# 4. Valid input refused
# =================================================================================================


@pytest.mark.parametrize("given", [
    pytest.param({}, id="both-doubles"),
    pytest.param({"dx": 0.5e-6}, id="dt_s-double"),
    pytest.param({"dt": 0.2e-6}, id="dx_m-double"),
])
def test_exr_frames_with_double_attributes_are_read(tmp_path, given):
    write_exr_frames(tmp_path / "folder", n=3, dt_s=double(0.2e-6), dx_m=double(0.5e-6),
                     temperature_unit="C")
    scene = read_frames(str(tmp_path / "folder" / "frame_*.exr"), **given)
    assert scene.dt == 0.2e-6 and scene.dx == 0.5e-6
    assert scene.n_frames == 3 and scene.shape == (12, 12)
    assert scene.frame(2)[0, 0] == pytest.approx(502.0 + 273.15)


def test_cli_exr_frames_with_double_attributes_are_measured(tmp_path, capsys):
    folder = write_exr_frames(tmp_path / "folder", n=3, dt_s=double(1e-6), dx_m=double(1e-6),
                              temperature_unit="K")
    code, out, err = cli(["measure", folder, "--camera", "linear-ideal", "--pixel-pitch",
                          "3um", "--integration-time", "2us"], capsys)
    assert code == 0, err
    assert "4 × 4 pixels" in out


def test_exr_frames_with_float_attributes_are_read(tmp_path):
    write_exr_frames(tmp_path / "folder", n=3, dt_s=1e-6, dx_m=1e-6, units="K")
    scene = read_frames(tmp_path / "folder")
    assert scene.dt == pytest.approx(1e-6) and scene.dx == pytest.approx(1e-6)
    consume(scene)


@pytest.mark.parametrize("channel", ["temperature", "T", "Y"])
def test_exr_frames_in_any_temperature_channel_are_read(tmp_path, channel):
    write_exr_frames(tmp_path / "folder", n=2, channel=channel, dt_s=1e-6, dx_m=1e-6,
                     temperature_unit="K")
    assert read_frames(tmp_path / "folder").frame(1)[0, 0] == 501.0


def test_exr_frames_are_ordered_by_the_numbers_in_their_names(tmp_path):
    write_exr_frames(tmp_path / "folder", n=11, dt_s=1e-6, dx_m=1e-6, temperature_unit="K")
    scene = read_frames(str(tmp_path / "folder" / "frame_*.exr"))
    assert [scene.frame(k)[0, 0] for k in (2, 9, 10)] == [502.0, 509.0, 510.0]


@pytest.mark.parametrize("missing, flag", [("dx_m", "--dx"), ("dt_s", "--dt")])
def test_exr_missing_grid_attribute_names_attribute_file_and_flag(tmp_path, missing, flag):
    attributes = {"dt_s": 1e-6, "dx_m": 1e-6, "temperature_unit": "K"}
    del attributes[missing]
    write_exr_frames(tmp_path / "folder", n=2, **attributes)
    with pytest.raises(RadiosimError) as info:
        read_frames(str(tmp_path / "folder" / "frame_*.exr"))
    api_error(info, missing, "frame_0.exr", flag)


def test_cli_exr_missing_dx_names_attribute_file_and_flag(tmp_path, capsys):
    folder = write_exr_frames(tmp_path / "folder", n=2, dt_s=double(1e-6), temperature_unit="K")
    before = snapshot(tmp_path)
    code, _, err = cli(["measure", folder, "--camera", "linear-ideal", "--pixel-pitch", "3um",
                        "--integration-time", "2us", "--out", tmp_path / "m.exr"], capsys)
    assert code == 2
    one_line(err, "dx_m", "frame_0.exr", "--dx")
    assert_unchanged(before, tmp_path)


def test_cli_exr_missing_unit_names_attribute_file_and_flag(tmp_path, capsys):
    folder = write_exr_frames(tmp_path / "folder", n=2, dt_s=1e-6, dx_m=1e-6)
    before = snapshot(tmp_path)
    code, _, err = cli(["measure", folder, "--camera", "linear-ideal", "--pixel-pitch", "3um",
                        "--integration-time", "2us"], capsys)
    assert code == 2
    one_line(err, "temperature_unit", "frame_0.exr", "--units")
    assert_unchanged(before, tmp_path)


def test_fea_csv_with_byte_order_mark_is_read(tmp_path):
    path = tmp_path / "excel.csv"
    path.write_text(fea_text(fea_rows()), encoding="utf-8-sig")
    assert_linear_fea_field(read_fea_nodes(path, dx=1e-6))


@pytest.mark.parametrize("variant", ["crlf", "reordered-extra-column", "spaced-capitals"])
def test_fea_csv_variants_are_read(tmp_path, variant):
    rows = fea_rows()
    if variant == "crlf":
        text = fea_text(rows).replace("\n", "\r\n")
    elif variant == "reordered-extra-column":
        text = FEA_UNITS + "node,temperature,y,x,time\n" + "".join(
            f"{i},{T:g},{y:g},{x:g},{t:g}\n" for i, (t, x, y, T) in enumerate(rows))
    else:
        text = fea_text(rows, header=" Time , X , Y , Temperature \n")
    path = tmp_path / "nodes.csv"
    path.write_bytes(text.encode())
    scene = read_fea_nodes(path, dx=1e-6)
    assert scene.n_frames == 3
    consume(scene)


@pytest.mark.parametrize("dtype", ["float32", "int16", "uint16", ">f8"])
def test_numeric_npy_dtypes_are_read(tmp_path, dtype):
    np.save(tmp_path / "s.npy", np.full((4, 6, 6), 500, dtype=dtype))
    assert read_frames(tmp_path / "s.npy", dt=1e-6, dx=1e-6, units="K").frame(3)[0, 0] == 500.0


@pytest.mark.parametrize("unit, kelvin", [("K", 500.0), ("kelvin", 500.0), ("C", 773.15),
                                          ("celsius", 773.15), ("°C", 773.15)])
def test_temperature_unit_spellings_are_read(tmp_path, unit, kelvin):
    np.save(tmp_path / "s.npy", np.full((4, 6, 6), 500.0))
    frame = read_frames(tmp_path / "s.npy", dt=1e-6, dx=1e-6, units=unit).frame(0)
    assert frame[0, 0] == pytest.approx(kelvin)


def test_cli_micro_sign_units_are_read(tmp_path, capsys):
    npy = write_frames_npy(tmp_path / "s.npy")
    code, out, err = cli(["measure", npy, "--camera", "linear-ideal", "--pixel-pitch", "3µm",
                          "--dx", "1µm", "--dt", "1µs", "--units", "K",
                          "--integration-time", "2µs"], capsys)
    assert code == 0, err
    assert "8 × 8 pixels" in out


# =================================================================================================
# 5. Misleading text
# =================================================================================================


def test_text_file_named_npy_is_not_called_pickled(tmp_path, capsys):
    path = tmp_path / "notes.npy"
    path.write_text("time,temperature\n0,500\n")
    with pytest.raises(RadiosimError) as info:
        read_frames(path, dt=1e-6, dx=1e-6, units="K")
    message = api_error(info, path.name)
    assert "pickle" not in message.lower()
    assert "not a NumPy" in message or "not a numpy" in message.lower()
    before = snapshot(tmp_path)
    code, _, err = cli(measure_args(path), capsys)
    assert code == 2
    line = one_line(err, path.name)
    assert "pickle" not in line.lower()
    assert_unchanged(before, tmp_path)


@pytest.mark.parametrize("t_start, word", [
    pytest.param(float("nan"), "NaN", id="nan"),
    pytest.param(float("inf"), "inf", id="inf"),
])
def test_non_finite_t_start_is_named_as_such(t_start, word):
    with pytest.raises(RadiosimError) as info:
        Camera.linear_ideal(3e-6).measure(_scene(), 1e-6, t_start=t_start)
    message = api_error(info)
    assert word.lower() in message.lower(), message
    assert "before the" not in message and "first frame" not in message, message


TYPOS = [
    pytest.param("integration_time_us =", "integration_time_uss =", "integration_time_uss",
                 id="sweep-integration_time_uss"),
    pytest.param("integration_time_us =", "integraton_time_us =", "integraton_time_us",
                 id="sweep-integraton_time_us"),
    pytest.param('cameras = ["lin"]', 'cameras = ["lin"]\npixel_pitch_umm = [3.0]',
                 "pixel_pitch_umm", id="sweep-pixel_pitch_umm"),
    pytest.param("dx_um =", "dx_umm =", "dx_umm", id="scene-dx_umm"),
    pytest.param('units = "K"', 'units = "K"\nevent_time_uss = 3.0', "event_time_uss",
                 id="scene-event_time_uss"),
    pytest.param('preset = "linear-ideal"', 'presett = "linear-ideal"', "presett",
                 id="camera-presett"),
    pytest.param("pixel_pitch_um = 3.0", "pixel_pich_um = 3.0", "pixel_pich_um",
                 id="camera-pixel_pich_um"),
    pytest.param("[cameras.lin]", "[camera.lin]", "camera", id="top-camera"),
    pytest.param("[[sweeps]]", "[[sweep]]", "sweep", id="top-sweep"),
    pytest.param('name = "small"', 'name = "small"\ndescriptoin = "x"', "descriptoin",
                 id="top-descriptoin"),
]


@pytest.mark.parametrize("old, new, typo", TYPOS)
def test_study_typo_names_the_likely_key(tmp_path, old, new, typo):
    study = write_study(tmp_path, VALID_STUDY.replace(old, new, 1))
    with pytest.raises(RadiosimError) as info:
        Study.from_toml(study).scene  # noqa: B018
    message = api_error(info, typo)
    assert "did you mean" in message, message


@pytest.mark.parametrize("old, new, key", [
    pytest.param('units = "K"\n', "", "units", id="scene-units"),
    pytest.param("dt_us = 1.0\n", "", "dt_us", id="scene-dt_us"),
    pytest.param('type = "frames"\n', "", "type", id="scene-type"),
    pytest.param('cameras = ["lin"]\n', "", "cameras", id="sweep-cameras"),
])
def test_study_missing_required_key_is_named(tmp_path, old, new, key):
    study = write_study(tmp_path, VALID_STUDY.replace(old, new, 1))
    with pytest.raises(RadiosimError) as info:
        Study.from_toml(study).scene  # noqa: B018
    api_error(info, key)


def test_cli_study_typo_names_the_likely_key(tmp_path, capsys):
    study = write_study(tmp_path, VALID_STUDY.replace("integration_time_us =",
                                                      "integration_time_uss ="))
    before = snapshot(tmp_path)
    code, _, err = cli(["run", study, "--out", tmp_path / "out", "--quiet"], capsys)
    assert code == 2
    one_line(err, "integration_time_uss", "did you mean")
    assert_unchanged(before, tmp_path)


@pytest.mark.parametrize("old, new, key", [
    pytest.param('cameras = ["lin"]', 'cameras = "lin"', "cameras", id="cameras-string"),
    pytest.param('cameras = ["lin"]', 'cameras = ["lin"]\nalignment = "centred"', "alignment",
                 id="alignment-string"),
    pytest.param('cameras = ["lin"]', 'cameras = ["lin"]\nresponse = "linear"', "response",
                 id="response-string"),
])
def test_study_scalar_where_a_list_is_expected_says_list(tmp_path, old, new, key):
    study = write_study(tmp_path, VALID_STUDY.replace(old, new, 1))
    with pytest.raises(RadiosimError) as info:
        Study.from_toml(study)
    message = api_error(info, key)
    assert "list" in message, message
    assert "['l', 'i', 'n']" not in message


def test_cli_fea_without_dx_names_the_flag(tmp_path, capsys):
    path = tmp_path / "nodes.csv"
    path.write_text(fea_text(fea_rows()))
    before = snapshot(tmp_path)
    code, _, err = cli(["measure", path, "--camera", "linear-ideal", "--pixel-pitch", "3um",
                        "--integration-time", "2us"], capsys)
    assert code == 2
    one_line(err, "--dx")
    assert_unchanged(before, tmp_path)


def test_progress_to_a_pipe_has_no_carriage_return(processes):
    code, out, err, root, before = processes["progress"]
    assert code == 0, err.decode()
    assert b"\r" not in err
    assert b"[2/2]" in err
    assert b"Traceback" not in err


def test_compressed_npz_warns_in_one_line(tmp_path):
    np.savez_compressed(tmp_path / "c.npz", a=np.full((6, 12, 12), 500.0))
    with pytest.warns(RadiosimWarning) as record:
        scene = read_frames(tmp_path / "c.npz", dt=1e-6, dx=1e-6, units="K")
    ours = [w for w in record if issubclass(w.category, RadiosimWarning)]
    assert len(ours) == 1
    message = str(ours[0].message)
    assert "\n" not in message and "c.npz" in message and "compressed" in message
    consume(scene)


def test_cli_compressed_npz_warning_is_one_line_without_source(processes):
    code, out, err, root, before = processes["npz"]
    text = err.decode()
    assert code == 0, text
    assert "Traceback" not in text
    lines = [line for line in text.splitlines() if line.strip()]
    warned = [line for line in lines if "compressed" in line]
    assert len(warned) == 1 and warned[0].startswith("radiosim: warning:"), text
    assert "c.npz" in warned[0]
    assert len(lines) == 1, text  # no source line ("warnings.warn(...)") after it
    assert "warnings.warn" not in text


def test_fea_coordinates_in_the_wrong_length_unit_are_named(tmp_path):
    # µm coordinates declared as metres: a grid of 10¹⁸ samples, refused before any allocation.
    rows = ["# units: time=us, length=m, temperature=C", "time,x,y,temperature"]
    rows += [f"{t},{x},{y},{500 + x / 10}" for t in (0, 1) for x in (0, 500, 960)
             for y in (0, 400, 742)]
    (tmp_path / "n.csv").write_text("\n".join(rows) + "\n")
    with pytest.raises(RadiosimError, match=r"length unit right \(µm data read as m\?\)"):
        read_fea_nodes(tmp_path / "n.csv", dx=0.5e-6)


def test_region_emissivity_map_is_refused_naming_the_region():
    from radiosim.scenes import SegmentedChip

    scene = SegmentedChip(dx=8e-6, dt=1e-6)
    with pytest.raises(RadiosimError, match="emissivity of region 'chip' must be a number or"):
        SegmentedChip(dx=8e-6, dt=1e-6, emissivity={"chip": np.full(scene.shape, 0.3)})


def test_overwrite_refuses_a_folder_radiosim_did_not_write(tmp_path, capsys):
    study = tmp_path / "s.toml"
    write_frames_npy(tmp_path / "frames.npy")
    study.write_text(VALID_STUDY)
    out = tmp_path / "theirs"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    before = snapshot(tmp_path)
    code, _, err = cli(["run", study, "--out", out, "--overwrite", "--quiet", "--no-figures"],
                       capsys)
    assert code == 2 and "did not write it" in err
    assert_unchanged(before, tmp_path)


def test_overwrite_refuses_a_manifest_that_lists_a_folder(tmp_path, capsys):
    study = tmp_path / "s.toml"
    write_frames_npy(tmp_path / "frames.npy")
    study.write_text(VALID_STUDY)
    out = tmp_path / "out"
    assert cli(["run", study, "--out", out, "--quiet", "--no-figures"], capsys)[0] == 0
    (out / "sub").mkdir()
    (out / "radiosim-manifest.json").write_text(json.dumps({"files": ["sub", "results.csv"]}))
    before = snapshot(tmp_path)
    code, _, err = cli(["run", study, "--out", out, "--overwrite", "--quiet", "--no-figures"],
                       capsys)
    assert code == 2 and "which is a folder" in err
    assert_unchanged(before, tmp_path)

"""Shared test helpers."""

import math
import os
import re
import subprocess
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, settings
from hypothesis.configuration import set_hypothesis_home_dir

from radiosim.errors import RadiosimError


def frames_study(times_us, pixel_pitch_um: float, name: str = "small", camera: str = "lin",
                 sweep: str = "t") -> str:
    """A study TOML on ``frames.npy`` (1 µs frames of 1 µm samples, kelvin) beside it: one
    linear-ideal camera, one integration-time sweep."""
    times = ", ".join(f"{t:g}" for t in times_us)
    return f"""name = "{name}"
[scene]
type = "frames"
path = "frames.npy"
dt_us = 1.0
dx_um = 1.0
units = "K"
[cameras.{camera}]
preset = "linear-ideal"
pixel_pitch_um = {float(pixel_pitch_um)!r}
[[sweeps]]
name = "{sweep}"
cameras = ["{camera}"]
integration_time_us = [{times}]
"""


# -- one-line errors -------------------------------------------------------------------------------


def single_line(message: str, *expected):
    """``message`` is one line (a trailing newline aside) and names every one of ``expected``."""
    assert "\n" not in message.strip(), message
    for item in expected:
        assert str(item) in message, (item, message)


def one_line_naming(info, *names):
    """The error is one line and names every one of ``names``."""
    text = str(info.value)
    assert "\n" not in text, text
    for name in names:
        assert str(name) in text, (name, text)
    return text


def one_line_message(info):
    """The error's message: one line, no traceback."""
    message = str(info.value)
    assert "\n" not in message and "Traceback" not in message
    return message


# -- studies and output folders --------------------------------------------------------------------


def frames_study_dict(folder: Path, sweeps=None, name="small", cameras=None, value=600.0,
                      shape=(6, 12, 12)) -> dict:
    """A study dict on ``frames.npy`` in ``folder`` (1 µs frames of 1 µm samples, kelvin)."""
    rng = np.random.default_rng(0)
    np.save(folder / "frames.npy", value + 50.0 * rng.random(shape))
    return {
        "name": name,
        "scene": {"type": "frames", "path": str(folder / "frames.npy"), "dt_us": 1.0,
                  "dx_um": 1.0, "units": "K"},
        "cameras": cameras or {"lin": {"preset": "linear-ideal", "pixel_pitch_um": 3.0}},
        "sweeps": sweeps or [{"name": "t", "cameras": ["lin"], "integration_time_us": [1, 2]}],
    }


#: A study file on ``frames.npy`` beside it, with a slot for a sweep's and the scene's lines.
STUDY_TEMPLATE = """name = "s"
[scene]
type = "frames"
path = "frames.npy"
dt_us = 1.0
dx_um = 1.0
units = "K"
{scene_extra}
[cameras.lin]
preset = "linear-ideal"
pixel_pitch_um = 3.0

[[sweeps]]
name = "a"
cameras = ["lin"]
{sweep}
"""


def tree(root: Path) -> dict:
    """Every file under ``root`` → its bytes."""
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file()}


@pytest.fixture
def small_disk(tmp_path):
    """A 64 KiB tmpfs (root only; skipped with the reason otherwise)."""
    folder = tmp_path / "disk"
    folder.mkdir()
    try:
        done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(folder)],
                              capture_output=True, timeout=20)
    except (OSError, subprocess.TimeoutExpired) as exc:
        pytest.skip(f"cannot mount a tmpfs: {exc}")
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs (needs root): {done.stderr.decode().strip()}")
    try:
        yield folder
    finally:
        subprocess.run(["umount", str(folder)], capture_output=True, timeout=20)


# -- bad inputs: errors that name the value, files that readers refuse -----------------------------

# Hypothesis keeps its caches outside the repository, and no example database.
if not os.environ.get("HYPOTHESIS_STORAGE_DIRECTORY"):
    set_hypothesis_home_dir(Path(tempfile.gettempdir()) / "radiosim-tests-hypothesis")
BOUNDED = settings(max_examples=30, deadline=None, database=None, derandomize=True,
                   suppress_health_check=[HealthCheck.too_slow])  # seeded: the same examples

_TEMPORARY = [tempfile.gettempdir()]  # and pytest's base folder (see in_tmp)


@pytest.fixture
def in_tmp(tmp_path, monkeypatch, tmp_path_factory):
    """Run in the test's folder (default output names land there); its base folder counts as
    a temporary path for :func:`without_paths`."""
    monkeypatch.chdir(tmp_path)
    base = str(tmp_path_factory.getbasetemp())
    if base not in _TEMPORARY:
        _TEMPORARY.append(base)


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


def api_error(exc_info, *expected) -> str:
    """The message of a RadiosimError, naming every one of ``expected``; returned without its
    temporary paths."""
    message = str(exc_info.value)
    assert isinstance(exc_info.value, RadiosimError), type(exc_info.value)
    for name in expected:
        assert names(message, name), f"{name!r} is not named in: {message}"
    return without_paths(message)


VALID_STUDY = frames_study([2, 4], 3.0)


def write_study(folder, text=VALID_STUDY, name="study.toml", frames=None) -> Path:
    """A small, fast frames study (and its frames.npy) in ``folder``."""
    folder = Path(folder)
    if not (folder / "frames.npy").exists():
        np.save(folder / "frames.npy", np.full((20, 24, 24), 500.0) if frames is None else frames)
    (folder / name).write_text(text)
    return folder / name


def nan_late_study(tmp_path, frame=18):
    """``write_study`` over 2, 4 and 19 µs of frames with one NaN sample in ``frame``."""
    stack = np.full((20, 24, 24), 500.0)
    stack[frame, 5, 7] = np.nan
    return write_study(tmp_path, VALID_STUDY.replace("[2, 4]", "[2, 4, 19]"), frames=stack)


FEA_UNITS = "# units: time=us, length=um, temperature=C\n"
FEA_HEADER = "time,x,y,temperature\n"


def fea_rows(steps=3, n=5, pitch=2.0):
    return [[t, x * pitch, y * pitch, 500.0 + x + y + t]
            for t in range(steps) for x in range(n) for y in range(n)]


def fea_text(rows, units=FEA_UNITS, header=FEA_HEADER) -> str:
    return units + header + "".join(",".join(f"{v:g}" for v in row) + "\n" for row in rows)


def conflicting_fea(tmp_path) -> Path:
    """``fea_rows`` with a second, different temperature for one node."""
    rows = fea_rows()
    rows.append([1, 2.0, 4.0, 999.0])  # the node (2, 4) at t = 1 µs already has 507 °C
    path = tmp_path / "conflict.csv"
    path.write_text(fea_text(rows))
    return path


def exr_header(**attributes):
    import OpenEXR

    return {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, **attributes}


def write_exr_frames(folder, n=3, shape=(12, 12), channel="temperature", **attributes):
    """EXR frames ``frame_0.exr`` … with the given header attributes."""
    import OpenEXR

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


def gradient_frames(frames=3):
    """300 K to 2500 K across the columns: well inside nist-ir's 150-3000 K calibration."""
    row = np.linspace(300.0, 2500.0, 120)
    return np.broadcast_to(row, (frames, 120, 120)).copy()


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


# -- the EMVA 1288 linear model of a camera, written out -------------------------------------------


def blank_and_sigma(camera, t_int):
    """(b [DN], σ_b [DN]) written out from the EMVA 1288 model."""
    el = camera.electronics
    dark = el.dark_current * t_int  # [e⁻]
    sigma = math.sqrt(el.gain**2 * (el.read_noise**2 + dark) + 1 / 12)
    return el.gain * dark + el.offset, sigma


def photo(camera, temperature, t_int):
    """Mean photo-electrons of a blackbody [e⁻], written out."""
    from radiosim.radiometry import band_radiance

    fpa, optics = camera.fpa, camera.optics
    etendue = fpa.fill_factor * fpa.detector_pitch**2 * math.pi * (
        optics.objective_na / (fpa.detector_pitch / fpa.pixel_pitch)) ** 2
    return float(band_radiance(temperature, optics.band, "photon", camera.responsivity)) \
        * etendue * t_int


def true_camera(nist):
    """nist-ir without temporal noise (the table is a mean of many frames), quantising."""
    return nist.replace(electronics=replace(nist.electronics, read_noise=0.0,
                                            shot_noise=False), fpa=replace(nist.fpa, shape=(2, 2)))


def counts_table(camera, temperatures, t_int):
    """The mean counts of each temperature, written out."""
    el = camera.electronics
    return np.array([el.gain * (photo(camera, t, t_int) + el.dark_current * t_int) + el.offset
                     for t in temperatures])


def write_file(tmp_path, text, name="table.csv", encoding="utf-8"):
    path = tmp_path / name
    path.write_text(text, encoding=encoding)
    return path


@pytest.fixture(autouse=True)
def _numpy_print_options_restored():
    """Every test leaves numpy's print options as it found them (importing colour-science
    switches them to ``legacy="1.13"``, and doctests that run after would print otherwise)."""
    import numpy as np

    options = np.get_printoptions()
    yield
    np.set_printoptions(**options)


#: Test files that start processes, clusters, notebooks or the docs' build: ``slow``.
SLOW_FILES = {"test_validation_notebooks.py", "test_docs.py", "test_snippets.py",
              "test_examples.py", "test_packaging.py", "test_startup.py", "test_interrupts.py"}
#: Words in the names of the other tests that start processes or clusters: ``slow`` too.
SLOW_WORDS = ("workers", "signals_during", "never_answers", "real_process", "closed_stdout",
              "mplbackend", "jit_disabled", "address_space", "no_other_process",
              "importing_and_launching", "many_columns", "damaged_kernel_cache")


def pytest_collection_modifyitems(items):
    """Mark ``slow`` what starts processes, clusters, notebooks or the docs' build, so that
    ``pytest -m "not slow"`` runs the physics core on its own."""
    for item in items:
        name = item.nodeid.split("::")[-1]
        if item.path.name in SLOW_FILES or any(word in name for word in SLOW_WORDS):
            item.add_marker(pytest.mark.slow)


"""
What a camera recorded: counts frames with their metadata, read by file type
(:data:`RECORDING_READERS`, :func:`read_recording`), and turned into temperatures by the
file's own calibration or by a radiosim camera's (:meth:`Recording.temperature`).

Formats
-------
-   FLIR ``.fff`` frames, ``.seq`` sequences and radiometric JPEGs
    (:mod:`radiosim.io.flir_files`): counts with the camera's Planck curve and object
    parameters.
-   FLIR ResearchIR / Altair ``.ptw`` (Cedip, FLIR Titanium, Jade, Silver): a main header
    (signature ``CED``, its size at byte 11, the frame header's size [bytes] at 15, a
    frame's size with and without its header [16-bit words] at 19 and 23, the number of
    frames at 27, the camera's name at 44, its housing temperatures [K] at 212, the columns
    and rows at 377 and 379, the acquisition period [s] at 403 and the integration time [s]
    at 407; little-endian, as the Altair reference guide DL002U lays it out), then per frame
    a header (its time of day at bytes 80–83 and 160) and rows × columns unsigned 16-bit
    counts, row by row. Read as a memory map: a recording of any length is never loaded
    whole. A PTW file holds no temperature calibration: :meth:`Recording.temperature` needs
    a camera.

-   16-bit TIFF stacks (``.tif``, ``.tiff``): a page a frame of counts, each page decoded
    when asked (:func:`read_tiff_stack`).

Every check names the file and the field: a truncated file, a foreign one, sizes that
contradict each other, a frame index out of range.
"""

from __future__ import annotations

import dataclasses
import math
import struct
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from radiosim.errors import RadiosimError

__all__ = ["Recording", "RECORDING_READERS", "read_recording", "read_ptw", "read_tiff_stack",
           "export_recording", "info_lines"]


@dataclass(frozen=True, eq=False)
class Recording:
    """
    A camera's recording.

    Attributes
    ----------
    path : pathlib.Path
        The file.
    counts : numpy.ndarray
        Raw counts [DN], (frames, rows, columns); memory-mapped where the format allows.
    frame_times : numpy.ndarray
        Each frame's time from the first [s].
    integration_time : float or None
        [s], as the file states it.
    housing_temperature : float or None
        The camera's housing (instrument) temperature [K], as the file states it.
    camera_name : str
        The camera's name as the file gives it.
    metadata : dict
        The file's fields, named as the file's documentation names them.
    curve : radiosim.flir.PlanckCurve or None
        The camera maker's own calibration curve, where the file holds one (FLIR files).
    """

    path: Path
    counts: np.ndarray
    frame_times: np.ndarray
    integration_time: float | None
    housing_temperature: float | None
    camera_name: str
    metadata: dict = field(default_factory=dict)
    curve: object = None

    @property
    def shape(self) -> tuple[int, int, int]:
        """(frames, rows, columns)."""
        return tuple(self.counts.shape)

    def frame_indices(self, frames=None) -> np.ndarray:
        """The indices of ``frames`` (an index, a slice or a sequence of indices; ``None``:
        all); an index out of range is refused naming the file and its number of frames."""
        n = self.counts.shape[0]
        if frames is None or isinstance(frames, slice):
            return np.arange(n)[slice(None) if frames is None else frames]
        index = np.atleast_1d(np.asarray(frames))
        if index.dtype.kind not in "iu" or index.size == 0 or index.ndim != 1:
            raise RadiosimError(f"{self.path}: frames must be whole frame indices, got "
                                f"{frames!r}")
        bad = (index < -n) | (index >= n)
        if bad.any():
            raise RadiosimError(f"{self.path}: frame {int(index[bad][0])} is out of range; "
                                f"the recording has {n} frames (0–{n - 1})")
        return np.where(index < 0, index + n, index)

    def frames(self, frames=None) -> np.ndarray:
        """The counts [DN] of ``frames`` (see :meth:`frame_indices`) as float64, (frames,
        rows, columns)."""
        if isinstance(frames, slice) or frames is None:
            return np.asarray(self.counts[frames if frames is not None else slice(None)],
                              dtype=float)
        return np.asarray(self.counts[self.frame_indices(frames)], dtype=float)

    def defect_pixels(self, frames=None, k: float = 6.0):
        """The defect pixels (hot, cold, dead, noisy) of ``frames`` by the EMVA 1288 rules
        (:func:`radiosim.defects.find_defect_pixels`, at ``k`` robust σ)."""
        from radiosim.defects import find_defect_pixels

        return find_defect_pixels(self.frames(frames), k)

    def temperature(self, camera=None, frames=None, integration_time: float | None = None,
                    **object_parameters) -> np.ndarray:
        """
        Temperatures [K] of ``frames`` (see :meth:`frames`), (frames, rows, columns).

        Without ``camera``: the file's own calibration (a FLIR file's Planck curve, through
        :func:`radiosim.flir.raw_to_temperature` with the file's object parameters, each
        overridable in SI: ``emissivity``, ``reflected_temperature`` [K],
        ``atmospheric_temperature`` [K], ``distance`` [m], ``relative_humidity`` (0–1),
        ``window_temperature`` [K], ``window_transmission``). A file without one (PTW) is
        refused in one line.

        With a radiosim ``camera``: that camera's calibration at the recording's integration
        time (or ``integration_time`` [s], for a file that states none) and housing
        temperature (its ``instrument_temperature``), NaN outside its calibration range. For a long recording pass ``frames`` in chunks: memory then holds
        a chunk, not the recording.
        """
        counts = self.frames(frames)
        if camera is None:
            if self.curve is None:
                raise RadiosimError(
                    f"{self.path}: the file holds no temperature calibration of its own (a "
                    f"{self.path.suffix} file stores counts); give a radiosim camera fitted to "
                    "this camera's calibration tables (camera=, or --camera)")
            from radiosim.flir import ObjectParameters, raw_to_temperature

            stated = self.metadata.get("object_parameters", {})
            unknown = sorted(set(object_parameters) - {f.name for f in
                                                       dataclasses.fields(ObjectParameters)})
            if unknown:
                raise RadiosimError(f"{self.path}: unknown object parameter {unknown[0]!r}")
            parameters = ObjectParameters(**(stated | object_parameters))
            return raw_to_temperature(counts, self.curve, parameters)
        if object_parameters:
            raise RadiosimError(f"{self.path}: object parameters "
                                f"({', '.join(sorted(object_parameters))}) apply to the file's "
                                "own calibration; a radiosim camera states its own")
        camera, t_int = self._camera_at_housing(camera, integration_time)
        return camera.calibration(t_int).temperature(counts)

    def _camera_at_housing(self, camera, integration_time):
        """``camera`` at the recording's housing temperature, and the integration time [s]
        its calibration is taken at (the file's, or ``integration_time`` agreeing with it)."""
        if not hasattr(camera, "calibration") or not hasattr(camera, "channel_cameras"):
            raise RadiosimError(f"{self.path}: camera must be a radiosim Camera, got "
                                f"{type(camera).__name__} {camera!r:.60}")
        if camera.channels is not None:
            raise RadiosimError(f"{self.path}: {camera.name} has {len(camera.channels)} "
                                "channels; a recording's counts are one band's: give the "
                                "channel's camera (camera.channel_cameras[k])")
        if integration_time is not None:
            from radiosim.checks import check_time

            integration_time = check_time(integration_time, "integration_time")
        t_int = integration_time if integration_time is not None else self.integration_time
        if t_int is None:
            raise RadiosimError(f"{self.path}: the file states no integration time; a "
                                "camera's calibration needs one (integration_time=)")
        # files store it as float32: agreement within its precision (1e-6 relative)
        if (integration_time is not None and self.integration_time is not None
                and abs(integration_time - self.integration_time) > 1e-6 * integration_time):
            raise RadiosimError(f"{self.path}: integration_time={integration_time:g} s "
                                f"contradicts the file's {self.integration_time:g} s")
        if self.housing_temperature is not None:
            camera = camera.replace(optics=dataclasses.replace(
                camera.optics, instrument_temperature=self.housing_temperature))
        return camera, t_int

    def measurement(self, camera, frame: int = 0, integration_time: float | None = None,
                    bad_pixels=None):
        """
        One recorded frame read through a radiosim ``camera`` as a
        :class:`~radiosim.measurement.Measurement`: its counts [DN], the charge [e⁻] they
        stand for (the camera's conversion inverted), the calibration's reading and flags
        (saturated at the converter's top code, under range at code 0 or below the detection
        limit), as :meth:`temperature` reads them. The scene's truth is unknown: the
        ``tensor_*`` fields and ``signal_mean`` are NaN. What
        :func:`radiosim.correction.correct` takes.

        ``bad_pixels`` (a boolean mask shaped like a frame, for instance
        ``recording.defect_pixels().any``) are replaced by the median of their good
        neighbours first, as cameras replace them.
        """
        from radiosim.electronics import Exposure
        from radiosim.measurement import Measurement

        index = int(self.frame_indices([frame])[0]) if not isinstance(frame, bool) else None
        if index is None:
            raise RadiosimError(f"{self.path}: frame must be a frame index, got {frame!r}")
        camera, t_int = self._camera_at_housing(camera, integration_time)
        counts = np.asarray(self.counts[index], dtype=float)  # [DN]
        if bad_pixels is not None:
            from radiosim.calibration import replace_bad_pixels

            bad = np.asarray(bad_pixels)
            if bad.dtype != bool or bad.shape != counts.shape:
                raise RadiosimError(f"{self.path}: bad_pixels must be a boolean mask of "
                                    f"{counts.shape[0]} × {counts.shape[1]} pixels, got "
                                    f"{bad.dtype} of shape {bad.shape}")
            counts = replace_bad_pixels(counts, bad)
        if camera.fpa.shape is not None and tuple(camera.fpa.shape) != counts.shape:
            raise RadiosimError(f"{self.path}: frames of {counts.shape[0]} × {counts.shape[1]} "
                                f"pixels, but {camera.name}'s array is {camera.fpa.shape[0]} "
                                f"× {camera.fpa.shape[1]}")
        el = camera.electronics
        electrons = el.photoelectrons(counts, t_int) + el.dark_current * t_int  # [e⁻]
        exposure = Exposure(electrons, counts, counts >= el.max_count, counts <= 0)
        reading = camera.calibration(t_int).read(exposure)
        unknown = np.full(counts.shape, np.nan)
        start = float(self.frame_times[index]) if len(self.frame_times) > index else 0.0
        return Measurement(reading.apparent_temperature, counts, electrons, reading.saturated,
                           reading.under_range, unknown, unknown, unknown, unknown,
                           camera.response_model.unit, camera, t_int, start, 1,
                           {"recording": str(self.path), "frame": index}, "given",
                           reading.over_range)


    def to_xarray(self, camera=None, frames=None, chunk: int = 16, **object_parameters):
        """
        The recording as a CF dataset: ``counts`` [DN] and ``temperature`` [K] (through
        :meth:`temperature`, when the file or ``camera`` calibrates it) on (time, y, x), the
        frame times [s] as the time coordinate, the file's provenance (path, SHA-256,
        camera, integration time, housing temperature) in the attributes. The arrays are
        Dask arrays of ``chunk`` frames: writing the dataset streams the recording through
        memory a chunk at a time.
        """
        import hashlib
        import uuid

        import dask.array as da
        import xarray as xr

        from radiosim._version import __version__

        if isinstance(chunk, bool) or not isinstance(chunk, (int, np.integer)) or chunk < 1:
            raise RadiosimError(f"{self.path}: chunk must be a whole number of frames ≥ 1, "
                                f"got {chunk!r}")
        index = self.frame_indices(frames)
        if index.size == 0:
            raise RadiosimError(f"{self.path}: frames {frames!r} select no frame of its "
                                f"{self.counts.shape[0]}")
        sizes = tuple(min(chunk, index.size - k) for k in range(0, index.size, chunk))
        blocks = (sizes, (self.counts.shape[1],), (self.counts.shape[2],))

        def frames_of(block_info):  # the recording's frames of one block, read when asked
            start, stop = block_info[None]["array-location"][0]
            return index[start:stop]

        # Each block reads its own frames from the file when it is computed: nothing here
        # holds more than a block of the recording. The arrays are named, not tokenised
        # (Dask would hash the whole memory-mapped recording to name them).
        token = uuid.uuid4().hex
        counts = da.map_blocks(lambda block_info=None: np.asarray(
            self.counts[frames_of(block_info)]), chunks=blocks, dtype=self.counts.dtype,
            meta=np.empty((0, 0, 0), self.counts.dtype), name=f"counts-{token}")
        dims = ("time", "y", "x")
        data = {"counts": (dims, counts, {"units": "1", "long_name": "raw counts [DN]"})}
        calibrated = camera is not None or self.curve is not None
        if calibrated:
            self.temperature(camera, index[:1], **object_parameters)  # checked before any work
            temperature = da.map_blocks(
                lambda block_info=None: self.temperature(camera, frames_of(block_info),
                                                         **object_parameters),
                chunks=blocks, dtype=np.float64, meta=np.empty((0, 0, 0)),
                name=f"temperature-{token}")
            data["temperature"] = (dims, temperature, {
                "units": "K", "standard_name": "surface_temperature",
                "long_name": "temperature through " + (
                    f"radiosim camera {camera.name}" if camera is not None
                    else "the file's own calibration")})
        digest = hashlib.sha256()
        with open(self.path, "rb") as handle:
            for block in iter(lambda: handle.read(1 << 20), b""):
                digest.update(block)
        attrs = {"Conventions": "CF-1.10", "title": f"recording {self.path.name}",
                 "source": f"{self.path} (sha256 {digest.hexdigest()})",
                 "history": f"read by radiosim {__version__}",
                 "camera_name": self.camera_name}
        if self.integration_time is not None:
            attrs["integration_time_s"] = self.integration_time
        if self.housing_temperature is not None:
            attrs["housing_temperature_K"] = self.housing_temperature
        coords = {"time": ("time", np.asarray(self.frame_times)[index],
                           {"units": "s", "long_name": "time from the first frame"})}
        return xr.Dataset(data, coords=coords, attrs=attrs)


def export_recording(recording: Recording, path, camera=None, frames=None,
                     **object_parameters) -> Path:
    """
    Write ``recording``'s temperatures (and counts) to ``path``, atomically: a CF NetCDF
    ``.nc`` (:meth:`Recording.to_xarray`, streamed a chunk of frames at a time) or an
    ``.exr`` of one frame (``frames`` one index, default 0: channels ``temperature`` [K]
    and ``counts``, the provenance in the header).
    """
    path = Path(path)
    dataset = recording.to_xarray(camera, frames if path.suffix.lower() != ".exr" else
                                  [0 if frames is None else frames], **object_parameters)
    if "temperature" not in dataset:
        recording.temperature(camera)  # says, in one line, that a camera is needed
    if path.suffix.lower() == ".nc":
        from radiosim.io.netcdf import write_netcdf

        return write_netcdf(path, dataset)
    if path.suffix.lower() == ".exr":
        from radiosim.io.exr import _typed, write_channels

        frame = dataset.isel(time=0).compute()
        header = {key: _typed(value) for key, value in dataset.attrs.items()}
        return write_channels(path, {"temperature": frame["temperature"].values,
                                     "counts": frame["counts"].values}, header)
    raise RadiosimError(f"{path}: radiosim exports recordings to .nc or .exr, not "
                        f"{path.suffix!r}")


def info_lines(recording: Recording) -> list[str]:
    """The recording's metadata as a table of lines (what ``radiosim recording info``
    prints): frames, size, times, and each field of the file as the file names it."""
    from radiosim.units import to_celsius

    n, rows, cols = recording.shape
    lines = [f"{recording.path.name}: {recording.camera_name}, {n} frame(s) of {cols} × {rows} "
             f"px, {recording.frame_times[-1]:.6g} s",
             "  integration time: " + (f"{recording.integration_time * 1e6:g} µs"
                                        if recording.integration_time else "not stated"),
             "  housing temperature: " + (
                 f"{recording.housing_temperature:.2f} K "
                 f"({to_celsius(recording.housing_temperature):.2f} °C)"
                 if recording.housing_temperature else "not stated"),
             "  calibration: " + ("the file's own (FLIR Planck curve)" if recording.curve
                                  else "none in the file: give a camera")]
    width = max((len(k) for k in recording.metadata), default=0)
    for key, value in recording.metadata.items():
        if isinstance(value, dict):
            value = ", ".join(f"{k} = {v:.6g}" for k, v in value.items())
        elif isinstance(value, float):
            value = f"{value:.6g}"
        lines.append(f"  {key:<{width}}  {value}")
    return lines


# -- FLIR ResearchIR / Altair .ptw ----------------------------------------------------------------

_PTW_MAIN = 381  # bytes of the main header this reader reads (it is larger: its size at 11)
_PTW_FRAME_HEADER = 236  # bytes of a frame header this reader reads


def _field(path, data: bytes, fmt: str, offset: int, name: str):
    try:
        return struct.unpack_from("<" + fmt, data, offset)[0]
    except struct.error:
        raise RadiosimError(f"{path}: truncated before the header field {name} (byte "
                            f"{offset})") from None


def _text(data: bytes, start: int, stop: int) -> str:
    return data[start:stop].split(b"\0")[0].decode("latin-1").strip()


def read_ptw(path) -> Recording:
    """
    A FLIR ResearchIR / Altair ``.ptw`` recording (module docstring), memory-mapped.

    Raises
    ------
    RadiosimError
        Naming the file and the field: not a PTW file, a header whose sizes contradict each
        other or the file's length, no frames, a compressed or lock-in recording.
    """
    path = Path(path)
    from radiosim.files import why_not_a_file

    why = why_not_a_file(path)
    if why is not None:
        raise RadiosimError(f"{path} {why} (expected a FLIR ResearchIR .ptw recording)")
    size = path.stat().st_size
    with open(path, "rb") as handle:
        head = handle.read(4096)
    if not head:
        raise RadiosimError(f"{path} is empty (0 bytes); expected a FLIR ResearchIR .ptw "
                            "recording")
    if head[:3] != b"CED":
        raise RadiosimError(f"{path} is not a FLIR ResearchIR / Altair .ptw file: it starts "
                            f"with {head[:5]!r}, not the signature b'CED'")
    if len(head) < _PTW_MAIN:
        raise RadiosimError(f"{path}: truncated in its main header ({len(head)} bytes; the "
                            f"fields read reach byte {_PTW_MAIN})")
    main = _field(path, head, "i", 11, "MainHeaderSize")
    frame_header = _field(path, head, "i", 15, "FrameHeaderSize")
    frame_and_header = _field(path, head, "i", 19, "SizeOfOneFrameAndHeader")
    n = _field(path, head, "i", 27, "NumberOfFieldInFile")
    cols = _field(path, head, "H", 377, "PixelsPerLine")
    rows = _field(path, head, "H", 379, "LinesPerField")
    if not (_PTW_MAIN <= main <= size):
        raise RadiosimError(f"{path}: header field MainHeaderSize is {main}; expected "
                            f"{_PTW_MAIN}–{size} (the file's length)")
    if frame_header < 0 or rows < 1 or cols < 1:
        raise RadiosimError(f"{path}: header fields FrameHeaderSize {frame_header}, "
                            f"LinesPerField {rows}, PixelsPerLine {cols}; expected ≥ 0, ≥ 1, "
                            "≥ 1")
    frame_size = frame_header + rows * cols * 2  # [bytes]
    words = _field(path, head, "i", 23, "SizeOfOneFrame")
    if words != rows * cols or frame_and_header * 2 != frame_size:  # sizes in 16-bit words
        raise RadiosimError(
            f"{path}: header fields SizeOfOneFrame {words} and SizeOfOneFrameAndHeader "
            f"{frame_and_header} (16-bit words) contradict a frame header of {frame_header} "
            f"bytes and {rows} × {cols} pixels ({rows * cols} and {frame_size // 2}; a "
            "compressed or lock-in recording is not read)")
    if n < 1:
        raise RadiosimError(f"{path}: header field NumberOfFieldInFile is {n}; the file holds "
                            "no frames")
    expected = main + n * frame_size
    if size < expected:
        raise RadiosimError(f"{path} is truncated: {n} frames of {frame_size} bytes after a "
                            f"{main}-byte header need {expected} bytes, the file has {size}")
    record = np.dtype([("header", f"V{frame_header}"), ("counts", "<u2", (rows, cols))])
    mapped = np.memmap(path, dtype=record, mode="r", offset=main, shape=(n,))
    counts = mapped["counts"]
    integration = _field(path, head, "f", 407, "CEDIPIntegrationTime")
    period = _field(path, head, "f", 403, "CEDIPAquisitionPeriod")
    housing = _field(path, head, "f", 212, "HousingTemperature1")
    frame_times = _frame_times(mapped, frame_header, period)
    metadata = {
        "Signature": _text(head, 0, 5), "Version": _text(head, 5, 10),
        "CameraName": _text(head, 44, 64), "LensName": _text(head, 64, 84),
        "FilterName": _text(head, 84, 104),
        "Emissivity": _field(path, head, "f", 141, "Emissivity"),
        "Ambiant": _field(path, head, "f", 145, "Ambiant"),
        "Distance": _field(path, head, "f", 149, "Distance"),
        "AtmosphereTemp": _field(path, head, "f", 184, "AtmosphereTemp"),
        "CutOnWavelength": _field(path, head, "f", 188, "CutOnWavelength"),
        "CutOffWavelength": _field(path, head, "f", 192, "CutOffWavelength"),
        "PixelSize": _field(path, head, "f", 196, "PixelSize"),
        "PixelPitch": _field(path, head, "f", 200, "PixelPitch"),
        "HousingTemperature1": housing,
        "HousingTemperature2": _field(path, head, "f", 216, "HousingTemperature2"),
        "CEDIPAquisitionPeriod": period, "CEDIPIntegrationTime": integration,
        "PixelsPerLine": cols, "LinesPerField": rows, "NumberOfFieldInFile": n,
    }
    return Recording(path, counts, frame_times,
                     float(integration) if math.isfinite(integration) and integration > 0
                     else None,
                     float(housing) if math.isfinite(housing) and housing > 0 else None,
                     metadata["CameraName"], metadata)


def _frame_times(mapped, frame_header: int, period: float) -> np.ndarray:
    """Each frame's time from the first [s]: from the frame headers' time of day (hour,
    minute, second, hundredths and thousandths) where they hold one, else n × the
    acquisition period (0 where neither is stated)."""
    n = mapped.shape[0]
    if frame_header >= 161 and n > 1:
        heads = mapped["header"]
        times = np.array([_time_of_day(bytes(heads[k])) for k in range(n)])
        if np.all(np.diff(times) > 0):
            return times - times[0]
    step = float(period) if math.isfinite(period) and period > 0 else 0.0
    return np.arange(n) * step


def _time_of_day(header: bytes) -> float:
    """A PTW frame header's time of day [s]: hour (81), minute (80), second (83), hundredths
    (82) and thousandths (160)."""
    return (header[81] * 3600.0 + header[80] * 60.0 + header[83]
            + (header[82] * 10 + header[160]) / 1000)


class _TiffPages:
    """The pages of a 16-bit TIFF stack as a read-only array (frames, rows, columns), each
    page decoded (by Pillow) only when indexed: a long stack is never loaded whole."""

    dtype = np.dtype(np.uint16)
    ndim = 3

    def __init__(self, path: Path, n: int, shape: tuple[int, int]):
        self.path, self.shape = path, (n, *shape)

    def _page(self, k: int) -> np.ndarray:
        from PIL import Image

        try:
            with Image.open(self.path) as image:
                image.seek(int(k))
                page = np.array(image)
        except (OSError, ValueError, TypeError, EOFError) as exc:  # Pillow on a damaged page
            raise RadiosimError(f"{self.path}: page {k} cannot be read "
                                f"({type(exc).__name__}: {exc})") from None
        if page.shape != self.shape[1:] or page.dtype.kind != "u" or page.itemsize != 2:
            raise RadiosimError(f"{self.path}: page {k} holds {page.shape} {page.dtype} "
                                f"samples; page 0 holds {self.shape[1:]} uint16")
        return page

    def __len__(self) -> int:
        return self.shape[0]

    def __getitem__(self, key):
        whole = np.arange(self.shape[0])
        index = whole[key] if isinstance(key, (slice, np.ndarray, list)) else \
            np.atleast_1d(whole[int(key)])  # a negative index counts from the end
        pages = np.stack([self._page(k) for k in index]) if index.size else \
            np.empty((0, *self.shape[1:]), np.uint16)
        return pages if isinstance(key, (slice, np.ndarray, list)) else pages[0]

    def __array__(self, dtype=None, copy=None):
        return np.asarray(self[:], dtype=dtype)


def read_tiff_stack(path) -> Recording:
    """
    A 16-bit radiometric TIFF stack: one page a frame of unsigned 16-bit counts (each page
    read when asked). It states no times, integration time or calibration: a radiosim camera
    gives the temperatures, and frame times are the page numbers unless the caller knows
    the rate.
    """
    from PIL import Image, UnidentifiedImageError

    path = Path(path)
    from radiosim.files import why_not_a_file

    why = why_not_a_file(path)
    if why is not None:
        raise RadiosimError(f"{path} {why} (expected a 16-bit TIFF stack)")
    try:
        with Image.open(path) as image:
            n, mode, (cols, rows) = getattr(image, "n_frames", 1), image.mode, image.size
    except (UnidentifiedImageError, OSError, ValueError, TypeError, EOFError) as exc:
        raise RadiosimError(f"{path} is not a readable TIFF ({type(exc).__name__}: "
                            f"{exc})") from None
    if mode not in ("I;16", "I;16B", "I;16L"):
        raise RadiosimError(f"{path}: its pages are {mode!r} images; a radiometric stack "
                            "holds 16-bit counts (mode I;16)")
    pages = _TiffPages(path, n, (rows, cols))
    return Recording(path, pages, np.arange(n, dtype=float), None, None, "",
                     {"pages": n, "mode": mode})


def _flir(reader: str) -> Callable[[Path], Recording]:
    """A reader of :mod:`radiosim.io.flir_files`, imported when first used."""
    def read(path) -> Recording:
        from radiosim.io import flir_files

        return getattr(flir_files, reader)(path)

    return read


#: The readers of recordings by file suffix (lower case).
RECORDING_READERS: dict[str, Callable[[Path], Recording]] = {
    ".ptw": read_ptw, ".fff": _flir("read_fff"), ".seq": _flir("read_seq"),
    ".jpg": _flir("read_flir_jpeg"), ".jpeg": _flir("read_flir_jpeg"),
    ".tif": read_tiff_stack, ".tiff": read_tiff_stack}


def read_recording(path) -> Recording:
    """
    Read a camera's recording by its suffix (:data:`RECORDING_READERS`).

    Examples
    --------
    >>> read_recording("frames.xyz")
    Traceback (most recent call last):
    ...
    radiosim.errors.RadiosimError: frames.xyz: no reader for '.xyz' recordings; radiosim reads .fff, .jpeg, .jpg, .ptw, .seq, .tif, .tiff
    """
    path = Path(path)
    reader = RECORDING_READERS.get(path.suffix.lower())
    if reader is None:
        raise RadiosimError(f"{path}: no reader for {path.suffix!r} recordings; radiosim reads "
                            + ", ".join(sorted(RECORDING_READERS)))
    return reader(path)

"""
FLIR's own files: ``.fff`` frames and ``.seq`` sequences of them, raw (uncompressed) counts with
the camera's calibration and the object parameters.

An FFF frame is a 64-byte header (``FFF\\0``, the creator, a version of 100 whose byte order is
the directory's, the directory's offset at byte 24 and its number of entries at 28) and a
directory of 32-byte records (type, subtype, version, index, offset, length). Two records are
read, each in its own byte order (its first 16-bit word is 2):

-   RawData (type 1): its width and height at bytes 2 and 4, the counts from byte 32, unsigned
    16-bit, row by row, or a PNG of them (decoded by Pillow, the samples byte-swapped as FLIR
    stores them);
-   CameraInfo (type 32): the object parameters (emissivity at byte 0x20, distance [m] 0x24,
    reflected, atmospheric and window temperatures [K] 0x28, 0x2c, 0x30, window transmission
    0x34, relative humidity 0x3c as a fraction), Planck R1, B, F at 0x58, 0x5c, 0x60, the
    atmosphere's α₁, α₂, β₁, β₂, X at 0x70–0x80, the camera's model at 0xd4, its serial number
    at 0x104, the field of view [°] at 0x1b4, Planck O (int32) and R2 at 0x308 and 0x30c,
    the date at 0x384 and the frame rate [Hz] at 0x464 — the offsets exiftool's FLIR tables
    give (Harvey, ``Image::ExifTool::FLIR``).

A ``.seq`` file is FFF frames one after another; frames of one size are memory-mapped as one
array (a sequence of any length is never loaded whole). A FLIR radiometric JPEG carries one FFF
frame in its APP1 segments (``FLIR\0`` and an index each), joined in order.
"""

from __future__ import annotations

import datetime
import struct
from pathlib import Path

import numpy as np

from radiosim.errors import RadiosimError
from radiosim.io.recordings import Recording

__all__ = ["read_fff", "read_seq", "read_flir_jpeg"]

_RAW, _CAMERA_INFO = 1, 32
_FLOATS = {  # CameraInfo: name → offset (float32)
    "Emissivity": 0x20, "ObjectDistance": 0x24, "ReflectedApparentTemperature": 0x28,
    "AtmosphericTemperature": 0x2C, "IRWindowTemperature": 0x30, "IRWindowTransmission": 0x34,
    "RelativeHumidity": 0x3C, "PlanckR1": 0x58, "PlanckB": 0x5C, "PlanckF": 0x60,
    "AtmosphericTransAlpha1": 0x70, "AtmosphericTransAlpha2": 0x74,
    "AtmosphericTransBeta1": 0x78, "AtmosphericTransBeta2": 0x7C, "AtmosphericTransX": 0x80,
    "CameraTemperatureRangeMax": 0x90, "CameraTemperatureRangeMin": 0x94,
    "FieldOfView": 0x1B4, "PlanckR2": 0x30C,
}
_TEXTS = {"CameraModel": (0xD4, 32), "CameraSerialNumber": (0x104, 16),
          "LensModel": (0x170, 32)}


def _frame(path, data, start: int) -> tuple[dict, int, int, tuple[int, int], str, int]:
    """One FFF frame at ``start`` of ``data``: (metadata, the counts' offset, the frame's
    length, (rows, cols), the counts' byte order, the frame's end); a field that lies past
    the data's end is named as a truncation."""
    try:
        return _frame_fields(path, data, start)
    except struct.error:
        raise RadiosimError(f"{path}" + (f" (frame at byte {start})" if start else "")
                            + ": truncated or damaged: a record's fields lie past the end of "
                            f"its {len(data)} bytes") from None


def _frame_fields(path, data, start: int):
    where = f"{path}" + (f" (frame at byte {start})" if start else "")
    if bytes(data[start:start + 4]) != b"FFF\0":
        raise RadiosimError(f"{where} is not a FLIR FFF frame: it starts with "
                            f"{bytes(data[start:start + 4])!r}, not b'FFF\\x00'")
    if len(data) < start + 64:
        raise RadiosimError(f"{where}: truncated in its 64-byte FFF header")
    for order in (">", "<"):
        if struct.unpack_from(order + "I", data, start + 20)[0] in (100, 101):
            break
    else:
        raise RadiosimError(f"{where}: FFF header field version is "
                            f"{struct.unpack_from('>I', data, start + 20)[0]}; expected 100")
    directory, entries = struct.unpack_from(order + "II", data, start + 24)
    if entries < 1 or start + directory + 32 * entries > len(data):
        raise RadiosimError(f"{where}: its record directory ({entries} entries at byte "
                            f"{directory}) lies outside the file's {len(data)} bytes")
    records, end = {}, start + directory + 32 * entries
    for i in range(entries):
        kind, _, _, _, offset, length = struct.unpack_from(order + "HHIIII", data,
                                                            start + directory + 32 * i)
        if kind in (_RAW, _CAMERA_INFO) and kind not in records:
            if start + offset + length > len(data):
                raise RadiosimError(f"{where} is truncated: its record of type {kind} runs to "
                                    f"byte {start + offset + length}, the file has {len(data)}")
            records[kind] = (start + offset, length)
        if kind:
            end = max(end, start + offset + length)
    if _RAW not in records:
        raise RadiosimError(f"{where}: no RawData record (type 1): the file holds no counts")
    if _CAMERA_INFO not in records:
        raise RadiosimError(f"{where}: no CameraInfo record (type 32): no calibration")
    raw, raw_length = records[_RAW]
    raw_order = "<" if struct.unpack_from("<H", data, raw)[0] == 2 else ">"
    cols, rows = struct.unpack_from(raw_order + "HH", data, raw + 2)
    if bytes(data[raw + 32:raw + 36]).startswith(b"\x89PNG"):
        raw_order = "png"  # compressed: decoded by _png_counts, not memory-mapped
    elif rows < 1 or cols < 1 or 32 + 2 * rows * cols > raw_length:
        raise RadiosimError(f"{where}: RawData fields width {cols} and height {rows} do not fit "
                            f"its {raw_length} bytes")
    info, info_length = records[_CAMERA_INFO]
    if info_length < 0x468:
        raise RadiosimError(f"{where}: its CameraInfo record has {info_length} bytes; the "
                            "fields read reach byte 0x468")
    order_info = "<" if struct.unpack_from("<H", data, info)[0] == 2 else ">"
    meta = {name: struct.unpack_from(order_info + "f", data, info + offset)[0]
            for name, offset in _FLOATS.items()}
    if meta["RelativeHumidity"] > 2:  # some cameras store a percentage (as exiftool reads it)
        meta["RelativeHumidity"] /= 100.0
    meta["PlanckO"] = struct.unpack_from(order_info + "i", data, info + 0x308)[0]
    for name, (offset, size) in _TEXTS.items():
        meta[name] = bytes(data[info + offset:info + offset + size]).split(b"\0")[0].decode(
            "latin-1").strip()
    seconds, ms, zone = struct.unpack_from(order_info + "IIh", data, info + 0x384)
    try:
        tz = datetime.timezone(datetime.timedelta(minutes=-zone))
        meta["DateTimeOriginal"] = (datetime.datetime.fromtimestamp(seconds, tz)
                                    + datetime.timedelta(milliseconds=ms)).isoformat()
    except (ValueError, OverflowError, OSError):  # a date the file garbled: not needed
        meta["DateTimeOriginal"] = None
    meta["FrameRate"] = struct.unpack_from(order_info + "H", data, info + 0x464)[0]
    meta["_raw_end"] = raw + raw_length
    return meta, raw + 32, end - start, (rows, cols), raw_order, end


def _png_counts(path, data, start: int, stop: int, shape) -> np.ndarray:
    """A RawData record's PNG-compressed counts: 16-bit samples that FLIR stores
    little-endian inside the PNG's big-endian container (exiftool's note), so swapped."""
    import io

    from PIL import Image

    try:
        with Image.open(io.BytesIO(bytes(data[start:stop]))) as image:
            image.load()
            counts = np.array(image)
    except Exception as exc:  # Pillow's own errors on a damaged stream: one line
        raise RadiosimError(f"{path}: its PNG-compressed counts cannot be decoded "
                            f"({type(exc).__name__}: {exc})") from None
    if counts.shape != tuple(shape) or counts.dtype.itemsize != 2:
        raise RadiosimError(f"{path}: its PNG holds {counts.shape} {counts.dtype} samples; "
                            f"the RawData record states {shape[0]} × {shape[1]} 16-bit")
    return counts.astype(np.uint16).byteswap()


def _recording(path, meta, counts, frame_times) -> Recording:
    from radiosim.flir import ObjectParameters, PlanckCurve

    try:
        curve = PlanckCurve(R1=meta["PlanckR1"], R2=meta["PlanckR2"], B=meta["PlanckB"],
                            F=meta["PlanckF"], O=float(meta["PlanckO"]))
        stated = dict(
            emissivity=meta["Emissivity"], distance=meta["ObjectDistance"],
            reflected_temperature=meta["ReflectedApparentTemperature"],
            atmospheric_temperature=meta["AtmosphericTemperature"],
            relative_humidity=meta["RelativeHumidity"],
            window_temperature=meta["IRWindowTemperature"],
            window_transmission=meta["IRWindowTransmission"],
            alpha1=meta["AtmosphericTransAlpha1"], alpha2=meta["AtmosphericTransAlpha2"],
            beta1=meta["AtmosphericTransBeta1"], beta2=meta["AtmosphericTransBeta2"],
            x=meta["AtmosphericTransX"])
        ObjectParameters(**stated)  # checked once, when read
    except RadiosimError as exc:
        raise RadiosimError(f"{path}: CameraInfo: {exc}") from None
    meta = {k: v for k, v in meta.items() if not k.startswith("_")} | {
        "object_parameters": stated}
    return Recording(Path(path), counts, frame_times, None, None, meta["CameraModel"], meta,
                     curve)


def read_fff(path) -> Recording:
    """A FLIR ``.fff`` frame (module docstring): one frame of raw counts, the file's Planck
    curve and object parameters. Errors name the file and the record or field."""
    path = Path(path)
    data = _bytes(path)
    return _one_frame(path, data)


def read_flir_jpeg(path) -> Recording:
    """
    A FLIR radiometric JPEG: the FFF frame its APP1 segments carry (each begins
    ``FLIR\0``, then its index; joined in order), read as :func:`read_fff` reads a frame
    (its counts PNG-compressed or raw). A JPEG without them (a plain picture) is refused.
    """
    path = Path(path)
    data = _bytes(path, "a FLIR radiometric JPEG")
    if data[:2] != b"\xff\xd8":
        raise RadiosimError(f"{path} is not a JPEG (it starts with {data[:4]!r})")
    chunks, pos, scan = {}, 2, False
    while pos + 4 <= len(data) and data[pos] == 0xFF:
        marker = data[pos + 1]
        if marker in (0xD9, 0xDA):  # end of image, start of scan: no metadata after
            scan = True
            break
        length = struct.unpack_from(">H", data, pos + 2)[0]
        if pos + 2 + length > len(data):
            break  # a segment cut short
        segment = data[pos + 4:pos + 2 + length]
        if marker == 0xE1 and segment[:5] == b"FLIR\0" and len(segment) > 8:
            chunks[segment[6]] = segment[8:]
        pos += 2 + length
    if not scan:
        raise RadiosimError(f"{path} is truncated or damaged: its header segments stop at byte "
                            f"{pos} of {len(data)}, before the image")
    if not chunks:
        raise RadiosimError(f"{path}: a JPEG without FLIR's APP1 segments: a picture, not a "
                            "radiometric FLIR file (saved by FLIR Tools or the camera?)")
    return _one_frame(path, b"".join(chunks[k] for k in sorted(chunks)))


def _one_frame(path, data: bytes) -> Recording:
    """The recording of the one FFF frame ``data`` holds (its counts raw or a PNG)."""
    meta, start, _, shape, order, _ = _frame(path, data, 0)
    if order == "png":
        counts = _png_counts(path, data, start, meta["_raw_end"], shape)
    else:
        counts = np.frombuffer(data, order + "u2", count=shape[0] * shape[1],
                               offset=start).reshape(shape)
    return _recording(path, meta, counts[None], np.zeros(1))


def read_seq(path) -> Recording:
    """A FLIR ``.seq`` sequence (module docstring), memory-mapped; its frames must share one
    size and layout, and their times follow from the frame rate."""
    path = Path(path)
    from radiosim.files import why_not_a_file

    why = why_not_a_file(path)
    if why is not None:
        raise RadiosimError(f"{path} {why} (expected a FLIR .seq sequence)")
    if not path.stat().st_size:
        raise RadiosimError(f"{path} is empty (0 bytes); expected a FLIR .seq sequence")
    data = np.memmap(path, dtype=np.uint8, mode="r")
    meta, start, length, shape, order, _ = _frame(path, data, 0)
    if order == "png":
        raise RadiosimError(f"{path}: its frames' counts are PNG-compressed; radiosim "
                            "memory-maps sequences of raw frames (export them raw)")
    n = len(data) // length
    for k in (1, n - 1):  # the second and the last frame have the first one's layout
        if k < n and _frame(path, data, k * length)[1:5] != (start + k * length, length, shape,
                                                              order):
            raise RadiosimError(f"{path}: frame {k} differs in size or layout from frame 0; "
                                "radiosim reads sequences of equal frames")
    if len(data) % length:
        raise RadiosimError(f"{path} is truncated: {len(data)} bytes are not a whole number "
                            f"of {length}-byte frames")
    record = np.dtype([("before", f"V{start}"), ("counts", order + "u2", shape),
                       ("after", f"V{length - start - 2 * shape[0] * shape[1]}")])
    counts = np.memmap(path, dtype=record, mode="r", shape=(n,))["counts"]
    rate = meta["FrameRate"]
    times = np.arange(n) / rate if rate else np.zeros(n)
    return _recording(path, meta, counts, times)


def _bytes(path: Path, what: str = "a FLIR .fff frame") -> bytes:
    from radiosim.files import why_not_a_file

    why = why_not_a_file(path)
    if why is not None:
        raise RadiosimError(f"{path} {why} (expected {what})")
    data = path.read_bytes()
    if not data:
        raise RadiosimError(f"{path} is empty (0 bytes); expected {what}")
    return data

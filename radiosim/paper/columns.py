"""
The paper's reference locations on the segmented-chip scene: Columns I, II, III and the band
pixel (MSEC2009-84319, Figures 4, 6–8).

One helper answers "which pixel column holds Column I" (:func:`column_index`), for every
figure, table and calibration target.
"""

from __future__ import annotations

import math

import numpy as np

from radiosim.errors import RadiosimError

__all__ = ["COLUMN_NAMES", "column_index", "band_pixel", "has_columns"]

#: The paper's reference columns, Column I nearest the free surface.
COLUMN_NAMES = ("I", "II", "III")


def has_columns(scene) -> bool:
    """True if ``scene`` knows the paper's reference columns (the segmented chip)."""
    return hasattr(scene, "column_x")


def column_index(scene, pixel_pitch: float, name: str = "I", origin_x: float = 0.0) -> int:
    """
    Index of the pixel column, of cells ``pixel_pitch`` [m] wide from ``origin_x`` [m], that
    contains the paper's Column ``name`` on ``scene``.

    Examples
    --------
    >>> from radiosim.scenes import SegmentedChip
    >>> column_index(SegmentedChip(dx=4e-6, dt=1e-6), 6e-6)
    37
    """
    if not has_columns(scene):
        raise RadiosimError(f"a {type(scene).__name__} has no reference columns (the segmented "
                            "chip has)")
    return math.floor((scene.column_x(name) - origin_x) / pixel_pitch)


def band_pixel(scene, pixel_pitch: float):
    """
    The scene cropped to the Column I pixel where the shear band peaks in the event frame
    (the paper's Figure 8 pixel); ``pixel_pitch`` [m] must be a whole number of samples.
    """
    if not has_columns(scene):
        raise RadiosimError("the band pixel needs a scene with reference columns (the "
                            "segmented chip)")
    pitch = pixel_pitch / scene.dx
    if abs(pitch - round(pitch)) > 1e-6:
        raise RadiosimError(f"the band pixel needs a pixel of a whole number of samples, got "
                            f"{pitch:.6g} samples")
    p = round(pitch)
    column = column_index(scene, pixel_pitch)
    rows = scene.shape[0] - scene.shape[0] % p
    cols = (column * p, column * p + p)
    event = scene.frame(int(scene.event_time / scene.dt), (slice(0, rows), slice(*cols)))
    means = event.reshape(-1, p, p).mean(axis=(1, 2))
    row = int(np.argmax(means))
    return scene.crop((row * p, row * p + p), cols)

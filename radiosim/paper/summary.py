"""
The paper's summary columns of a study: the shear band's reading in Column I.

:func:`column_summary` is the study hook (``summary = "radiosim.paper:column_summary"`` in a
study file) that adds, for a scene with reference columns, the scene's Column I peak and the
highest valid reading in that pixel column, its bias (reading − scene, negative when the camera
reads low) and its ±1σ tensor standard deviation.
"""

from __future__ import annotations

import numpy as np

from radiosim.measurement import Measurement
from radiosim.paper.columns import column_index, has_columns
from radiosim.units import to_celsius

__all__ = ["COLUMN_I_COLUMNS", "column_summary"]

#: The columns :func:`column_summary` adds, with units in the names.
COLUMN_I_COLUMNS = ["column_I_scene_C", "column_I_C", "column_I_bias_K",
                    "column_I_uncertainty_K"]


def column_summary(m: Measurement, scene) -> dict:
    """
    Column I of a measurement: scene peak [°C], highest valid reading [°C], bias [K] and the
    tensor standard deviation at that pixel [K]; empty if the scene has no columns or the
    column lies outside the measured pixels.
    """
    if scene is None or not has_columns(scene):
        return {}
    column = column_index(scene, m.camera.fpa.pixel_pitch, "I", m.camera.fpa.origin[1])
    if not 0 <= column < m.shape[1]:
        return {}
    readings = m.apparent_temperature[:, column]
    scene_peak = float(m.tensor_max[:, column].max())
    out = {"column_I_scene_C": to_celsius(scene_peak)}
    if np.isfinite(readings).any():
        i = int(np.nanargmax(readings))
        out.update(column_I_C=to_celsius(float(readings[i])),
                   column_I_bias_K=float(readings[i]) - scene_peak,
                   column_I_uncertainty_K=float(m.tensor_std[i, column]))
    return out


#: The columns the hook adds, read by :meth:`radiosim.study.Study.columns`.
column_summary.columns = COLUMN_I_COLUMNS
#: Those the command's console table shows after the peak's: (heading, column, unit).
column_summary.table_columns = (("col. I", "column_I_C", "[°C]"),
                                ("bias", "column_I_bias_K", "[K]"))

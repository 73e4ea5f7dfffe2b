"""
Everything specific to the paper radiosim starts from: Whitenton, Heigel & Ivester, *The
effects of integration time and size-of-source on the temperature measurement of segmented chip
formation using infrared thermography*, ASME MSEC2009-84319.

-   :mod:`radiosim.paper.columns`: Columns I–III and the band pixel (one helper each);
-   :mod:`radiosim.paper.summary`: the study's Column I summary columns;
-   :mod:`radiosim.paper.figures`: Figures 4–11;
-   :mod:`radiosim.paper.chip_calibration`: the segmented chip calibrated to the paper's numbers.

The ``msec2009`` study names these as its hooks.
"""

from radiosim.paper.columns import COLUMN_NAMES, band_pixel, column_index
from radiosim.paper.figures import make_figures, preview_scene
from radiosim.paper.summary import COLUMN_I_COLUMNS, column_summary

__all__ = ["COLUMN_NAMES", "column_index", "band_pixel", "column_summary", "COLUMN_I_COLUMNS",
           "make_figures", "preview_scene"]

"""
Full-resolution check of the segmented-chip calibration against the paper (docs/scene.md's table).

Measures every target with the linear ideal camera on the whole 1440 × 1113 field with 0.2 µs
frames (no crops), prints the table and exits non-zero if any row is out of tolerance. The test
suite runs a reduced version (tests/test_chip_calibration.py); run this before changing the
scene's defaults:

    python benchmarks/check_chip_calibration.py
"""

import sys
import time

from radiosim.paper.chip_calibration import evaluate_targets, report, residuals

if __name__ == "__main__":
    start = time.perf_counter()
    values = evaluate_targets(crop=False)
    print(report(values))
    print(f"Column I pixel row {values['column_I_peak_row']}, 90 µs peak at "
          f"{values['peak_90us_location_um']} µm; {time.perf_counter() - start:.0f} s")
    sys.exit(0 if (abs(residuals(values)) <= 1).all() else 1)

"""The wheel ships the spectra and the presets, and the installed package finds them."""

import subprocess
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_wheel_contains_spectra_and_presets(tmp_path):
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
         "-w", str(tmp_path), str(ROOT)],
        check=True, capture_output=True,
    )
    (wheel,) = tmp_path.glob("radiosim-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    for csv in (ROOT / "spectra").glob("*.csv"):
        assert f"radiosim/data/spectra/{csv.name}" in names
    for preset in (ROOT / "radiosim" / "presets").glob("*.toml"):
        assert f"radiosim/presets/{preset.name}" in names

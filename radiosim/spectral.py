"""
Spectral curves: filters, optics transmission, detector quantum efficiency and emissivity.

Curves are :class:`colour.SpectralDistribution` objects whose domain is the wavelength in metres
(SI inside) and whose values are dimensionless (transmission, quantum efficiency or emissivity,
0 to 1). They interpolate linearly between their nodes (a cubic spline would overshoot at filter
edges) and are *zero* outside their range: a curve says nothing about wavelengths it does not
cover, and a filter or detector that is not specified there must not transmit there.

The curves shipped with radiosim live in ``spectra/`` as CSV files (wavelength in µm at the edge,
converted once on reading); each file states its quantity, units, source or generating model and
whether it is idealised, in ``# key: value`` header lines. Users pass their own curves as a
``SpectralDistribution`` (domain in metres), a CSV path in the same format, or a shipped name.

References
----------
-   Mansencal, T. et al. *Colour 0.4* (colour-science), ``colour.SpectralDistribution``.
"""

from __future__ import annotations

import logging
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from radiosim.errors import RadiosimError

if TYPE_CHECKING:  # colour-science is imported when a curve is first built (see colour_science)
    from colour import SpectralDistribution

__all__ = [
    "colour_science",
    "is_spectrum",
    "WAVELENGTH_UNITS",
    "spectra_directory",
    "available_spectra",
    "spectral_distribution",
    "read_spectrum",
    "as_spectrum",
]


def colour_science():
    """
    The colour-science package, imported on first use (it costs seconds: its plotting package
    and matplotlib) with numpy's print options kept as they were (colour's import switches them
    to ``legacy="1.13"``).
    """
    module = sys.modules.get("colour")
    if module is None or not hasattr(module, "SpectralDistribution"):
        options = np.get_printoptions()
        try:
            import colour as module
        finally:
            np.set_printoptions(**options)
    return module


def is_spectrum(value) -> bool:
    """
    Whether ``value`` is a :class:`colour.SpectralDistribution` (without importing colour: no
    curve exists before colour is imported).

    Examples
    --------
    >>> is_spectrum(0.3)
    False
    """
    module = sys.modules.get("colour")
    cls = getattr(module, "SpectralDistribution", None) if module is not None else None
    return cls is not None and isinstance(value, cls)

logger = logging.getLogger(__name__)

#: Wavelength units accepted in CSV headers, with their factor to metres.
WAVELENGTH_UNITS = {"m": 1.0, "um": 1e-6, "µm": 1e-6, "nm": 1e-9}

_REQUIRED_KEYS = ("quantity", "wavelength_unit", "source", "idealised")


def spectra_directory() -> Path:
    """
    Folder holding the shipped spectral CSV files.

    Inside an installed wheel they are ``radiosim/data/spectra``; in a source checkout (or an
    editable install) they are ``spectra/`` at the top of the repository.
    """
    here = Path(__file__).resolve().parent
    for candidate in (here / "data" / "spectra", here.parent / "spectra"):
        if candidate.is_dir():
            return candidate
    raise RadiosimError(
        f"radiosim's spectral data were not found in {here / 'data' / 'spectra'} nor in "
        f"{here.parent / 'spectra'}: the installation is incomplete"
    )


def available_spectra() -> tuple[str, ...]:
    """
    Names of the shipped spectral curves (file names without ``.csv``).

    Examples
    --------
    >>> "qe_insb_77K" in available_spectra()
    True
    """
    return tuple(sorted(p.stem for p in spectra_directory().glob("*.csv")))


def spectral_distribution(
    wavelength: np.ndarray, values: np.ndarray, name: str = "spectrum"
) -> SpectralDistribution:
    """
    Build a spectral curve: linear interpolation, zero outside its range.

    Parameters
    ----------
    wavelength
        Node wavelengths [m], strictly increasing.
    values
        Dimensionless values at the nodes (transmission, quantum efficiency, emissivity), in
        [0, 1].
    name
        Name of the curve.

    Examples
    --------
    >>> sd = spectral_distribution([4e-6, 5e-6], [0.5, 1.0], "ramp")
    >>> sd[np.array([3e-6, 4.5e-6, 6e-6])]
    array([0.  , 0.75, 0.  ])
    """
    wavelength = np.asarray(wavelength, dtype=float)
    values = np.asarray(values, dtype=float)
    if wavelength.ndim != 1 or wavelength.shape != values.shape or wavelength.size < 2:
        raise RadiosimError(
            f"spectrum {name!r}: expected two 1-D arrays of equal length ≥ 2, got wavelength "
            f"shape {wavelength.shape} and values shape {values.shape}"
        )
    if not np.all(np.isfinite(wavelength)) or np.any(wavelength <= 0):
        raise RadiosimError(f"spectrum {name!r}: wavelengths must be finite and > 0 [m]")
    if np.any(np.diff(wavelength) <= 0):
        raise RadiosimError(f"spectrum {name!r}: wavelengths must be strictly increasing")
    if wavelength.max() > 1e-3:
        raise RadiosimError(
            f"spectrum {name!r}: wavelength {wavelength.max():g} is beyond 1 mm; wavelengths are "
            "in metres (a µm or nm value passed as metres?)"
        )
    if not np.all(np.isfinite(values)) or np.any(values < 0) or np.any(values > 1):
        raise RadiosimError(
            f"spectrum {name!r}: values are dimensionless fractions and must lie in [0, 1]"
        )
    colour = colour_science()
    return colour.SpectralDistribution(
        values,
        wavelength,
        name=name,
        interpolator=colour.algebra.LinearInterpolator,
        extrapolator=colour.algebra.Extrapolator,
        extrapolator_kwargs={"method": "Constant", "left": 0.0, "right": 0.0},
    )


def _parse_csv(path: Path) -> tuple[dict[str, str], np.ndarray]:
    metadata: dict[str, str] = {}
    rows: list[tuple[float, float]] = []
    header_seen = False
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise RadiosimError(f"cannot read spectrum file {path}: {exc}") from exc
    for number, line in enumerate(text.splitlines(), start=1):
        line = line.strip()
        if not line:
            continue
        if line.startswith("#"):
            key, sep, value = line[1:].partition(":")
            if sep:
                metadata[key.strip().lower()] = value.strip()
            continue
        if not header_seen:
            header_seen = True
            columns = [c.strip() for c in line.split(",")]
            if len(columns) != 2:
                raise RadiosimError(
                    f"{path}, line {number}: expected a header of two columns "
                    f"(wavelength, value), got {line!r}"
                )
            continue
        fields = line.split(",")
        try:
            if len(fields) != 2:
                raise ValueError
            rows.append((float(fields[0]), float(fields[1])))
        except ValueError:
            raise RadiosimError(
                f"{path}, line {number}: expected two numbers separated by a comma, got {line!r}"
            ) from None
    if len(rows) < 2:
        raise RadiosimError(f"{path}: needs at least two data rows, found {len(rows)}")
    return metadata, np.array(rows)


def read_spectrum(name_or_path: str | Path) -> SpectralDistribution:
    """
    Read a spectral curve from a shipped name or a CSV path.

    The CSV holds ``# key: value`` header lines, then a header row of two column names, then
    rows ``wavelength,value``. The keys ``quantity``, ``wavelength_unit`` (``um``, ``nm`` or
    ``m``), ``source`` and ``idealised`` are required, so that every curve says what it is and
    where it comes from. They are kept in the returned curve's ``metadata`` dict.

    Parameters
    ----------
    name_or_path
        A name from :func:`available_spectra` or a path to a CSV file.

    Returns
    -------
    SpectralDistribution
        Domain wavelength [m], dimensionless values, zero outside the file's range.

    Examples
    --------
    >>> qe = read_spectrum("qe_insb_77K")
    >>> float(qe[4.0e-6]) > 0.8, float(qe[5.4e-6]), qe.metadata["wavelength_unit"]
    (True, 0.0, 'um')
    """
    path = Path(name_or_path)
    if path.suffix.lower() != ".csv" and not path.exists():
        shipped = spectra_directory() / f"{name_or_path}.csv"
        if not shipped.is_file():
            raise RadiosimError(
                f"unknown spectrum {str(name_or_path)!r}: not a file and not one of the shipped "
                f"curves {', '.join(available_spectra())}"
            )
        path = shipped
    if not path.is_file():
        raise RadiosimError(f"spectrum file {path} does not exist")
    metadata, data = _parse_csv(path)
    missing = [k for k in _REQUIRED_KEYS if k not in metadata]
    if missing:
        raise RadiosimError(
            f"{path}: header lacks {', '.join('# ' + k + ': …' for k in missing)}; every spectrum "
            "states its quantity, wavelength unit, source and whether it is idealised"
        )
    unit = metadata["wavelength_unit"]
    if unit not in WAVELENGTH_UNITS:
        raise RadiosimError(
            f"{path}: wavelength_unit {unit!r} is not one of {', '.join(WAVELENGTH_UNITS)}"
        )
    name = metadata.get("name", path.stem)
    try:
        sd = spectral_distribution(data[:, 0] * WAVELENGTH_UNITS[unit], data[:, 1], name)
    except RadiosimError as exc:
        raise RadiosimError(f"{path}: {exc}") from None
    sd.metadata = metadata
    logger.debug("read spectrum %s from %s", name, path)
    return sd


def as_spectrum(value: float | str | Path | SpectralDistribution, what: str):
    """
    Coerce a scalar, a shipped name, a CSV path or a curve into a float or a curve.

    Parameters
    ----------
    value
        A dimensionless scalar in [0, 1] (grey), a ``SpectralDistribution`` (domain [m]),
        a shipped curve name or a CSV path.
    what
        What the value is, for error messages (e.g. ``"emissivity"``).

    Returns
    -------
    float or SpectralDistribution
    """
    if is_spectrum(value):  # a user's curve: checked as a file's would be
        domain = np.asarray(value.domain, dtype=float)
        values = np.asarray(value.values, dtype=float)
        if domain.size and (not np.all(np.isfinite(domain)) or domain.min() <= 0
                            or domain.max() > 1e-3):
            raise RadiosimError(f"{what}: its wavelengths run {domain.min():g}–{domain.max():g}; "
                                "wavelengths are in metres, > 0 and up to 1 mm (a µm or nm "
                                "value passed as metres?)")
        if not np.all(np.isfinite(values)) or values.min() < 0 or values.max() > 1:
            raise RadiosimError(f"{what}: its values run {values.min():g}–{values.max():g}; "
                                "expected dimensionless fractions in [0, 1]")
        return value
    if isinstance(value, (str, Path)):
        return read_spectrum(value)
    if isinstance(value, Sequence) or np.ndim(value) != 0:
        raise RadiosimError(
            f"{what} must be a scalar, a SpectralDistribution, a shipped curve name or a CSV "
            f"path, got {type(value).__name__}"
        )
    scalar = float(value)
    if not np.isfinite(scalar) or not 0 <= scalar <= 1:
        raise RadiosimError(f"{what} must be a number in [0, 1], got {value!r}")
    return scalar

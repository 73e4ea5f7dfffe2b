"""
The response's signal as tables, engine-neutral (:class:`SignalTable`): what a response
(:meth:`radiosim.response.Response.signal_table`) hands to the integration engines. It holds
no engine's format: each entry's :class:`~radiosim.radiometry.BandRadianceTable` (its
temperature grid ``temperatures`` [K], nodes T_k, and ``coefficients`` (intervals, 4), the
cubic of the radiance in T − T_k on each interval, highest power first [signal unit K⁻³,
K⁻², K⁻¹, 1]; the range ``temperature_range`` [K] it answers over), the exact radiance for
samples below it, the entries' grey factors and the frame's grey and index maps, with the numpy
evaluation of the signal (:meth:`SignalTable.signal`, every engine's reference). An engine packs
it into its own format (the compiled CPU engine: :func:`radiosim.kernels.packing.pack`) and may
keep that in :attr:`SignalTable.engine_data`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from radiosim.errors import RadiosimError
from radiosim.kernels.codes import SIGNAL_INDEX, SIGNAL_MAP, SIGNAL_SCALAR
from radiosim.radiometry import BandRadianceTable, band_radiance

__all__ = ["SignalTable"]

_UNCHANGED = object()


class SignalTable:
    """
    The signal S(T) = L_e(T) · grey_e · grey of every sample [signal unit, e.g. photons s⁻¹
    m⁻² sr⁻¹], where e is the sample's *entry*: one or more
    :class:`~radiosim.radiometry.BandRadianceTable` (L_e), with the emissivity of every sample.

    Emissivity forms:

    -   one entry, ``grey`` a scalar: a grey body (or a spectral curve, tabulated in the entry's
        table, with ``grey`` 1);
    -   one entry, ``grey`` a 2-D map on the frame region's sample grid: a grey map;
    -   several entries (e.g. per scene region: each a table and a grey factor) and ``index``,
        the entry of every sample (2-D integer map on the region grid), optionally with a
        ``grey`` map as well.

    Parameters
    ----------
    tables
        A table, or one table per entry (the same table object may serve several entries; it is
        packed once). All are evaluated exactly as :meth:`BandRadianceTable.__call__` does.
    exact
        The exact radiance of each entry for samples below its table: ``None`` (such samples
        raise), a mapping of :func:`~radiosim.radiometry.band_radiance` keyword arguments
        (``band``, ``quantity``, ``responsivity``, ``emissivity``), or a callable T [K] →
        radiance; one, or one per entry.
    grey
        Grey factor of every sample: a scalar, or a float map shaped like the frame region.
    index
        Entry of every sample, an integer map shaped like the frame region (needed, by
        :func:`accumulate`, with more than one entry). uint8 maps are used as they are; other
        integer types are converted to intp (a copy).
    entry_grey
        Grey factor of each entry (default 1).

    Examples
    --------
    >>> from radiosim.radiometry import BandRadianceTable
    >>> table = BandRadianceTable(temperature_range=(200.0, 1500.0), per_octave=64)
    >>> signal = SignalTable(table, exact={"band": table.band}, grey=0.9)
    >>> signal.n_entries, table.intervals, table.coefficients.shape, signal.mode
    (1, 210, (210, 4), 1)
    """

    def __init__(self, tables, exact=None, grey=1.0, index=None, entry_grey=None):
        if isinstance(tables, BandRadianceTable):
            tables = [tables]
        tables = list(tables)
        if not tables or not all(isinstance(t, BandRadianceTable) for t in tables):
            raise RadiosimError("tables must be one or more BandRadianceTable")
        n = len(tables)
        self.tables = tables
        unique: list[BandRadianceTable] = []
        entry_table = []
        for t in tables:
            for j, u in enumerate(unique):
                if u is t:
                    entry_table.append(j)
                    break
            else:
                entry_table.append(len(unique))
                unique.append(t)
        self.entry_table = np.array(entry_table, dtype=np.intp)
        if entry_grey is None:
            entry_grey = np.ones(n)
        self.entry_grey = np.array(entry_grey, dtype=np.float64).reshape(-1)
        if self.entry_grey.size != n or not np.all(np.isfinite(self.entry_grey)):
            raise RadiosimError(f"entry_grey must hold {n} finite values, got {entry_grey!r}")
        if exact is None or callable(exact) or isinstance(exact, Mapping):
            exact = [exact] * n
        exact = list(exact)
        if len(exact) != n:
            raise RadiosimError(f"exact must be one specification or {n}, got {len(exact)}")
        self.exact = exact
        #: The distinct tables, in entry order (a table serving several entries once).
        self.unique_tables = tuple(unique)
        #: The range each distinct table answers over [K] (samples below it take the exact
        #: radiance, samples above it are refused).
        self.t_min = np.array([t.temperature_range[0] for t in unique])
        self.t_max = np.array([t.temperature_range[1] for t in unique])
        #: What engines keep for this table (their packed forms, by engine name); shared with
        #: the copies :meth:`with_maps` makes.
        self.engine_data: dict = {}
        self._set_maps(grey, index)

    @classmethod
    def build(cls, band=(3.8e-6, 5.1e-6), quantity: str = "photon", responsivity=None,
              emissivity=(1.0,), temperature_range=(150.0, 3000.0),
              per_octave: int | None = None, grey=1.0, index=None) -> "SignalTable":
        """
        Tables and exact radiances for a band and responsivity, one entry per emissivity
        (scalar: the blackbody table with that grey factor; spectral: its own table).
        """
        if not isinstance(emissivity, (list, tuple)):
            emissivity = [emissivity]
        tables, exact, entry_grey = [], [], []
        blackbody = None
        for value in emissivity:
            if np.isscalar(value):
                if blackbody is None:
                    blackbody = BandRadianceTable(band, quantity, responsivity, 1.0,
                                                  temperature_range, per_octave)
                tables.append(blackbody)
                exact.append(dict(band=band, quantity=quantity, responsivity=responsivity))
                entry_grey.append(float(value))
            else:
                tables.append(BandRadianceTable(band, quantity, responsivity, value,
                                                temperature_range, per_octave))
                exact.append(dict(band=band, quantity=quantity, responsivity=responsivity,
                                  emissivity=value))
                entry_grey.append(1.0)
        return cls(tables, exact, grey, index, entry_grey)

    def _set_maps(self, grey, index):
        if isinstance(grey, np.ndarray) and grey.ndim == 2:
            self.grey = np.ascontiguousarray(grey, dtype=np.float64)
            self.grey_scalar = None
        else:
            try:
                value = float(grey)
            except (TypeError, ValueError):
                raise RadiosimError(f"grey must be a number or a 2-D map, got {grey!r}") from None
            if not math.isfinite(value):
                raise RadiosimError(f"grey must be finite, got {grey!r}")
            self.grey, self.grey_scalar = value, value
        if index is None:
            self.index = None
        else:
            index = np.asarray(index)
            if index.ndim != 2 or not np.issubdtype(index.dtype, np.integer):
                raise RadiosimError(f"index must be a 2-D integer map, got {index.dtype} "
                                    f"shape {index.shape}")
            if index.dtype != np.uint8:
                index = index.astype(np.intp, copy=False)
            self.index = np.ascontiguousarray(index)
            if self.grey_scalar is None and self.grey.shape != self.index.shape:
                raise RadiosimError(f"grey map shape {self.grey.shape} and index map shape "
                                    f"{self.index.shape} differ")

    def with_maps(self, grey=_UNCHANGED, index=_UNCHANGED) -> "SignalTable":
        """The same tables with other grey and/or index maps (e.g. those of the next frame)."""
        other = object.__new__(type(self))
        other.__dict__.update(self.__dict__)
        other._set_maps(self.grey if grey is _UNCHANGED else grey,
                        self.index if index is _UNCHANGED else index)
        return other

    @property
    def n_entries(self) -> int:
        return int(self.entry_table.size)

    @property
    def mode(self) -> int:
        """How the samples' emissivity is given (:mod:`radiosim.kernels.codes`):
        SIGNAL_SCALAR (one entry, a grey factor), SIGNAL_MAP (one entry, a grey map) or
        SIGNAL_INDEX (an index map of entries)."""
        if self.index is not None:
            return SIGNAL_INDEX
        return SIGNAL_SCALAR if self.grey_scalar is not None else SIGNAL_MAP

    def check_maps(self, shape):
        """Raise unless the maps fit a frame region of ``shape`` (and several entries have an
        index map)."""
        if self.index is None and self.n_entries > 1:
            raise RadiosimError(f"{self.n_entries} radiance table entries need an index map "
                                "(the entry of every sample): see with_maps")
        for name, value in (("grey map", None if self.grey_scalar is not None else self.grey),
                            ("index map", self.index)):
            if value is not None and value.shape != tuple(shape):
                raise RadiosimError(f"{name} has shape {value.shape}, expected the frame "
                                    f"region's shape {tuple(shape)}")

    def _exact(self, entry: int, t: np.ndarray) -> np.ndarray:
        spec = self.exact[entry]
        if spec is None:
            lo = self.tables[entry].temperature_range[0]
            raise RadiosimError(
                f"temperature {t.min():g} K is below the radiance table's range (from {lo:g} K) "
                "and no exact radiance was given for it"
            )
        if isinstance(spec, Mapping):
            return band_radiance(t, **spec)
        return np.asarray(spec(t), dtype=float)

    def signal(self, temperature: np.ndarray, grey=None, index=None) -> np.ndarray:
        """
        S = L_e(T) · grey_e · grey of samples (numpy, the reference): the table inside its
        range, the exact radiance below it. ``grey`` and ``index`` are the values of the maps at
        those samples (default: the scalar grey, entry 0).
        """
        t = np.asarray(temperature, dtype=np.float64)
        out = np.empty(t.shape)
        entries = np.zeros(t.shape, dtype=np.intp) if index is None else np.asarray(index)
        factor_map = self.grey_scalar if grey is None else np.asarray(grey, dtype=np.float64)
        for e in np.unique(entries):
            here = entries == e
            te = t[here]
            table = self.tables[e]
            lo, hi = table.temperature_range
            radiance = np.empty(te.shape)
            cold = te < lo
            radiance[~cold] = table(te[~cold])
            if cold.any():
                radiance[cold] = self._exact(int(e), te[cold])
            if np.ndim(factor_map) == 0:
                factor = self.entry_grey[e] * factor_map
            else:
                factor = self.entry_grey[e] * factor_map[here]
            out[here] = radiance * factor
        return out


"""
Figures (matplotlib), generic: a figure factory, Markdown tables, a study's results loaded back,
a reading-against-parameter plot, and PNG files written atomically.

The library draws on a figure it creates and returns; it never shows windows. Axes carry units.
The paper's figures are in :mod:`radiosim.paper.figures`.
"""

from __future__ import annotations

import contextlib
import functools
import math
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from radiosim.errors import RadiosimError, RadiosimIOError

__all__ = ["DPI", "figure", "fixed_axes", "few_ticks", "load_matplotlib", "preload",
           "wrap_text", "title_block", "markdown_table", "load_results", "select", "plot_versus",
           "save_figure", "collector_held", "unhinted_text"]


#: Resolution of the PNG files [dots per inch]. Figures are created at it, so the layout computed
#: once is the one drawn.
DPI = 110


def figure(width, height, dpi: float = DPI, layout: str | None = "constrained"):
    """
    A figure of ``width`` × ``height`` inches at ``dpi``, drawn by Agg.

    ``layout`` is matplotlib's layout engine: ``"constrained"`` (the default) places titles,
    labels and colorbars by measuring every text (it costs a draw's worth of text layout);
    ``None`` leaves the axes where they are put, e.g. by :func:`fixed_axes` (the paper's
    figures, drawn once). It does not import pyplot and does not depend on the active backend:
    the canvas is Agg's (which also displays inline in notebooks), created with the figure.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=dpi, layout=layout)
    FigureCanvasAgg(fig)
    return fig


def fixed_axes(fig, nrows: int, ncols: int, left: float, right: float, bottom: float,
               top: float, wspace: float = 0.0, hspace: float = 0.0, **subplots):
    """
    ``nrows`` × ``ncols`` axes on ``fig`` at fixed places: margins ``left``, ``right``,
    ``bottom``, ``top`` and the gaps between axes ``wspace``, ``hspace``, all in inches [in].
    No layout engine measures them afterwards, so the figure is drawn once. ``subplots`` go to
    :meth:`matplotlib.gridspec.GridSpec.subplots` (``sharex``, ``sharey``, ``squeeze``).
    """
    width, height = fig.get_size_inches()
    cell_w = (width - left - right - (ncols - 1) * wspace) / ncols
    cell_h = (height - bottom - top - (nrows - 1) * hspace) / nrows
    if cell_w <= 0 or cell_h <= 0:
        raise RadiosimError(f"a figure of {width:g} × {height:g} in has no room for {nrows} × "
                            f"{ncols} axes within margins of {left:g}, {right:g}, {bottom:g}, "
                            f"{top:g} in")
    grid = fig.add_gridspec(nrows, ncols, left=left / width, right=1 - right / width,
                            bottom=bottom / height, top=1 - top / height,
                            wspace=wspace / cell_w, hspace=hspace / cell_h)
    return grid.subplots(**subplots)


def few_ticks(ax, x: int | str = 5, y: int | str = 6):
    """At most about ``x`` and ``y`` intervals between major ticks on ``ax``'s axes (``"auto"``:
    as many as matplotlib's default locator gives), at round steps (1, 2, 2.5, 5 × 10ⁿ): a tick
    and its label cost a good part of a figure's drawing.
    Only the ticks inside the axes' limits are made (matplotlib makes a tick object for each
    location its locator gives, also the ones beyond the limits it then leaves undrawn)."""
    steps = [1, 2, 2.5, 5, 10]
    ax.xaxis.set_major_locator(_in_view(nbins=x, steps=steps))
    ax.yaxis.set_major_locator(_in_view(nbins=y, steps=steps))
    return ax


def _in_view(**kwargs):
    """A :class:`matplotlib.ticker.MaxNLocator` of ``kwargs`` that gives only the locations
    within its axis' view interval (to a millionth of it: matplotlib draws those it finds
    inside)."""
    return _in_view_class()(**kwargs)


@functools.cache
def _in_view_class():
    from matplotlib.ticker import MaxNLocator

    class InViewLocator(MaxNLocator):
        def __call__(self):
            locs = np.asarray(super().__call__())
            lo, hi = sorted(self.axis.get_view_interval())
            tol = 1e-6 * (hi - lo)
            return locs[(locs >= lo - tol) & (locs <= hi + tol)]

    return InViewLocator


_PRELOAD: list = []


def load_matplotlib() -> None:
    """Import matplotlib's figure, Agg canvas, ticker, legend and colorbar modules and load its
    default font (what a figure drawn here would otherwise wait for)."""
    import matplotlib.colorbar  # noqa: F401
    import matplotlib.figure  # noqa: F401
    import matplotlib.legend  # noqa: F401
    import matplotlib.ticker  # noqa: F401
    from matplotlib.backends import backend_agg  # noqa: F401
    from matplotlib.font_manager import FontProperties, findfont, get_font

    get_font(findfont(FontProperties()))


def preload():
    """
    :func:`load_matplotlib` on a background (daemon) thread, once per process, so that a figure
    drawn later does not wait for it; returns the thread. Any error is left for the figure that
    needs the module to raise.
    """
    import threading

    def load():
        try:
            load_matplotlib()
        except Exception:  # noqa: BLE001  (the figure that needs it raises it)
            pass

    if not _PRELOAD:
        thread = threading.Thread(target=load, name="radiosim-preload-plotting", daemon=True)
        thread.start()
        _PRELOAD.append(thread)
    return _PRELOAD[0]


@contextmanager
def collector_held():
    """
    Python's cyclic garbage collector held off while figures are built and drawn, then run once
    over the objects made meanwhile (its youngest generation).

    A figure makes tens of thousands of small objects (ticks, texts, paths, transforms) that
    live until it is saved: with the collector on, they survive its young passes and set off a
    full pass over every object of the process (a study's numba, scipy and matplotlib
    included). Held off, the figures' objects
    are freed by the one young pass at the end, and the process's old objects are not walked.
    The collector's state is restored on exit; nested uses hold it once.
    """
    import gc

    if not gc.isenabled():
        yield
        return
    gc.disable()
    try:
        yield
    finally:
        gc.enable()
        gc.collect(0)


@contextmanager
def unhinted_text():
    """
    Text measured and drawn from the glyphs' outlines as they are, not hinted to the pixel grid
    (matplotlib's ``text.hinting: none``, the setting its own image tests draw with), unless the
    user set ``text.hinting`` to another value than matplotlib's default (in a matplotlibrc or
    ``rcParams``): theirs is kept. (matplotlib caches a text's size whatever the hinting: a
    figure drawn before on the same canvas keeps the sizes it measured then.) matplotlib's
    default runs each glyph's TrueType hinting program whenever a text is shaped; without it
    the figures draw faster (``benchmarks/bench_figures.py``), and their pixels do not depend on
    the FreeType build's hinting. :func:`save_figure` and :func:`wrap_text` measure and draw inside it; the rc
    settings are restored on exit.
    """
    import matplotlib

    if matplotlib.rcParams["text.hinting"] != matplotlib.rcParamsDefault["text.hinting"]:
        yield  # the user's setting
        return
    with matplotlib.rc_context({"text.hinting": "none"}):
        yield


def _text_width(fig, text: str, fontsize: float) -> float:
    """Width [in] of one line of ``text`` at ``fontsize`` [pt], as Agg draws it on ``fig``
    (:func:`save_figure`: text unhinted, :func:`unhinted_text`)."""
    from matplotlib.font_manager import FontProperties

    renderer = fig.canvas.get_renderer()
    with unhinted_text():
        width, _, _ = renderer.get_text_width_height_descent(
            text, FontProperties(size=fontsize), ismath=False)
    return width / fig.dpi


def wrap_text(fig, text: str, width: float, fontsize: float) -> str:
    """
    ``text`` broken at spaces into lines no wider than ``width`` [in] at ``fontsize`` [pt], as
    measured by the renderer that draws ``fig`` (a word longer than a line stays whole).

    Examples
    --------
    >>> fig = figure(4, 1, layout=None)
    >>> len(wrap_text(fig, "a title that does not fit on one short line", 1.5, 10).splitlines()) > 1
    True
    """
    import textwrap

    # Text is measured once, then each line it is broken into once: shaping a line of text
    # costs about a millisecond, so a width per word tried would cost a title tens of them.
    out: list[str] = []
    for paragraph in text.split("\n"):
        whole = _text_width(fig, paragraph, fontsize)
        chars = max(1, int(len(paragraph) * width / whole)) if whole > width else len(paragraph)
        while True:
            lines = textwrap.wrap(paragraph, chars, break_long_words=False,
                                  break_on_hyphens=False) or [""]
            if chars == 1 or all(" " not in line or _text_width(fig, line, fontsize) <= width
                                 for line in lines):
                break
            chars = max(1, int(chars * 0.95))
        out += lines
    return "\n".join(out)


def _lines_height(lines: int, fontsize: float) -> float:
    """Height [in] of ``lines`` lines of text at ``fontsize`` [pt] (matplotlib's line spacing,
    1.2, and the descent of the last line)."""
    return (1.2 * lines + 0.1) * fontsize / 72


def title_block(fig, text: str, fontsize: float = 9, pad: float = 0.06,
                side: float = 0.2) -> float:
    """
    The figure's title: ``text`` wrapped to the figure's width less ``side`` [in] each side
    and held ``pad`` [in] below its top edge (also if the figure is resized afterwards);
    returns the height it takes from the top [in], padding included, for the axes' top margin.
    """
    from matplotlib.transforms import ScaledTranslation

    width = fig.get_size_inches()[0]
    wrapped = wrap_text(fig, text, width - 2 * side, fontsize)
    title = fig.suptitle(wrapped, fontsize=fontsize, y=1.0, va="top")
    title.set_transform(fig.transSubfigure + ScaledTranslation(0, -pad, fig.dpi_scale_trans))
    return pad + _lines_height(wrapped.count("\n") + 1, fontsize)


def markdown_table(rows: list[dict], formats: dict | None = None) -> str:
    """
    A Markdown table of ``rows`` (dicts with the same keys), numbers formatted by ``formats``
    (key → format spec); NaN and empty values show as a dash.

    Examples
    --------
    >>> print(markdown_table([{"t [µs]": 1.0, "T [°C]": 739.04}], {"T [°C]": ".1f"}))
    | t [µs] | T [°C] |
    | --- | --- |
    | 1.0 | 739.0 |
    """
    if not rows:
        return ""
    formats = formats or {}
    keys = list(rows[0])

    def cell(key, value):
        if value is None or value == "" or (isinstance(value, float) and math.isnan(value)):
            return "—"
        if isinstance(value, (int, float, np.floating, np.integer)) and key in formats:
            return format(value, formats[key])
        return str(value)

    lines = ["| " + " | ".join(keys) + " |", "| " + " | ".join("---" for _ in keys) + " |"]
    lines += ["| " + " | ".join(cell(k, r.get(k)) for k in keys) + " |" for r in rows]
    return "\n".join(lines)



# -- a study's results ------------------------------------------------------------------

#: The suffixes of numeric columns (their unit), and the unitless numeric columns.
_NUMERIC_SUFFIXES = ("_C", "_K", "_us", "_um", "_um2", "_fraction")
_NUMERIC = {"n_frames", "pixel_samples"}


def _numeric(column: str) -> bool:
    """Whether a results column holds numbers: its name ends with a unit, or is a count."""
    return column in _NUMERIC or column.endswith(_NUMERIC_SUFFIXES)


def _rows(path: Path) -> list[dict]:
    import csv

    with path.open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    for row in rows:
        for key in [k for k in row if k is not None and _numeric(k)]:
            if row[key] in ("", None):
                row[key] = math.nan
            else:
                with contextlib.suppress(ValueError):  # a hook's text column: kept as text
                    row[key] = float(row[key])
    return rows


def load_results(folder) -> tuple[list[dict], list[dict]]:
    """The rows of a study's ``results.csv`` and ``pixel_history.csv`` (if any), numbers as
    floats."""
    folder = Path(folder)
    table = folder / "results.csv"
    if not table.is_file():
        raise RadiosimError(f"{folder} holds no results.csv (run a study into it first)")
    history = folder / "pixel_history.csv"
    return _rows(table), (_rows(history) if history.is_file() else [])


def select(rows, sweep, **match):
    """The rows of ``sweep`` whose keys equal ``match``."""
    return [r for r in rows if r["sweep"] == sweep and all(r[k] == v for k, v in match.items())]


def _label(camera: str, response: str) -> str:
    return camera if camera == response else f"{camera} ({response} response)"


#: How the lines of :func:`plot_versus` differ besides colour, so that lines that coincide
#: stay visible: (marker, marker face filled, line style, marker size [pt], cap size [pt]).
_STYLES = (("o", True, "-", 7, 3), ("s", False, "--", 9, 6), ("^", False, "-.", 9, 5),
           ("D", False, ":", 7, 4), ("v", False, (0, (5, 1, 1, 1)), 9, 5))


def plot_versus(target, rows, x_key, y_key, err_key, scene_key, xlabel, title, ylabel=None,
                title_width=None):
    """
    Reading ±1σ against a sweep parameter, one line per camera (response named where it differs
    from the camera's name), the scene's value as a dashed line; returns the axes.

    ``target`` is the axes to draw on, or a figure (or subfigure) that gets one. The lines
    differ in marker, fill and line style as well as colour, the first drawn on top, so that
    cameras that read alike do not hide one another. ``title_width`` [in]: wrap the title to
    it (default: on one line).
    """
    ax = target.add_subplot() if hasattr(target, "add_subplot") else target
    groups = sorted({(r["camera"], r["response"]) for r in rows})
    for n, (camera, response) in enumerate(groups):
        mine = sorted((r for r in rows if (r["camera"], r["response"]) == (camera, response)),
                      key=lambda r: r[x_key])
        x = [r[x_key] for r in mine]
        marker, filled, style, size, cap = _STYLES[n % len(_STYLES)]
        lines = ax.errorbar(x, [r[y_key] for r in mine], yerr=[r[err_key] for r in mine],
                            marker=marker, markersize=size, ls=style, capsize=cap,
                            zorder=3 + len(groups) - n, label=_label(camera, response))
        if not filled:
            lines[0].set_markerfacecolor("none")
            lines[0].set_markeredgewidth(1.5)
    scene = [r[scene_key] for r in rows if np.isfinite(r[scene_key])]
    if scene:
        ax.axhline(max(scene), color="black", ls="--", lw=1, label="scene peak")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel or "temperature [°C]")
    if title_width is not None:
        title = wrap_text(ax.figure, title, title_width, 10)
    ax.set_title(title, fontsize=10, y=1.0)  # placed, not measured against the ticks
    ax.legend(fontsize=8)
    return few_ticks(ax)


@contextmanager
def _laid_out(fig, dpi):
    """
    ``fig`` at ``dpi`` on an Agg canvas, its layout engine run once and then held off, so that a
    draw inside (:func:`save_figure`'s) draws it once. (``savefig`` with a layout engine draws
    the figure twice: a draw with rendering off, to lay it out, then the real one.) The
    figure's dpi, canvas and layout engine are restored on exit.
    """
    import matplotlib
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas, engine, old_dpi = fig.canvas, fig.get_layout_engine(), fig.dpi
    if not isinstance(canvas, FigureCanvasAgg):
        FigureCanvasAgg(fig)
    if dpi != old_dpi:
        fig.set_dpi(dpi)
    try:
        if engine is not None:
            engine.execute(fig)  # with the canvas's renderer, the one the draw reuses
            with matplotlib.rc_context({"figure.autolayout": False,
                                        "figure.constrained_layout.use": False}):
                fig.set_layout_engine(None)
        yield fig
    finally:
        if engine is not None:
            fig.set_layout_engine(engine)
        if dpi != old_dpi:
            fig.set_dpi(old_dpi)
        if fig.canvas is not canvas:
            fig.set_canvas(canvas)


def save_figure(fig, path, dpi: float = DPI) -> Path:
    """
    Write ``fig`` as a PNG at ``path`` atomically (a temporary file renamed into place).

    The figure is laid out once and drawn once by Agg, at ``dpi`` [dots per inch], its text
    unhinted (:func:`unhinted_text`: a text.hinting the user set is kept). An opaque
    figure (every pixel's alpha 1, as the paper's) is written as RGB, without the alpha channel
    that carries nothing (a quarter less to filter and compress); one with transparent pixels as
    RGBA. The PNG is compressed lightly (zlib level 1: the encoding costs a fraction of the
    default's, the file is somewhat larger) and records the resolution and, as matplotlib's
    ``savefig`` does, the software that drew it.
    """
    from radiosim.files import atomic_write

    path = Path(path)
    try:
        with atomic_write(path, "wb") as stream, unhinted_text(), _laid_out(fig, dpi):
            fig.canvas.draw()
            _write_png(stream, fig.canvas.buffer_rgba(), dpi)
    except OSError as exc:
        raise RadiosimIOError(f"cannot write {path}: {exc.strerror or exc}") from None
    return path


def _write_png(stream, rgba, dpi: float) -> None:
    """Encode the Agg buffer ``rgba`` (rows × columns × 4, 8 bits) as a PNG into ``stream``:
    RGB where it is opaque throughout, else RGBA; ``dpi`` [dots per inch] in its pHYs chunk."""
    import matplotlib
    from PIL import Image, PngImagePlugin

    pixels = np.asarray(rgba)
    height, width = pixels.shape[:2]
    image = Image.frombuffer("RGBA", (width, height), pixels, "raw", "RGBA", 0, 1)
    if pixels[..., 3].min() == 255:
        image = image.convert("RGB")
    info = PngImagePlugin.PngInfo()
    info.add_text("Software", f"Matplotlib version{matplotlib.__version__}, "
                  "https://matplotlib.org/")
    image.save(stream, format="png", compress_level=1, pnginfo=info, dpi=(dpi, dpi))

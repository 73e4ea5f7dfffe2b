"""The paper's figures (radiosim.paper.figures) and the plotting helpers they are laid out with:
the same data, titles, labels and legends, every text inside the figure, lines that coincide
kept apart, and a layout drawn once (no layout engine)."""

from types import SimpleNamespace

import numpy as np
import pytest

from radiosim.paper import figures as F
from radiosim.plotting import figure, fixed_axes, save_figure, wrap_text

TIMES = (1.0, 10.0, 25.0, 45.0, 60.0, 75.0, 90.0)
AREAS = (4.0, 16.0, 36.0, 64.0, 100.0, 144.0, 196.0)


def _rows():
    """A study's results rows, two cameras reading alike (the linear and Planck peaks of the
    paper's Figure 5B nearly coincide)."""
    rows = []
    for camera in ("linear", "planck"):
        lift = 0.0 if camera == "linear" else 0.5
        for t in TIMES:
            rows.append({"sweep": "integration-time", "camera": camera, "response": camera,
                         "integration_time_us": t, "sensor_area_um2": 35.0,
                         "peak_C": 740.0 - t + lift, "peak_uncertainty_K": 5.0 + t / 3,
                         "peak_scene_C": 744.0, "column_I_C": 560.0 - 2 * t + lift,
                         "column_I_uncertainty_K": 10.0, "column_I_scene_C": 568.0})
        for a in AREAS:
            rows.append({"sweep": "size-of-source", "camera": camera, "response": camera,
                         "integration_time_us": 0.2, "sensor_area_um2": a,
                         "peak_C": 738.0 - a / 4 + lift / 10, "peak_uncertainty_K": a / 8,
                         "peak_scene_C": 740.0, "column_I_C": 568.0 - a / 10,
                         "column_I_uncertainty_K": 2.0, "column_I_scene_C": 568.3})
    return rows


def _texts_outside(fig):
    """The texts ``fig`` draws (visible, non-empty; tick labels of ticks within their axis's
    view) that reach beyond its edges by more than a pixel."""
    from matplotlib.text import Text

    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    undrawn = set()
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            low, high = sorted(axis.get_view_interval())
            slack = 1e-9 * max(1.0, abs(high - low))
            for loc, tick in zip(axis.get_majorticklocs(), axis.get_major_ticks()):
                if not low - slack <= loc <= high + slack:
                    undrawn.update((id(tick.label1), id(tick.label2)))
    box = fig.bbox
    outside = []
    for text in fig.findobj(Text):
        if not text.get_visible() or not text.get_text().strip() or id(text) in undrawn:
            continue
        extent = text.get_window_extent(renderer)
        if (extent.x0 < box.x0 - 1 or extent.x1 > box.x1 + 1 or extent.y0 < box.y0 - 1
                or extent.y1 > box.y1 + 1):
            outside.append(text.get_text())
    return outside


def test_figure_5_shows_each_camera_and_the_scene_peak_within_the_figure():
    rows = _rows()
    fig = F.plot_peak(rows)
    assert fig.get_layout_engine() is None  # laid out once, by hand: drawn once when saved
    left, right = fig.axes
    title = " ".join(fig.get_suptitle().split())  # wrapped to the figure, same words
    assert title == ("Figure 5, peak temperature: reading of each camera against the scene; "
                     + F.ERROR_BARS)
    assert " ".join(left.get_title().split()) == ("A) Figure 5, peak temperature vs "
                                                  "integration time (9 × 9 × n)")
    assert " ".join(right.get_title().split()) == ("B) Figure 5, peak temperature vs sensor "
                                                   "area (p × p × 1)")
    assert left.get_xlabel() == "integration time [µs]"
    assert right.get_xlabel() == "sensor element area [µm²]"
    assert left.get_ylabel() == right.get_ylabel() == "temperature [°C]"
    for ax in (left, right):
        labels = ax.get_legend_handles_labels()[1]
        assert sorted(labels) == ["linear", "planck", "scene peak"]
    # The same data: each camera's line through its rows' readings, in order of the sweep.
    lines = {c.get_label(): c.lines[0] for c in right.containers}
    assert sorted(lines) == ["linear", "planck"]
    for camera, line in lines.items():
        mine = [r for r in rows if r["sweep"] == "size-of-source" and r["camera"] == camera]
        np.testing.assert_array_equal(np.asarray(line.get_xdata(), float), AREAS)
        np.testing.assert_array_equal(np.asarray(line.get_ydata(), float),
                                      [r["peak_C"] for r in mine])
    # Lines that coincide stay apart: different markers, fills and line styles.
    linear, planck = lines["linear"], lines["planck"]
    assert linear.get_marker() != planck.get_marker()
    assert linear.get_linestyle() != planck.get_linestyle()
    assert "none" in (str(linear.get_markerfacecolor()), str(planck.get_markerfacecolor()))
    assert _texts_outside(fig) == []


def test_figure_7_titles_fit_and_are_wrapped_not_cut():
    fig = F.plot_column_i(_rows())
    assert "Figure 7, shear band peak in Column I" in fig.get_suptitle()
    assert _texts_outside(fig) == []


def test_figure_8_draws_the_history_and_the_readings():
    rows = [{"sweep": "long-integration", "camera": "linear", "response": "linear",
             "integration_time_us": t, "peak_C": 300.0 + t, "peak_uncertainty_K": 100.0 + t}
            for t in (1.0, 45.0, 90.0, 725.0)]
    history = [{"time_us": t, "mean_C": 200.0 + (t % 90)} for t in np.arange(0.0, 725.0, 0.2)]
    fig = F.plot_long_integration(rows, history)
    top, bottom = fig.axes
    assert [line.get_label() for line in top.get_lines()] == [
        "pixel footprint mean, instantaneous (x = time)", "reading (x = integration time)"]
    assert list(bottom.get_lines()[0].get_ydata()) == [101.0, 145.0, 190.0, 825.0]
    assert bottom.get_xlabel() == "time since the event frame's start; integration time [µs]"
    assert _texts_outside(fig) == []


def _measurement(seed, shape=(12, 16), pitch=6e-6):
    rng = np.random.default_rng(seed)
    apparent = 300.0 + 400.0 * rng.random(shape)
    return SimpleNamespace(apparent_temperature=apparent,
                           tensor_max=apparent + 20.0 * rng.random(shape),
                           tensor_std=10.0 * rng.random(shape), shape=shape,
                           camera=SimpleNamespace(fpa=SimpleNamespace(pixel_pitch=pitch)))


def test_the_maps_share_one_colour_scale_per_row_and_label_the_outer_axes(tmp_path):
    cases = [{"exr": f"exr/{i}.exr", "pixel_samples": 9.0, "n_frames": n,
              "integration_time_us": t, "camera": "linear"}
             for i, (n, t) in enumerate(((1, 0.2), (451, 90.0)))]
    cache = {c["exr"]: _measurement(i) for i, c in enumerate(cases)}
    fig = F.plot_maps(tmp_path, [], cases, cache=cache)
    maps = [ax for ax in fig.axes if ax.get_images()]
    bars = [ax for ax in fig.axes if not ax.get_images()]
    assert len(maps) == 6 and len(bars) == 3
    assert sorted(ax.get_ylabel() for ax in bars) == ["apparent temperature [°C]",
                                                      "peak error [K]", "uncertainty [K]"]
    for r in range(3):  # one colour scale per row
        limits = {ax.get_images()[0].get_clim() for ax in maps[2 * r:2 * r + 2]}
        assert len(limits) == 1
    first = maps[0].get_images()[0].get_array()
    np.testing.assert_array_equal(first, cache["exr/0.exr"].apparent_temperature - 273.15)
    assert maps[0].get_ylabel() == "Fig. 9: reading\ny [µm]"
    assert maps[4].get_xlabel() == "x [µm]" and maps[0].get_xlabel() == ""
    assert maps[1].get_yticks().size == 0 and maps[0].get_yticks().size > 0  # outer ticks only
    assert [ax.get_title() for ax in maps[:2]] == ["9×9×1 (0.2 µs, linear)",
                                                   "9×9×451 (90 µs, linear)"]
    assert _texts_outside(fig) == []


def test_wrap_text_keeps_the_words_and_fits_the_width():
    fig = figure(6, 2, layout=None)
    text = "Figure 6: vertical profiles of the camera 'linear' along Columns I–III, one line " \
           "per integration time"
    wrapped = wrap_text(fig, text, 2.0, 9)
    assert wrapped.replace("\n", " ") == text
    from radiosim.plotting import _text_width

    assert all(_text_width(fig, line, 9) <= 2.0 for line in wrapped.splitlines())
    assert wrap_text(fig, "short", 2.0, 9) == "short"


def test_fixed_axes_are_placed_in_inches_and_refuse_no_room():
    fig = figure(10, 5, layout=None)
    left, right = fixed_axes(fig, 1, 2, left=1.0, right=0.5, bottom=0.5, top=1.0, wspace=1.0)
    assert left.get_position().x0 == pytest.approx(0.1)
    assert right.get_position().x1 == pytest.approx(0.95)
    assert (right.get_position().x0 - left.get_position().x1) * 10 == pytest.approx(1.0)
    assert left.get_position().y1 == pytest.approx(0.8)
    from radiosim.errors import RadiosimError

    with pytest.raises(RadiosimError, match="no room"):
        fixed_axes(figure(2, 2, layout=None), 1, 2, left=1.0, right=1.0, bottom=0.5, top=0.5)


def test_save_figure_writes_a_png_of_the_figure_size(tmp_path):
    from PIL import Image

    fig = figure(4, 3, dpi=50, layout=None)
    fig.add_subplot().plot([0, 1], [1, 0])
    path = save_figure(fig, tmp_path / "a.png", dpi=50)
    with Image.open(path) as image:
        assert image.format == "PNG" and image.size == (200, 150)


def test_few_ticks_makes_only_the_ticks_inside_the_limits():
    from matplotlib.ticker import MaxNLocator

    from radiosim.plotting import few_ticks

    fig = figure(4, 3, layout=None)
    ax = few_ticks(fig.add_subplot(), 5, "auto")
    ax.set_xlim(0.3, 9.6)
    ax.set_ylim(-1.7, 2.2)
    assert list(ax.xaxis.get_major_locator()()) == [2, 4, 6, 8]  # 0 and 10 lie outside
    default = MaxNLocator(nbins="auto", steps=[1, 2, 2.5, 5, 10])  # matplotlib's AutoLocator
    default.set_axis(ax.yaxis)
    assert list(ax.yaxis.get_major_locator()()) == [v for v in default() if -1.7 <= v <= 2.2]
    fig.canvas.draw()
    assert len(ax.xaxis.majorTicks) == 4


def test_preload_imports_matplotlib_once_on_a_background_thread():
    from radiosim.plotting import preload

    thread = preload()
    assert preload() is thread and thread.daemon
    thread.join(30)
    assert not thread.is_alive()
    assert F.make_figures.prepare is F.prepare  # a study calls it while it measures


def test_save_figure_writes_the_drawn_pixels_rgb_when_opaque_rgba_when_not(tmp_path):
    from PIL import Image

    fig = figure(2, 1, dpi=40, layout=None)
    fig.add_subplot().plot([0, 1], [1, 0], color="red")
    path = save_figure(fig, tmp_path / "opaque.png", dpi=40)
    drawn = np.asarray(fig.canvas.buffer_rgba())
    assert (drawn[..., 3] == 255).all()
    with Image.open(path) as image:
        assert image.mode == "RGB" and image.size == (80, 40)
        np.testing.assert_array_equal(np.asarray(image), drawn[..., :3])  # the same pixels
        assert image.info["Software"].startswith("Matplotlib version")
        assert image.info["dpi"] == pytest.approx((40, 40), abs=0.01)
    fig.patch.set_alpha(0.0)  # a transparent background keeps its alpha channel
    path = save_figure(fig, tmp_path / "clear.png", dpi=40)
    with Image.open(path) as image:
        assert image.mode == "RGBA"
        np.testing.assert_array_equal(np.asarray(image), np.asarray(fig.canvas.buffer_rgba()))
        assert np.asarray(image)[0, 0, 3] == 0


def test_collector_held_holds_the_collector_and_restores_its_state():
    import gc

    from radiosim.plotting import collector_held

    assert gc.isenabled()
    with collector_held():
        assert not gc.isenabled()
        with collector_held():
            assert not gc.isenabled()
        assert not gc.isenabled()  # the inner exit leaves the outer's hold
    assert gc.isenabled()
    gc.disable()
    try:
        with collector_held():
            assert not gc.isenabled()
        assert not gc.isenabled()  # a collector the caller held off stays off
    finally:
        gc.enable()
    with pytest.raises(ZeroDivisionError):
        with collector_held():
            1 / 0
    assert gc.isenabled()


def _text_png(tmp_path, name, hinting=None):
    """A figure of one line of text saved by save_figure (under rcParams text.hinting
    ``hinting`` when given), and the same figure drawn by matplotlib's own Agg canvas under
    each hinting: (saved pixels, {hinting: pixels})."""
    import matplotlib
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from PIL import Image

    def make():
        fig = figure(2.5, 0.6, dpi=60, layout=None)
        fig.text(0.05, 0.3, "Hinting 0.123 °C", fontsize=11)
        return fig

    drawn = {}
    for h in ("none", "native"):
        with matplotlib.rc_context({"text.hinting": h}):
            canvas = FigureCanvasAgg(make())
            canvas.draw()
            drawn[h] = np.asarray(canvas.buffer_rgba())[..., :3].copy()
    # matplotlib's default (e.g. a runner's matplotlibrc may set another), or the user's
    unset = matplotlib.rcParamsDefault["text.hinting"]
    with matplotlib.rc_context({"text.hinting": hinting or unset}):
        path = save_figure(make(), tmp_path / name, dpi=60)
        assert matplotlib.rcParams["text.hinting"] == (hinting or unset)  # restored
    with Image.open(path) as image:
        return np.asarray(image), drawn


def test_save_figure_draws_text_unhinted_unless_the_user_set_a_hinting(tmp_path):
    import matplotlib

    before = matplotlib.rcParams["text.hinting"]
    saved, drawn = _text_png(tmp_path, "default.png")
    assert not np.array_equal(drawn["none"], drawn["native"])  # the test can tell them apart
    np.testing.assert_array_equal(saved, drawn["none"])
    assert matplotlib.rcParams["text.hinting"] == before
    saved, drawn = _text_png(tmp_path, "native.png", hinting="native")  # the user's setting
    np.testing.assert_array_equal(saved, drawn["native"])

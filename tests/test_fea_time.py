"""FEA time done right: a field linear in space and in time, written as an XDMF series and as
a ParaView collection whose first time stamp is off the frame grid, measured against the exact
averages (sample-and-hold, and linear in time) computed here from the field's own formula."""

import meshio
import numpy as np
import pytest
from scipy.spatial import Delaunay

from conftest import one_line_naming
from radiosim import Camera
from radiosim.errors import RadiosimError
from radiosim.io import read_fea_mesh

T0, STEP, N = 0.3, 1.0, 6  # first time stamp, snapshot step [µs], snapshots: t0 off the grid
PITCH = 4.0  # pixel pitch [µm]; the mesh covers 0–20 µm, the scene's samples are 1 µm


def field(x, y, t):
    """400 K + 3 K/µm · x + 2 K/µm · y + 50 K/µs · t (x, y in µm, t in µs) [K]."""
    return 400.0 + 3.0 * x + 2.0 * y + 50.0 * t


def times():
    return [T0 + k * STEP for k in range(N)]


def write(folder, kind, values=field):
    """The series as ``kind`` ('xdmf' or 'pvd'), node values ``values(x, y, t)`` [K]."""
    g = np.arange(0.0, 20.0 + 1e-9, 2.5)
    x, y = (a.ravel() for a in np.meshgrid(g, g))
    points = np.column_stack([x, y, np.zeros(x.size)])
    cells = [("triangle", Delaunay(points[:, :2]).simplices)]
    if kind == "xdmf":
        path = folder / "series.xdmf"
        with meshio.xdmf.TimeSeriesWriter(path) as writer:
            writer.write_points_cells(points, cells)
            for t in times():
                writer.write_data(t, point_data={"temperature": values(x, y, t)})
        return path
    entries = []
    for k, t in enumerate(times()):
        meshio.write(folder / f"s{k}.vtu", meshio.Mesh(
            points, cells, point_data={"temperature": values(x, y, t)}))
        entries.append(f'<DataSet timestep="{t!r}" file="s{k}.vtu"/>')
    path = folder / "series.pvd"
    path.write_text('<?xml version="1.0"?><VTKFile type="Collection"><Collection>'
                    + "".join(entries) + "</Collection></VTKFile>")
    return path


def read(path, **kwargs):
    return read_fea_mesh(path, dx=1e-6, units={"length": "um", "time": "us",
                                               "temperature": "K"}, **kwargs)


def pixel_centres():
    """The 5 × 5 pixels' centres (x, y) [µm]: row 0 at the top (y = 20 µm)."""
    centre = (np.arange(5) + 0.5) * PITCH
    return np.meshgrid(centre, 20.0 - centre)


def hold_mean(a, b):
    """The exact mean time of the sample-and-hold field over [a, b] µs: snapshot j holds its
    time t_j over [t_j, t_j + step)."""
    return sum(max(0.0, min(b, t + STEP) - max(a, t)) * t for t in times()) / (b - a)


@pytest.fixture(params=["xdmf", "pvd"])
def series(request, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # meshio writes the XDMF series' HDF5 file in the working folder
    return write(tmp_path, request.param)


@pytest.mark.parametrize("start, duration", [
    (T0, 1.0),          # from the first time stamp: refused before
    (T0, 2.5),
    (T0 + 0.5, 1.0),    # one step across two snapshots: 0.21/0.58/0.21 of three before
    (2.0, 1.7),
    (T0 + 4.75, 1.25),  # to the last snapshot's end
])
def test_hold_gives_the_exact_sample_and_hold_average_off_the_frame_grid(series, start,
                                                                          duration):
    scene = read(series)
    assert scene.t0 == pytest.approx(T0 * 1e-6) and scene.frame_origin == pytest.approx(
        T0 * 1e-6)
    x, y = pixel_centres()
    m = Camera.linear_ideal(PITCH * 1e-6).measure(scene, duration * 1e-6,
                                                  t_start=start * 1e-6)
    expected = field(x, y, hold_mean(start, start + duration))
    # The mesh holds the field exactly (linear in space), the pixel mean of a linear field
    # is its value at the centre: only rounding is left.
    np.testing.assert_allclose(m.apparent_temperature, expected, rtol=1e-11)
    assert m.t_start == pytest.approx(start * 1e-6, rel=1e-12)


def test_a_frame_of_the_hold_mode_is_one_snapshot(series):
    scene = read(series)
    x, y = pixel_centres()
    for j, t in enumerate(times()):
        frame = scene.frame(scene.first_frame + j)  # the scene's 1 µm samples
        sample = frame[2, 3]  # (x, y) = (3.5, 17.5) µm
        assert sample == pytest.approx(field(3.5, 17.5, t), rel=1e-12)


def test_no_start_given_starts_at_the_first_time_stamp_and_before_it_is_refused(series):
    scene = read(series)
    m = Camera.linear_ideal(PITCH * 1e-6).measure(scene, 1e-6)
    assert m.t_start == pytest.approx(T0 * 1e-6, rel=1e-12)
    with pytest.raises(RadiosimError) as info:
        Camera.linear_ideal(PITCH * 1e-6).measure(scene, 1e-6, t_start=0.1e-6)
    one_line_naming(info, "before", "0.3 µs")


@pytest.mark.parametrize("start, duration", [
    (T0, 2.0),           # frame edges
    (T0 + 1.0, 3.0),
    (T0 + 0.37, 3.0),    # a whole number of frames from anywhere: the two ends cancel
    (T0 + 1.61, 1.0),
])
def test_linear_is_exact_for_a_field_linear_in_time_on_whole_frames(series, start, duration):
    scene = read(series, interpolation="linear")
    x, y = pixel_centres()
    m = Camera.linear_ideal(PITCH * 1e-6).measure(scene, duration * 1e-6,
                                                  t_start=start * 1e-6)
    # A field linear in time: its mean over [a, b] is its value at the middle.
    np.testing.assert_allclose(m.apparent_temperature,
                               field(x, y, start + duration / 2), rtol=1e-11)


@pytest.mark.parametrize("dt", [None, 0.25])
def test_linear_off_the_frame_edges_is_within_the_stated_bound(series, dt):
    """Start 0.25 of a frame after an edge, a window of 1.25 frames: the ends' pieces (0.75
    and 0.5 of a frame) are taken at their frames' means; the documented bound is
    |∂T/∂t| · dt² / (4 · t_int), and the error here is s·(0.5·0.5 − 0.75·0.25)·dt²/2/t_int."""
    scene = read(series, interpolation="linear", dt=None if dt is None else dt * 1e-6)
    frame = STEP if dt is None else dt
    start, duration = T0 + 0.25 * frame, 1.25 * frame
    x, y = pixel_centres()
    m = Camera.linear_ideal(PITCH * 1e-6).measure(scene, duration * 1e-6,
                                                  t_start=start * 1e-6)
    error = m.apparent_temperature - field(x, y, start + duration / 2)
    slope = 50.0  # [K/µs]
    bound = slope * frame**2 / (4 * duration)
    expected = slope * (0.5 * 0.5 - 0.75 * 0.25) * frame**2 / 2 / duration
    np.testing.assert_allclose(error, expected, rtol=1e-6, atol=1e-9)
    assert 0 < expected <= bound


def test_linear_frames_straddling_snapshots_are_the_exact_frame_means(tmp_path, monkeypatch):
    """A field curved in time (50 K/µs² · t² at the nodes), frames of 0.4 steps that straddle
    the snapshots: each frame is the mean of the piecewise-linear field over its interval,
    against a fine trapezoid quadrature of numpy's interpolation."""
    monkeypatch.chdir(tmp_path)
    path = write(tmp_path, "xdmf", values=lambda x, y, t: 400.0 + 50.0 * t**2 + 0 * x)
    scene = read(path, interpolation="linear", dt=0.4e-6)
    t_nodes = np.array(times())
    for k in range(scene.first_frame, scene.n_frames):
        a = scene.frame_start(k) * 1e6
        t = np.linspace(a, a + 0.4, 4001)
        piecewise = np.interp(t, t_nodes, 400.0 + 50.0 * t_nodes**2)
        reference = np.trapezoid(piecewise, t) / 0.4
        assert scene.frame(k)[5, 5] == pytest.approx(reference, rel=1e-7)


def test_a_series_with_a_time_stamp_twice_is_refused(tmp_path):
    entries = "".join(f'<DataSet timestep="{t}" file="s{k}.vtu"/>'
                      for k, t in enumerate((0.0, 1.0, 1.0, 2.0)))
    g = np.arange(0.0, 10.0 + 1e-9, 5.0)
    x, y = (a.ravel() for a in np.meshgrid(g, g))
    points = np.column_stack([x, y, np.zeros(x.size)])
    for k in range(4):
        meshio.write(tmp_path / f"s{k}.vtu", meshio.Mesh(
            points, [("triangle", Delaunay(points[:, :2]).simplices)],
            point_data={"temperature": np.full(x.size, 500.0)}))
    (tmp_path / "run.pvd").write_text('<?xml version="1.0"?><VTKFile type="Collection">'
                                      f"<Collection>{entries}</Collection></VTKFile>")
    with pytest.raises(RadiosimError) as info:
        read(tmp_path / "run.pvd")
    one_line_naming(info, "run.pvd", "1 µs", "twice")


def test_a_csv_giving_one_time_stamp_to_two_node_sets_is_refused(tmp_path):
    """Two blocks of nodes both labelled t = 0 (the second step's time mistyped) were merged
    into one step (705 K from 510 K and 900 K); a file grouped by node is still read."""
    from radiosim.io import read_fea_nodes

    header = "# units: time=us, length=um, temperature=K\ntime,x,y,temperature\n"
    nodes = [(0, 0), (10, 0), (0, 10), (10, 10)]
    block = lambda t, temp: "".join(f"{t},{x},{y},{temp}\n" for x, y in nodes)  # noqa: E731
    path = tmp_path / "nodes.csv"
    path.write_text(header + block(0, 510.0) + block(1, 600.0) + block(0, 900.0))
    with pytest.raises(RadiosimError) as info:
        read_fea_nodes(path, dx=1e-6, dt=1e-6)
    one_line_naming(info, "nodes.csv", "time stamp 0 µs", "rows 1 and 9")
    by_node = "".join(f"{t},{x},{y},{500.0 + 100 * t}\n" for x, y in nodes for t in (0, 1, 2))
    path.write_text(header + by_node)
    scene = read_fea_nodes(path, dx=1e-6)
    assert scene.frame(1)[5, 5] == pytest.approx(600.0)

"""FEA meshes through meshio, resampled on their own cells."""


from pathlib import Path

import meshio
import numpy as np
import pytest
from scipy.interpolate import LinearNDInterpolator
from scipy.spatial import Delaunay

import radiosim as rs
from conftest import one_line_naming
from radiosim import Camera
from radiosim.errors import RadiosimError
from radiosim.io import read_fea_mesh

SIGMA, SPEED = 20.0, 5.0  # [µm], [µm/µs]


def field(x, y, t):
    """An analytic band moving along x [K], coordinates in µm, time in µs."""
    return 300.0 + 400.0 * np.exp(-((x - 40.0 - SPEED * t) ** 2 + (y - 50.0) ** 2)
                                  / (2 * SIGMA**2))


def mesh_points(step: float, jitter: int = 0):
    """A perturbed grid of nodes over 0–100 µm (its Delaunay triangles are the mesh)."""
    g = np.arange(0.0, 100.0 + step / 2, step)
    x, y = np.meshgrid(g, g)
    rng = np.random.default_rng(jitter)
    inner = (x > 0) & (x < 100) & (y > 0) & (y < 100)
    x = x + inner * rng.uniform(-0.2, 0.2, x.shape) * step
    y = y + inner * rng.uniform(-0.2, 0.2, y.shape) * step
    return np.column_stack([x.ravel(), y.ravel()])


def write_series(folder, times, step=5.0, moving=False):
    files = []
    for k, t in enumerate(times):
        points = mesh_points(step, jitter=k if moving else 0)  # remeshed when moving
        triangles = Delaunay(points).simplices
        values = field(points[:, 0], points[:, 1], t)
        path = folder / f"step_{k:03d}.vtu"
        meshio.write(path, meshio.Mesh(np.column_stack([points, np.zeros(len(points))]),
                                       [("triangle", triangles)],
                                       point_data={"temperature": values}))
        files.append((path, points, triangles, values))
    return files


def test_a_vtu_series_resamples_to_its_field_and_to_scipys_interpolation(tmp_path):
    """Inside each triangle the scene is the linear interpolation of its nodes: it equals
    scipy's LinearNDInterpolator on the same (Delaunay) triangles to rounding, and the
    analytic field within the linear-interpolation bound R²·M/2 (R the largest circumradius,
    ≈ 0.7·1.4 h for these perturbed cells, M the field's largest second derivative)."""
    times = [0.0, 1.0, 2.0]
    files = write_series(tmp_path, times, moving=True)
    scene = read_fea_mesh([f[0] for f in files], dx=1e-6, times=[t * 1e-6 for t in times],
                          units={"length": "um", "temperature": "K"}, fill=250.0)
    assert scene.shape == (100, 100) and scene.n_frames == 3 and scene.dt == pytest.approx(1e-6)
    x = (np.arange(100) + 0.5)
    y = 100.0 - (np.arange(100) + 0.5)
    gx, gy = np.meshgrid(x, y)
    h = 5.0 * 1.4  # longest edge of a perturbed 5 µm cell [µm]
    second = 400.0 / SIGMA**2  # max |∂²T| of the Gaussian band [K/µm²]
    bound = (0.75 * h) ** 2 * second / 2
    for k, (path, points, triangles, values) in enumerate(files):
        frame = scene.frame(k)
        reference = LinearNDInterpolator(Delaunay(points), values)(gx, gy)
        np.testing.assert_allclose(frame, reference, rtol=1e-12)
        assert np.max(np.abs(frame - field(gx, gy, times[k]))) < bound


def test_cell_data_quads_and_a_paraview_collection(tmp_path):
    """Quads split in two triangles carry their cell's value; a .pvd lists the steps."""
    g = np.arange(0.0, 60.0 + 1e-9, 10.0)
    x, y = np.meshgrid(g, g)
    points = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    n = g.size
    quads = np.array([[i * n + j, i * n + j + 1, (i + 1) * n + j + 1, (i + 1) * n + j]
                      for i in range(n - 1) for j in range(n - 1)])
    entries = []
    for k in range(2):
        cell_t = 400.0 + 10.0 * np.arange(len(quads)) + 100.0 * k  # [°C] per cell
        meshio.write(tmp_path / f"q{k}.vtu", meshio.Mesh(points, [("quad", quads)],
                                                       cell_data={"T_C": [cell_t]}))
        entries.append(f'<DataSet timestep="{0.5 * k}" file="q{k}.vtu"/>')
    (tmp_path / "run.pvd").write_text('<?xml version="1.0"?><VTKFile type="Collection">'
                                      f'<Collection>{"".join(entries)}</Collection></VTKFile>')
    scene = read_fea_mesh(tmp_path / "run.pvd", dx=1e-6, field="T_C",
                          units={"length": "um", "time": "us"})
    assert scene.dt == pytest.approx(0.5e-6) and scene.shape == (60, 60)
    frame = scene.frame(1)
    # The sample at (x, y) = (15.5, 44.5) µm lies in quad (row 4, column 1) of the mesh.
    row, col = int(60 - 44.5), 15
    cell = 4 * (n - 1) + 1
    assert frame[row, col] == pytest.approx(400.0 + 10 * cell + 100 + 273.15)


def test_an_xdmf_time_series(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # meshio writes the series' HDF5 file in the working folder
    points = mesh_points(10.0)
    triangles = Delaunay(points).simplices
    path = tmp_path / "series.xdmf"
    with meshio.xdmf.TimeSeriesWriter(path) as writer:
        writer.write_points_cells(np.column_stack([points, np.zeros(len(points))]),
                                  [("triangle", triangles)])
        for t in (0.0, 2.0, 4.0):
            writer.write_data(t, point_data={"temperature": field(points[:, 0], points[:, 1],
                                                                 t)})
    scene = read_fea_mesh(path, dx=2e-6, units={"length": "um", "time": "us",
                                                "temperature": "K"})
    assert scene.n_frames == 3 and scene.dt == pytest.approx(2e-6) and scene.shape == (50, 50)
    m = rs.Camera.linear_ideal(10e-6).measure(scene, 2e-6, t_start=0.0)
    # The window [0, 2) µs is the first step, held: samples at the centres of 2 µm squares
    # (row 0 at the top, y = 100 µm), each 10 µm pixel a block of 5 × 5 of them. The scene is
    # the mesh's linear interpolation: scipy's on the same triangles gives each pixel's mean
    # and maximum exactly (rounding: 1e-12 relative).
    x = (np.arange(50) + 0.5) * 2.0
    gx, gy = np.meshgrid(x, 100.0 - x)
    interpolated = LinearNDInterpolator(Delaunay(points), field(points[:, 0], points[:, 1],
                                                                0.0))(gx, gy)
    blocks = interpolated.reshape(10, 5, 10, 5)
    np.testing.assert_allclose(m.tensor_max, blocks.max(axis=(1, 3)), rtol=1e-12)
    np.testing.assert_allclose(m.apparent_temperature, blocks.mean(axis=(1, 3)), rtol=1e-12)
    # And the analytic field itself, within the linear-interpolation bound R²·M/2 of these
    # 10 µm cells (R ≤ 0.75 · 1.4 · 10 µm, M = 400/σ² K/µm²: 55 K): its hottest sample,
    # 300 + 400 exp(−2/(2σ²)) = 699.0 K at (39 or 41, 49 or 51) µm, and every pixel's mean.
    # (Step 1 or 2 instead, the band 10 or 20 µm further, fails the exact check above by
    # tens of kelvins.)
    exact = field(gx, gy, 0.0).reshape(10, 5, 10, 5)
    assert exact.max() == pytest.approx(300 + 400 * np.exp(-1 / SIGMA**2), rel=1e-14)
    bound = (0.75 * 1.4 * 10.0) ** 2 * (400.0 / SIGMA**2) / 2
    assert abs(m.tensor_max.max() - exact.max()) < bound
    assert np.max(np.abs(m.apparent_temperature - exact.mean(axis=(1, 3)))) < bound


def test_times_contradicting_an_xdmf_series_own_are_refused(tmp_path, monkeypatch):
    # The series states its times (0, 2, 4 µs): the same given again are fine, others (a
    # wrong step, or too few) are refused in one line naming both (they were ignored).
    monkeypatch.chdir(tmp_path)
    points = mesh_points(10.0)
    path = tmp_path / "series.xdmf"
    with meshio.xdmf.TimeSeriesWriter(path) as writer:
        writer.write_points_cells(np.column_stack([points, np.zeros(len(points))]),
                                  [("triangle", Delaunay(points).simplices)])
        for t in (0.0, 2.0, 4.0):
            writer.write_data(t, point_data={"temperature": field(points[:, 0], points[:, 1],
                                                                 t)})
    units = {"length": "um", "time": "us", "temperature": "K"}
    read_fea_mesh(path, dx=2e-6, units=units, times=[0.0, 2e-6, 4e-6])
    for wrong in ([0.0, 3e-6, 6e-6], [0.0, 2e-6]):
        with pytest.raises(RadiosimError, match=r"contradict the file's own times") as info:
            read_fea_mesh(path, dx=2e-6, units=units, times=wrong)
        assert "\n" not in str(info.value)


@pytest.mark.parametrize("kwargs, message", [
    (dict(units={"temperature": "K"}), "length unit"),
    (dict(units={"length": "um"}), "temperature unit"),
    (dict(units={"length": "um", "temperature": "K"}, field="T"), "no field 'T'"),
    (dict(units={"length": "um", "temperature": "K"}, times=[0.0]), "needs times"),
    (dict(units={"length": "um", "temperature": "F"}), "not one of"),
])
def test_bad_meshes_and_units_are_named(tmp_path, kwargs, message):
    files = write_series(tmp_path, [0.0, 1.0])
    kwargs = {"times": [0.0, 1e-6], **kwargs}
    with pytest.raises(RadiosimError, match=message):
        read_fea_mesh([f[0] for f in files], dx=1e-6, **kwargs)


def test_a_broken_mesh_file_is_one_line(tmp_path):
    (tmp_path / "bad.vtu").write_text("<VTKFile>not a mesh")
    with pytest.raises(RadiosimError, match="cannot read FEA mesh"):
        read_fea_mesh([tmp_path / "bad.vtu", tmp_path / "bad.vtu"], dx=1e-6, times=[0, 1e-6],
                      units={"length": "um", "temperature": "K"})


# -- edges: vector fields, NaN nodes and times, unit contradictions, the time origin ---------------


def mesh_files(folder, times, values=None, point_data=None, points=None):
    g = np.arange(0.0, 10.0 + 1e-9, 2.0)
    x, y = np.meshgrid(g, g)
    xy = np.column_stack([x.ravel(), y.ravel()]) if points is None else points
    triangles = Delaunay(np.column_stack([x.ravel(), y.ravel()])).simplices
    files = []
    for k, t in enumerate(times):
        data = point_data(k) if point_data else {
            "temperature": np.full(len(xy), values(t) if values else 500.0)}
        path = Path(folder) / f"step_{k}.vtu"
        meshio.write(path, meshio.Mesh(np.column_stack([xy, np.zeros(len(xy))]),
                                       [("triangle", triangles)], point_data=data))
        files.append(path)
    return files


def test_mesh_a_vector_field_as_temperature_is_refused(tmp_path):
    files = mesh_files(tmp_path, [0.0, 1.0],
                       point_data=lambda k: {"temperature": np.full((36, 3), 500.0)})
    with pytest.raises(RadiosimError) as info:
        read_fea_mesh(files, dx=1e-6, times=[0.0, 1e-6],
                      units={"length": "um", "temperature": "K"})
    one_line_naming(info, "'temperature'", "(36, 3)", "3 components")


def test_mesh_nan_coordinates_are_refused(tmp_path):
    g = np.arange(0.0, 10.0 + 1e-9, 2.0)
    x, y = np.meshgrid(g, g)
    points = np.column_stack([x.ravel(), y.ravel()])
    points[7, 0] = np.nan
    files = mesh_files(tmp_path, [0.0, 1.0], points=points)
    with pytest.raises(RadiosimError) as info:
        read_fea_mesh(files, dx=1e-6, times=[0.0, 1e-6],
                      units={"length": "um", "temperature": "K"})
    one_line_naming(info, "step 0", "node 7", "nan")


def test_mesh_a_nan_time_is_refused(tmp_path):
    files = mesh_files(tmp_path, [0.0, 1.0])
    with pytest.raises(RadiosimError) as info:
        read_fea_mesh(files, dx=1e-6, times=[0.0, float("nan")],
                      units={"length": "um", "temperature": "K"})
    one_line_naming(info, "step 1", "nan")


def test_mesh_a_unit_that_contradicts_the_fields_name_is_refused(tmp_path):
    files = mesh_files(tmp_path, [0.0, 1.0],
                       point_data=lambda k: {"temperature_C": np.full(36, 500.0)})
    with pytest.raises(RadiosimError) as info:
        read_fea_mesh(files, dx=1e-6, times=[0.0, 1e-6], field="temperature_C",
                      units={"length": "um", "temperature": "K"})
    one_line_naming(info, "temperature=K", "'temperature_C'", "in C")


def ramp(t_us):
    """A field linear in time: 300 K + 100 K/µs · t, the same at every node [K]."""
    return 300.0 + 100.0 * t_us


def test_mesh_keeps_its_origin_and_interpolates_linearly(tmp_path):
    files = mesh_files(tmp_path, [5.0, 6.0, 7.0], values=ramp)
    scene = read_fea_mesh(files, dx=1e-6, times=[5e-6, 6e-6, 7e-6],
                          units={"length": "um", "temperature": "K"}, interpolation="linear",
                          dt=0.5e-6)
    assert scene.t0 == pytest.approx(5e-6) and scene.first_frame == 10
    np.testing.assert_allclose(scene.frame(11), ramp(5.75), rtol=1e-12)
    m = Camera.linear_ideal(2e-6).measure(scene, 1e-6, t_start=5.5e-6)
    np.testing.assert_allclose(m.apparent_temperature, ramp(6.0), rtol=1e-12)

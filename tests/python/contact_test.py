"""Contact area from Python (python/contact.cpp) against closed forms: a ball of radius R held at
gap g above a flat insert leaves the insert closer than t to the ball on the disc
r^2 < (R+t)^2 - (R+g)^2, so S = pi ((R+t)^2 - (R+g)^2), split in half by the medial/lateral plane,
each half disc's centroid 4 r_t / (3 pi) from the diameter; sinking at speed v, dS/dt = 2 pi (R+g) v.
The meshes are built here with NumPy. The discretisation error is bounded as in
tests/contact/contact_area_test.cpp: the faceted ball lies up to its sag e = R (1 - cos(pi/nlat))
inside the true one and linear interpolation over insert cells of diagonal h misplaces the level
line by at most h^2 / (8 (R+g)); either moves the area by about 2 pi (R+t) times that distance."""

import math
import shutil

import numpy as np
import pytest

import kneesim
from conftest import source_path

R = 0.02     # ball radius (m)
H = 0.5e-3   # insert grid step (m)
NLAT, NLON = 90, 180


def flat_insert(x0=-0.02, x1=0.02, z0=-0.03, z1=0.03, bottom=-0.01):
    """A closed block whose top y = 0 is a grid of step H, outward-oriented."""
    xs, zs = np.linspace(x0, x1, round((x1 - x0) / H) + 1), np.linspace(z0, z1, round((z1 - z0) / H) + 1)
    nx, nz = len(xs), len(zs)
    X, Z = np.meshgrid(xs, zs, indexing="ij")
    top = np.column_stack([X.ravel(), np.zeros(X.size), Z.ravel()])
    bot = top.copy()
    bot[:, 1] = bottom
    v = np.vstack([top, bot])
    T = lambda i, k: i * nz + k
    B = lambda i, k: nx * nz + i * nz + k
    tris = []
    for i in range(nx - 1):
        for k in range(nz - 1):
            tris += [(T(i, k), T(i, k + 1), T(i + 1, k + 1)), (T(i, k), T(i + 1, k + 1), T(i + 1, k)),
                     (B(i, k), B(i + 1, k + 1), B(i, k + 1)), (B(i, k), B(i + 1, k), B(i + 1, k + 1))]
    for i in range(nx - 1):
        tris += [(T(i, 0), T(i + 1, 0), B(i + 1, 0)), (T(i, 0), B(i + 1, 0), B(i, 0)),
                 (T(i, nz - 1), B(i + 1, nz - 1), T(i + 1, nz - 1)), (T(i, nz - 1), B(i, nz - 1), B(i + 1, nz - 1))]
    for k in range(nz - 1):
        tris += [(T(0, k), B(0, k + 1), T(0, k + 1)), (T(0, k), B(0, k), B(0, k + 1)),
                 (T(nx - 1, k), T(nx - 1, k + 1), B(nx - 1, k + 1)), (T(nx - 1, k), B(nx - 1, k + 1), B(nx - 1, k))]
    return v, np.array(tris)


def ball(r=R, nlat=NLAT, nlon=NLON):
    """A UV sphere centred at the origin, poles along y, vertices on the sphere, outward-oriented."""
    v = [(0.0, -r, 0.0)]
    for i in range(1, nlat):
        t = -math.pi / 2 + math.pi * i / nlat
        for j in range(nlon):
            p = 2 * math.pi * j / nlon
            v.append((r * math.cos(t) * math.cos(p), r * math.sin(t), r * math.cos(t) * math.sin(p)))
    v.append((0.0, r, 0.0))
    north = len(v) - 1
    ring = lambda i, j: 1 + (i - 1) * nlon + (j % nlon)
    tris = [(0, ring(1, j), ring(1, j + 1)) for j in range(nlon)]
    for i in range(1, nlat - 1):
        for j in range(nlon):
            tris += [(ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)), (ring(i, j), ring(i + 1, j + 1), ring(i, j + 1))]
    tris += [(north, ring(nlat - 1, j + 1), ring(nlat - 1, j)) for j in range(nlon)]
    return np.array(v), np.array(tris)


def signed_volume(v, t):
    a, b, c = v[t[:, 0]], v[t[:, 1]], v[t[:, 2]]
    return np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6


def write_stl(path, v, t):
    """A binary STL, written without kneesim."""
    rec = np.zeros(len(t), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    rec["v"] = v[t]
    with open(path, "wb") as f:
        f.write(b"\0" * 80 + np.uint32(len(t)).tobytes() + rec.tobytes())


def disc_area(t, g):
    return math.pi * ((R + t) ** 2 - (R + g) ** 2)


def area_bound(t, g):
    sag = R * (1 - math.cos(math.pi / NLAT))
    h = math.sqrt(2) * H
    return 2 * math.pi * (R + t) * (sag + h * h / (8 * (R + g)))


def translation(p):
    X = np.eye(4)
    X[:3, 3] = p
    return X


@pytest.fixture(scope="module")
def meshes():
    insert, femur = flat_insert(), ball()
    assert signed_volume(*insert) > 0 and signed_volume(*femur) > 0
    return insert, femur


def test_contact_area_of_a_pose_matches_the_disc(meshes):
    insert, femur = meshes
    area = kneesim.ContactArea(insert, femur, extra_thresholds=[2e-3, 6e-3])
    assert area.distance_method == "fcl" and area.threshold == 4e-3
    # The top face but its outermost ring of cells (the rim's normals lean past 75 degrees).
    assert area.articular_area == pytest.approx(0.039 * 0.059, abs=1e-12)
    sag = R * (1 - math.cos(math.pi / NLAT))
    for g in (1e-3, 0.0, -1.2e-3):
        x0 = np.array([1.5e-3, R + g, 0.0])  # the ball's lowest vertex over a grid node
        f = area.calc_pose(translation(x0))
        assert f["S"] == pytest.approx(disc_area(4e-3, g), abs=area_bound(4e-3, g))
        assert f["S@2mm"] == pytest.approx(disc_area(2e-3, g), abs=area_bound(2e-3, g))
        assert f["S@6mm"] == pytest.approx(disc_area(6e-3, g), abs=area_bound(6e-3, g))
        assert f["S_medial"] == pytest.approx(f["S"] / 2, abs=area_bound(4e-3, g) / 2)
        assert f["S_medial"] + f["S_lateral"] == pytest.approx(f["S"], abs=1e-15)
        assert f["dmin"] == pytest.approx(g, abs=sag if g < 0 else 1e-9)
        r_t = math.sqrt((R + 4e-3) ** 2 - (R + g) ** 2)
        c = 4 * r_t / (3 * math.pi)
        tol = area_bound(4e-3, g) / f["S"] * r_t
        np.testing.assert_allclose(f["centroid_medial"], [x0[0], 0, c], atol=tol)  # medial = +z
        np.testing.assert_allclose(f["centroid_lateral"], [x0[0], 0, -c], atol=tol)
    far = area.calc_pose(translation([0, R + 5e-3, 0]))
    assert far["S"] == 0 and np.isnan(far["centroid_medial"]).all()
    # The exact MeshDistance agrees with the fcl plugin.
    exact = kneesim.ContactArea(insert, femur, distance="MeshDistance").calc_pose(translation([1.5e-3, R, 0]))
    assert exact["S"] == pytest.approx(area.calc_pose(translation([1.5e-3, R, 0]))["S"], rel=1e-9)


def test_contact_area_of_a_motion_matches_the_sinking_ball(meshes):
    insert, femur = meshes
    area = kneesim.ContactArea(insert, femur)
    v = 5e-3  # m/s
    time = np.linspace(0, 0.4, 9)
    gaps = 1e-3 - v * time
    poses = np.stack([translation([1.5e-3, R + g, 0]) for g in gaps])
    ch = area.calc_motion(poses, time=time)
    np.testing.assert_array_equal(ch["time"], time)
    for k, g in enumerate(gaps):
        assert ch["S"][k] == pytest.approx(disc_area(4e-3, g), abs=area_bound(4e-3, g))
        assert ch["dmin"][k] == pytest.approx(g, abs=R * (1 - math.cos(math.pi / NLAT)) if g < 0 else 1e-9)
    # Central differences in the middle: dS/dt = 2 pi (R + g) v within 3 %.
    assert ch["dS_dt"][4] == pytest.approx(2 * math.pi * (R + gaps[4]) * v, rel=0.03)


def scene(tmp_path, meshes):
    """The contact-area tool's ModelKinematics case (tests/tool/fixtures/README.md): the ball on a
    slider over the insert, X_IF = (I, (0.001, 0.025 + lift, 0)), so g = lift + 5 mm."""
    insert, femur = meshes
    write_stl(tmp_path / "flat_insert.stl", *insert)
    write_stl(tmp_path / "ball.stl", *femur)
    shutil.copy(source_path("tests/tool/fixtures/slider_knee.osim"), tmp_path / "slider_knee.osim")
    lifts = -0.004 - 0.0005 * np.arange(5)  # g = 1 mm .. -1 mm
    rows = "".join(f"{0.1 * k:.1f}\t{lift:.6f}\n" for k, lift in enumerate(lifts))
    (tmp_path / "lowering.mot").write_text(
        f"lowering\nversion=1\nnRows=5\nnColumns=2\ninDegrees=yes\nendheader\ntime\tlift\n{rows}")
    setup = tmp_path / "setup.xml"
    setup.write_text("""<ContactAreaTool name="slider">
  <femoral_component_file>ball.stl</femoral_component_file>
  <insert_file>flat_insert.stl</insert_file>
  <extra_thresholds>0.002 0.006</extra_thresholds>
  <ModelKinematics>
    <model_file>slider_knee.osim</model_file>
    <motion_file>lowering.mot</motion_file>
    <femoral_body>femur</femoral_body>
    <insert_body>tray</insert_body>
    <femoral_mesh>ball</femoral_mesh>
    <insert_mesh>flat_insert</insert_mesh>
  </ModelKinematics>
  <results_directory>out</results_directory>
</ContactAreaTool>
""")
    return setup, lifts


def test_run_contact_area_from_a_setup_file(tmp_path, meshes):
    setup, lifts = scene(tmp_path, meshes)
    r = kneesim.run_contact_area(str(setup))
    ch = r["channels"]
    np.testing.assert_allclose(ch["time"], 0.1 * np.arange(5), atol=1e-12)
    for k, lift in enumerate(lifts):
        g = lift + 0.005
        np.testing.assert_allclose(r["X_IF"][k], translation([0.001, 0.025 + lift, 0]), atol=1e-12)
        # STL coordinates are single precision: 1e-9 m more or less moves the area by ~1e-10 m^2.
        assert ch["S"][k] == pytest.approx(disc_area(4e-3, g), abs=area_bound(4e-3, g) + 1e-9)
        assert ch["S@6mm"][k] == pytest.approx(disc_area(6e-3, g), abs=area_bound(6e-3, g) + 1e-9)
    assert r["outputs"] == [str(tmp_path / "out" / "slider_contact_area.sto")]
    written = kneesim.read_storage(r["outputs"][0])
    np.testing.assert_allclose(written.column("S"), ch["S"], rtol=1e-8, atol=1e-12)
    # The same meshes and options through ContactArea.from_setup, one pose at a time.
    area = kneesim.ContactArea.from_setup(str(setup))
    assert area.calc_pose(r["X_IF"][2])["S"] == pytest.approx(ch["S"][2], rel=1e-12)


def test_contact_area_errors_are_input_errors(tmp_path, meshes):
    insert, femur = meshes
    v, t = femur
    with pytest.raises(kneesim.InputError, match=r"^ContactArea/femur: expected a closed, outward-oriented surface, got 3 open edges"):
        kneesim.ContactArea(insert, (v, t[1:]))
    with pytest.raises(kneesim.InputError, match=r"^ContactArea/femur: expected a closed, outward-oriented surface, got 0 open edges and a signed volume of -"):
        kneesim.ContactArea(insert, (v, t[:, ::-1]))
    with pytest.raises(kneesim.InputError, match="expected a contact threshold >= 0 m"):
        kneesim.ContactArea(insert, femur, threshold=-1e-3)
    area = kneesim.ContactArea(insert, femur)
    with pytest.raises(kneesim.InputError, match=r"^ContactArea.calc_pose/X_IF: expected an array of shape \(4, 4\), got \(3, 4\)$"):
        area.calc_pose(np.eye(4)[:3])
    sheared = np.eye(4)
    sheared[0, 1] = 0.3
    with pytest.raises(kneesim.InputError, match="expected a rigid transform"):
        area.calc_pose(sheared)
    with pytest.raises(kneesim.InputError) as e:
        kneesim.ContactArea(str(tmp_path / "none.stl"), femur)
    assert e.value.file == str(tmp_path / "none.stl")
    setup, _ = scene(tmp_path, meshes)
    setup.write_text(setup.read_text().replace("<extra_thresholds>", "<extra_treshold>").replace("</extra_thresholds>", "</extra_treshold>"))
    with pytest.raises(kneesim.InputError, match=r"unknown element <extra_treshold>") as e:
        kneesim.run_contact_area(str(setup))
    assert e.value.file == str(setup)

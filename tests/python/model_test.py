"""kneesim.load_model and kneesim.Model (python/model.cpp) against the model files themselves
(read independently with ElementTree) and the hand-derived kinematics of a fixture model."""

import os
import pathlib
import subprocess
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import kneesim
from conftest import data_path, source_path


def test_the_module_is_the_build_trees():
    # The tests run against the module just built (PYTHONPATH), never an installed copy.
    build = pathlib.Path(os.environ["PYTHONPATH"].split(os.pathsep)[0]).resolve()
    assert pathlib.Path(kneesim.__file__).resolve().parent == build / "kneesim"


def test_import_needs_no_numpy():
    # NumPy is loaded on first use: a Python without it can still import kneesim.
    code = "import sys; sys.modules['numpy'] = None; import kneesim; print(kneesim.InputError.__mro__[1].__name__)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ValueError"


def test_gait2354_bodies_coordinates_and_markers_match_the_osim_file():
    path = data_path("opensim-ik-tests/subject01_simbody.osim")
    model = kneesim.load_model(str(path))
    root = ET.parse(path).getroot()
    bodies = root.findall(".//BodySet/objects/Body")
    markers = root.findall(".//MarkerSet/objects/Marker")
    coords = root.findall(".//CoordinateSet/objects/Coordinate")
    assert model.name == "subject01"
    assert model.body_names == [b.get("name") for b in bodies]
    assert len(model.coordinate_names) == len(coords) == 23
    assert sorted(model.coordinate_names) == sorted(c.get("name") for c in coords)
    assert model.marker_names == [k.get("name") for k in markers]
    for b in bodies:
        ours = model.bodies[model.find_body(b.get("name"))]
        assert ours.mass == pytest.approx(float(b.findtext("mass")), rel=1e-12)
    for k in markers:
        ours = model.markers[model.find_marker(k.get("name"))]
        assert model.bodies[ours.body].name == k.findtext("body").strip()
        expected = [float(v) for v in k.findtext("location").split()]
        np.testing.assert_allclose(ours.location, expected, rtol=0, atol=1e-15)
    knee = model.coordinates[model.find_coordinate("knee_angle_r")]
    assert knee.motion_type == "rotational"
    xml_knee = next(c for c in coords if c.get("name") == "knee_angle_r")
    lo, hi = (float(v) for v in xml_knee.findtext("range").split())
    assert knee.range == pytest.approx((lo, hi))
    assert model.find_body("no_such_body") == -1


def test_marker_kinematics_match_the_hand_derived_fixture():
    # tests/tool/fixtures/README.md: with X_G,femur = (Rz(90), (0.001, 0.5 + lift, 0)), the markers
    # F1, F2, F3 are at (0.001, 0.5 + lift, 0.1), (0.001, 0.55 + lift, 0), (-0.049, 0.5 + lift, -0.1).
    model = kneesim.load_model(str(source_path("tests/tool/fixtures/slider_knee_markers.osim")))
    assert model.coordinate_names == ["lift"]
    assert model.coordinates[0].motion_type == "translational"
    lift = -0.0123
    p = model.calc_marker_locations([lift])
    names = model.marker_names
    np.testing.assert_allclose(p[names.index("F1")], [0.001, 0.5 + lift, 0.1], atol=1e-12)
    np.testing.assert_allclose(p[names.index("F2")], [0.001, 0.55 + lift, 0.0], atol=1e-12)
    np.testing.assert_allclose(p[names.index("F3")], [-0.049, 0.5 + lift, -0.1], atol=1e-12)
    X = model.calc_body_pose("femur", [lift])
    np.testing.assert_allclose(X[:3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-12)
    np.testing.assert_allclose(X[:3, 3], [0.001, 0.5 + lift, 0], atol=1e-12)


def test_a_missing_model_is_an_input_error():
    with pytest.raises(kneesim.InputError) as e:
        kneesim.load_model("/nonexistent/model.osim")
    assert isinstance(e.value, ValueError)
    assert str(e.value) == "/nonexistent/model.osim: model file not found"
    assert e.value.file == "/nonexistent/model.osim" and e.value.line is None


def test_a_malformed_model_names_its_file_and_line(tmp_path):
    bad = tmp_path / "bad.osim"
    bad.write_text('<?xml version="1.0"?>\n<OpenSimDocument Version="40000">\n<Model name="m">\n'
                   "<BodySet><objects><Body name=\"b\"><mass>heavy</mass></Body></objects></BodySet>\n"
                   "</Model></OpenSimDocument>\n")
    with pytest.raises(kneesim.InputError) as e:
        kneesim.load_model(str(bad))
    msg = str(e.value)
    assert msg.startswith(f"{bad}:4: ") and "\n" not in msg
    assert "heavy" in msg
    assert e.value.file == str(bad) and e.value.line == 4


def test_wrong_coordinate_count_is_an_input_error():
    model = kneesim.load_model(str(source_path("tests/tool/fixtures/slider_knee_markers.osim")))
    with pytest.raises(kneesim.InputError, match=r"^q: expected an array of shape \(1 coordinates\), got \(2,\)$"):
        model.calc_marker_locations([0.0, 1.0])

"""Inverse kinematics from Python (python/ik.cpp): OpenSim's IK regression case (gait2354,
subject01) from its setup file and from NumPy marker arrays, graded against OpenSim's stored
answer with OpenSim's tolerance, and a hand-derived slider model."""

import xml.etree.ElementTree as ET

import numpy as np
import pytest

import kneesim
from conftest import source_path
from io_test import parse_storage_text, parse_trc_text


def compare_with_opensim(names, q_si, model, ik_case):
    """Per-coordinate RMS difference from std_subject01_walk1_ik.mot, in degrees for rotational
    coordinates and metres for translations (as OpenSim's test compares them)."""
    labels, std = parse_storage_text(ik_case / "std_subject01_walk1_ik.mot")
    rms = {}
    for j, name in enumerate(names):
        c = model.coordinates[model.find_coordinate(name)]
        ours = np.degrees(q_si[:, j]) if c.motion_type == "rotational" else q_si[:, j]
        rms[name] = np.sqrt(np.mean((ours - std[:, labels.index(name)]) ** 2))
    return rms


def test_run_ik_from_the_setup_file_matches_opensim(ik_case):
    setup = ik_case / "subject01_Setup_InverseKinematics.xml"
    r = kneesim.run_ik(str(setup))
    model = kneesim.load_model(str(ik_case / "subject01_simbody.osim"))
    assert r.coordinate_names == model.coordinate_names
    assert r.coordinates.shape == (73, 23) and r.frames_solved == 73
    _, _, trc_time, _ = parse_trc_text(ik_case / "subject01_synthetic_marker_data.trc")
    np.testing.assert_array_equal(r.time, trc_time)  # every frame of the time range 0.4-1.6 s
    rms = compare_with_opensim(r.coordinate_names, r.coordinates, model, ik_case)
    assert max(rms.values()) < 0.02, rms  # OpenSim's tolerance is 0.2; kneesim reaches 0.008
    assert str(ik_case / "subject01_walk1_ik_test.mot") in r.outputs
    # The array is the written motion, in SI units.
    labels, written = parse_storage_text(ik_case / "subject01_walk1_ik_test.mot")
    knee = r.coordinate_names.index("knee_angle_r")
    np.testing.assert_allclose(np.degrees(r.coordinates[:, knee]), written[:, labels.index("knee_angle_r")], atol=1e-7)
    assert r.mean_rms < 0.02e-3


def test_solve_ik_from_numpy_arrays_matches_opensim(ik_case):
    model = kneesim.load_model(str(ik_case / "subject01_simbody.osim"))
    names, units, time, xyz = parse_trc_text(ik_case / "subject01_synthetic_marker_data.trc")
    assert units == "m"
    tasks = ET.parse(ik_case / "gait2354_IK_Tasks_uniform.xml").getroot()
    weights = {t.get("name"): float(t.findtext("weight")) for t in tasks.iter("IKMarkerTask")
               if t.findtext("apply").strip() == "true"}
    r = kneesim.solve_ik(model, xyz, names, time=time, weights=weights)
    assert r.outputs == []  # nothing written
    assert r.coordinates.shape == (73, 23)
    rms = compare_with_opensim(r.coordinate_names, r.coordinates, model, ik_case)
    assert max(rms.values()) < 0.02, rms
    # The same run as the setup file's, frame by frame.
    from_setup = kneesim.run_ik(str(ik_case / "subject01_Setup_InverseKinematics.xml"))
    np.testing.assert_allclose(r.coordinates, from_setup.coordinates, atol=1e-9)
    # A MarkerTable works as well as arrays.
    table = kneesim.read_trc(str(ik_case / "subject01_synthetic_marker_data.trc"))
    again = kneesim.solve_ik(model, table, weights=weights)
    np.testing.assert_array_equal(again.coordinates, r.coordinates)


def test_solve_ik_recovers_the_hand_derived_slider():
    # tests/tool/fixtures/README.md: markers F1..F3 of slider_knee_markers.osim at lift.
    model = kneesim.load_model(str(source_path("tests/tool/fixtures/slider_knee_markers.osim")))
    lift = np.array([-0.01, -0.005, 0.0, 0.004])
    xyz = np.stack([[[0.001, 0.5 + h, 0.1], [0.001, 0.55 + h, 0.0], [-0.049, 0.5 + h, -0.1]] for h in lift])
    xyz[2, 1] = np.nan  # one marker missing in one frame
    r = kneesim.solve_ik(model, xyz, ["F1", "F2", "F3"], rate=100.0, accuracy=1e-10)
    np.testing.assert_allclose(r.coordinates[:, 0], lift, atol=1e-9)
    # The default accuracy, 1e-5 m per step, is met (the answer is much closer).
    loose = kneesim.solve_ik(model, xyz, ["F1", "F2", "F3"], rate=100.0)
    np.testing.assert_allclose(loose.coordinates[:, 0], lift, atol=1e-5)
    np.testing.assert_allclose(r.time, np.arange(4) / 100.0)
    assert r.marker_rms.max() < 1e-9


def test_solve_ik_errors_are_input_errors():
    model = kneesim.load_model(str(source_path("tests/tool/fixtures/slider_knee_markers.osim")))
    with pytest.raises(kneesim.InputError,
                       match=r"^solve_ik/markers: expected an array of shape \(frames, markers, 3\), got \(4, 3\)$"):
        kneesim.solve_ik(model, np.zeros((4, 3)), ["F1", "F2", "F3"])
    with pytest.raises(kneesim.InputError, match=r"^solve_ik/marker_names: expected one name per marker column \(3\), got 2$"):
        kneesim.solve_ik(model, np.zeros((4, 3, 3)), ["F1", "F2"])
    with pytest.raises(kneesim.InputError, match=r"task names marker 'F9' which the model .* does not have"):
        kneesim.solve_ik(model, np.zeros((4, 3, 3)), ["F1", "F2", "F3"], weights={"F9": 1.0})
    with pytest.raises(kneesim.InputError, match="no tracked marker of the model"):
        kneesim.solve_ik(model, np.zeros((4, 1, 3)), ["X"])


def test_run_ik_errors_name_the_setup_file(tmp_path):
    setup = tmp_path / "ik.xml"
    setup.write_text("<OpenSimDocument><InverseKinematicsTool>\n<model_file>m.osim</model_file>\n"
                     "<marker_fle>x.trc</marker_fle>\n</InverseKinematicsTool></OpenSimDocument>\n")
    with pytest.raises(kneesim.InputError) as e:
        kneesim.run_ik(str(setup))
    assert str(e.value).startswith(f"{setup}:3: ") and "unknown element <marker_fle>" in str(e.value)

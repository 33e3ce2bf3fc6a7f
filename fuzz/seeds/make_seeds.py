#!/usr/bin/env python3
"""Writes the seed corpora fuzz/corpus/<target>/ from the repository's own files (data/, models/,
share/, tests/ fixtures): small files as they are, tables trimmed to their first rows (headers
updated to match), and a few files written here (meshes, a gap model). The C3D seeds come from
make_c3d_seeds.cpp (it needs the engine's C3D writer).

    python3 fuzz/seeds/make_seeds.py            (from the repository's root)
"""
import os
import re
import shutil
import struct

ROOT = os.path.normpath(os.path.join(os.path.dirname(__file__), "..", ".."))
CORPUS = os.path.join(ROOT, "fuzz", "corpus")


def src(rel):
    return os.path.join(ROOT, rel)


def put(target, name, data):
    folder = os.path.join(CORPUS, target)
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, name), "wb") as f:
        f.write(data if isinstance(data, bytes) else data.encode())


def copy(target, rel, name=None):
    put(target, name or os.path.basename(rel), open(src(rel), "rb").read())


def lines(rel):
    return open(src(rel), newline="").read().splitlines(keepends=True)


def trim_trc(rel, frames):
    ls = lines(rel)
    keys, values = ls[1].rstrip("\r\n").split("\t"), ls[2].rstrip("\r\n").split("\t")
    values[keys.index("NumFrames")] = str(frames)
    data = [l for l in ls[5:] if l.strip()][:frames]
    return "".join(ls[:2] + ["\t".join(values) + "\n"] + ls[3:5] + ["\n"] + data)


def trim_storage(rel, rows):
    ls = lines(rel)
    end = next(i for i, l in enumerate(ls) if l.strip() == "endheader")
    head = [re.sub(r"^(nRows=|datarows )\d+", lambda m: m.group(1) + str(rows), l) for l in ls[:end + 1]]
    return "".join(head + ls[end + 1:end + 2 + rows])


def trim_rows(rel, rows):
    return "".join(lines(rel)[:1 + rows])


TETRA = [((0, 0, 0), (0.01, 0, 0), (0, 0.01, 0)), ((0, 0, 0), (0, 0, 0.01), (0.01, 0, 0)),
         ((0, 0, 0), (0, 0.01, 0), (0, 0, 0.01)), ((0.01, 0, 0), (0, 0, 0.01), (0, 0.01, 0))]


def ascii_stl(tris):
    out = "solid tetra\n"
    for t in tris:
        out += "  facet normal 0 0 0\n    outer loop\n"
        for v in t:
            out += "      vertex %g %g %g\n" % v
        out += "    endloop\n  endfacet\n"
    return out + "endsolid tetra\n"


def binary_stl(tris):
    out = b"binary STL seed of kneesim's fuzz/corpus".ljust(80, b" ") + struct.pack("<I", len(tris))
    for t in tris:
        out += struct.pack("<3f", 0, 0, 0) + b"".join(struct.pack("<3f", *v) for v in t) + b"\0\0"
    return out


GAP_MODEL = """{
  "kind": "kneesim gap model",
  "source": "jw_gap.xml",
  "plugins": ["hertz", "gap_effects"],
  "law": "hertz",
  "trials": ["ngait_og3"],
  "synthetic": false,
  "interim_inputs": [],
  "emg_peaks_V": {"vaslat": 0.25},
  "targets": [
    {"target": "total", "law": "hertz", "effects": ["grf_load"],
     "parameters": [{"name": "E", "value": 5.0e8}, {"name": "grf_load.gain", "value": 0.1}],
     "verdict_class": "explained", "verdict": "grf_load explains the gap", "heldout_rmse_N": 80.5}
  ]
}
"""


def main():
    for rel in ["data/opensim-ik-tests/subject01_synthetic_marker_data.trc", "tests/ik/fixtures/chain.trc"]:
        put("trc", os.path.basename(rel), trim_trc(rel, 3))
    put("storage", "ik.mot", trim_storage("data/opensim-ik-tests/std_subject01_walk1_ik.mot", 3))
    put("storage", "id.sto", trim_storage("data/opensim-dynamics-tests/id/std_arm26_InverseDynamics.sto", 3))
    put("storage", "knee_loads.sto", trim_storage("tests/gap/fixtures/jw_ngait_og3_knee_loads.sto", 3))
    copy("storage", "data/opensim-dynamics-tests/jr/SinglePin_controls.sto")
    put("knee_forces", "og3.csv", trim_rows("data/kgc4-jw/knee-forces/jw_ngait_og3_knee_forces.csv", 5))
    put("csv", "markers.csv", trim_rows("models/jw-knee24/jw_knee24_markers.csv", 3))
    put("csv", "path.csv", trim_rows("models/jw-knee24/jw_knee24_path.csv", 3))
    put("csv", "forces.csv", trim_rows("data/kgc4-jw/knee-forces/jw_ngait_og3_knee_forces.csv", 3))
    put("stl_ascii", "tetra.stl", ascii_stl(TETRA))
    put("stl_binary", "tetra.stl", binary_stl(TETRA))
    put("stl_binary", "one.stl", binary_stl(TETRA[:1]))
    copy("stl_ascii", "tests/model/fixtures/Geometry/box.stl")
    for rel in ["tests/model/fixtures/chain40000.osim", "tests/model/fixtures/reverse30000.osim",
                "tests/model/fixtures/shoulder40000.osim", "tests/ik/fixtures/constraints40000.osim",
                "tests/tool/fixtures/slider_knee.osim"]:
        copy("osim", rel)
    copy("actuator_set", "models/jw-knee24/jw_muscle_reserves.xml")
    put("actuator_set", "arm_reserves.xml",
        '<OpenSimDocument Version="30000"><ForceSet name="arm_reserves"><objects>\n'
        '<CoordinateActuator name="elbow_res"><coordinate>r_elbow_flex</coordinate><optimal_force>1'
        '</optimal_force><min_control>-Inf</min_control><max_control>Inf</max_control></CoordinateActuator>\n'
        '</objects></ForceSet></OpenSimDocument>\n')
    copy("urdf", "tests/model/fixtures/chain.urdf")
    for rel in ["tests/ik/fixtures/chain_setup.xml", "data/opensim-ik-tests/subject01_Setup_InverseKinematics.xml",
                "models/jw-knee24/ngait_og3_ik_setup.xml"]:
        copy("ik_setup", rel)
    copy("ik_tasks", "models/jw-knee24/jw_knee24_ik_tasks.xml")
    copy("marker_placer", "models/jw-knee24/marker_placer.xml")
    for rel in ["data/opensim-dynamics-tests/id/arm26_Setup_InverseDynamics.xml",
                "data/opensim-dynamics-tests/id/subject01_Setup_InverseDynamics.xml",
                "models/jw-knee24/ngait_og3_id_setup.xml"]:
        copy("id_setup", rel)
    copy("external_loads", "data/opensim-dynamics-tests/id/subject01_walk1_grf.xml")
    for rel in ["data/opensim-dynamics-tests/so/arm26_Setup_StaticOptimization.xml",
                "data/opensim-dynamics-tests/jr/SinglePin_Setup_JointReaction.xml"]:
        copy("analyze_setup", rel)
    for rel in ["share/gap/jw_gap.xml", "share/gap/jw_gap_c3d.xml", "share/gap/jw_gap_muscle.xml"]:
        copy("gap_setup", rel)
    put("gap_model", "gap_model.json", GAP_MODEL)
    for rel in ["share/examples/contact_area/jw_ngait_og3_hinge.xml",
                "share/examples/contact_area/jw_flexion_0_120_hinge.xml"]:
        copy("contact_area_setup", rel)
    copy("workflow_setup", "models/jw-knee24/paper_workflow.xml")
    copy("workflow_setup", "models/jw-knee24/jw_muscle_chain.xml")
    copy("plugin_parameters", "models/jw-knee24/paper_workflow.xml")
    copy("knee_model_setup", "models/jw-knee24/build_model.xml")
    # The trial names its own file (the target writes input.xml), so the fuzzer starts from a
    # setup that reads.
    put("batch_trial", "trial.xml", '<BatchTrial name="jw_ngait_og3"><subject>jw</subject><trial>ngait_og3</trial>'
        '<activity>gait</activity><setup_files>input.xml</setup_files></BatchTrial>\n')
    copy("batch_manifest_csv", "share/examples/batch/jw_cohort.csv")
    put("batch_manifest_toml", "cohort.toml",
        '# a cohort\n[defaults]\nmodel = "m.osim"\ntools = ["ik", "contact"]\nbody_mass = 66.7\n\n'
        '[[trial]]\nsubject = "s1"\ntrial = "walk1"\ntime_range = [0.5, 2]\n\n'
        '[[trial]]\nsubject = "s2"\ntrial = "walk1"\ntools = "ik"\nplots = true\naccuracy = 1e-6\n')


if __name__ == "__main__":
    main()

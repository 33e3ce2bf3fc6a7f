#!/usr/bin/env python3
"""OpenSim's inverse-kinematics regression case (gait2354, subject01) driven from Python with
NumPy arrays: load the model, read the TRC markers, solve IK, compare with OpenSim's stored
answer, write the motion.

    python3 opensim_ik.py [DATA_DIR] [OUTPUT.mot]

DATA_DIR holds opensim-ik-tests/ (default: $KNEESIM_DATA_DIR, else the repository's data/);
OUTPUT.mot defaults to subject01_walk1_ik_python.mot in the current folder.
"""

import os
import pathlib
import sys

import numpy as np

import kneesim

here = pathlib.Path(__file__).resolve()
default_data = os.environ.get("KNEESIM_DATA_DIR", str(here.parents[3] / "data"))
case = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else default_data) / "opensim-ik-tests"
output = sys.argv[2] if len(sys.argv) > 2 else "subject01_walk1_ik_python.mot"

model = kneesim.load_model(str(case / "subject01_simbody.osim"))
print(model)
markers = kneesim.read_trc(str(case / "subject01_synthetic_marker_data.trc"))
print(markers, f"at {markers.rate:g} Hz")

# Any (frames, markers, 3) array in metres works; here the TRC's, every marker weighted 1.
result = kneesim.solve_ik(model, markers.positions, markers.labels, time=markers.time)
print(f"{result.frames_solved} frames, mean marker RMS {result.mean_rms * 1e3:.4f} mm")

# OpenSim's answer is in degrees (metres for the pelvis translations).
std = kneesim.read_storage(str(case / "std_subject01_walk1_ik.mot"))
worst = ("", 0.0)
for j, name in enumerate(result.coordinate_names):
    rotational = model.coordinates[j].motion_type == "rotational"
    ours = np.degrees(result.coordinates[:, j]) if rotational else result.coordinates[:, j]
    rms = float(np.sqrt(np.mean((ours - std.column(name)) ** 2)))
    worst = max(worst, (name, rms), key=lambda w: w[1])
print(f"largest RMS difference from OpenSim: {worst[1]:.4f} ({worst[0]}); OpenSim's tolerance is 0.2")

# Write the motion as OpenSim does: degrees for rotational coordinates.
deg = [np.degrees(1.0) if c.motion_type == "rotational" else 1.0 for c in model.coordinates]
motion = kneesim.Storage(["time"] + result.coordinate_names,
                         np.column_stack([result.time, result.coordinates * deg]), name="ik", in_degrees=True)
kneesim.write_storage(output, motion)
print("wrote", output)

"""The Python examples in share/examples/python run and say what their comments promise."""

import re
import subprocess
import sys

from conftest import data_path, source_path


def test_opensim_ik_example(tmp_path):
    data_path("opensim-ik-tests/subject01_Setup_InverseKinematics.xml")
    script = source_path("share/examples/python/opensim_ik.py")
    out = subprocess.run([sys.executable, str(script), str(data_path("")), str(tmp_path / "ik.mot")],
                         capture_output=True, text=True, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    worst = float(re.search(r"largest RMS difference from OpenSim: ([0-9.]+)", out.stdout).group(1))
    assert worst < 0.02, out.stdout
    assert (tmp_path / "ik.mot").read_text().startswith("ik\n")

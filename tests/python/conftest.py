"""Shared fixtures of the Python binding tests (run by ctest: tests/python/CMakeLists.txt sets
PYTHONPATH to the build tree's package and KNEESIM_DATA_DIR / KNEESIM_SOURCE_DIR).

Tests that need data call data_path(): a missing file fails the test, naming it, as
KNEESIM_REQUIRE_DATA does for the C++ tests (the data are in the repository's data/)."""

import os
import pathlib
import shutil

import pytest

SOURCE_DIR = pathlib.Path(os.environ.get("KNEESIM_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
DATA_DIR = pathlib.Path(os.environ.get("KNEESIM_DATA_DIR", SOURCE_DIR / "data"))


def data_path(rel):
    """Path of rel under the data folder; fails the test when it is not there."""
    p = DATA_DIR / rel
    if not p.exists():
        pytest.fail(f"missing test data file {p} (data/ of the repository, or -DKNEESIM_DATA_DIR=...: see docs/data.md)")
    return p


def source_path(rel):
    """Path of rel under the repository."""
    return SOURCE_DIR / rel


@pytest.fixture
def ik_case(tmp_path):
    """A copy of OpenSim's IK regression case (gait2354, subject01) in a scratch folder."""
    src = data_path("opensim-ik-tests/subject01_Setup_InverseKinematics.xml").parent
    dst = tmp_path / "opensim-ik"
    shutil.copytree(src, dst)
    return dst

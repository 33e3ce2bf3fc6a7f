"""The gap diagnosis from Python (python/gap.cpp): a <GapTool> setup on JW's gait and stair trials
with the paper workflow's real contact areas (tests/gap/fixtures), whose report comes back as the
dict gap_report.json holds; the diagnosis itself is graded by the C++ tests (tests/gap/)."""

import json

import pytest

import kneesim
from conftest import data_path, source_path

SETUP = """<GapTool name="py_gap">
  <results_directory>out</results_directory>
  <plugins>hertz gap_effects</plugins>
  <law>hertz</law>
  <free_parameters>E nu</free_parameters>
  <assumed_values>nu 0.45</assumed_values>
  <targets>total</targets>
  <body_mass>66.7</body_mass>
  <screen_top>2</screen_top>
  <max_effects>1</max_effects>
  <bootstrap_samples>20</bootstrap_samples>
  <plots>false</plots>
  <trials>{trials}</trials>
</GapTool>
"""


def write_setup(tmp_path):
    trials = ""
    for name, activity in (("ngait_og3", "gait"), ("stairupf1", "stair")):
        trials += (f'<Trial name="{name}" activity="{activity}">'
                   f"<knee_forces>{data_path(f'kgc4-jw/knee-forces/jw_{name}_knee_forces.csv')}</knee_forces>"
                   f"<c3d>{data_path(f'kgc4-jw/markers/jw_{name}.c3d')}</c3d>"
                   f"<contact_area>{source_path(f'tests/gap/fixtures/jw_{name}_contact_area.sto')}</contact_area>"
                   "</Trial>")
    setup = tmp_path / "gap.xml"
    setup.write_text(SETUP.format(trials=trials))
    return setup


def test_run_gap_returns_the_json_report(tmp_path):
    setup = write_setup(tmp_path)
    report = kneesim.run_gap(str(setup))
    with open(tmp_path / "out" / "gap_report.json") as f:
        assert report == json.load(f)
    assert (tmp_path / "out" / "gap_report.md").exists()
    assert not report["interim_inputs"]
    assert [t["target"] for t in report["targets"]] == ["total"]
    total = report["targets"][0]
    assert total["verdict"]
    params = {p["name"]: p for p in total["baseline"]["parameters"]}
    assert params["nu"]["status"] == "fixed: not identifiable" and params["nu"]["value"] == 0.45
    assert report["anchors"]["jw_body_mass_kg"] == 66.7
    # Overrides, as `kneesim gap -o DIR --targets ...` has them.
    medial = kneesim.run_gap(str(setup), results_directory=str(tmp_path / "medial"), targets=["medial"])
    assert [t["target"] for t in medial["targets"]] == ["medial"]
    with open(tmp_path / "medial" / "gap_report.json") as f:
        assert medial == json.load(f)


def test_gap_errors_are_input_errors(tmp_path):
    setup = tmp_path / "gap.xml"
    setup.write_text('<GapTool name="x">\n  <trails></trails>\n</GapTool>\n')
    with pytest.raises(kneesim.InputError) as e:
        kneesim.run_gap(str(setup))
    assert str(e.value).startswith(f"{setup}:2: ") and "unknown element <trails>" in str(e.value)
    with pytest.raises(kneesim.InputError, match=r"^run_gap/targets: .*'front'"):
        kneesim.run_gap(str(setup), targets=["front"])

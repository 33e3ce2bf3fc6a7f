#!/bin/sh
# Builds kneesim and runs the main job:
#  1. Dao & Pouletaut 2015 end to end on subject JW (models/jw-knee24/paper_workflow.xml): IK from the
#     C3D files, implant contact area, eKnee forces, Hertz law identified on ngait_og3 and predicted on
#     stairupf1 and chairrise1; summary.json, .sto files and PNG plots (the paper's Figures 6-9);
#     then the sim-to-real gap diagnosis on the areas it computed (results/paper_workflow/gap/).
#  2. OpenSim's own inverse-kinematics regression case (gait2354) against OpenSim's stored answer.
# Both run on copies in build/main-job/. The data are looked for in $KNEESIM_DATA_DIR, else
# ../shared/data next to the repository; a part whose data are missing is skipped with a message.
set -eu
cd "$(dirname "$0")/.."
data="${KNEESIM_DATA_DIR:-$(pwd)/../shared/data}"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DKNEESIM_DATA_DIR="$data" >/dev/null
cmake --build build -j"$(nproc)"
data="$(cd "$data" 2>/dev/null && pwd || echo "$data")"
ran=0

# 1. The paper's workflow. The setup files name the data as ../../../shared/data relative to
#    models/jw-knee24, so the copy gets that layout: build/main-job/shared/data -> $data.
if [ -f "$data/kgc4-jw/markers/jw_ngait_og3.c3d" ] && [ -f "$data/kgc4-jw/knee-forces/jw_ngait_og3_knee_forces.csv" ]; then
  job=build/main-job
  rm -rf "$job/paper" "$job/shared"
  mkdir -p "$job/paper/models" "$job/shared"
  ln -s "$data" "$job/shared/data"
  cp -r models/jw-knee24 "$job/paper/models/"
  # The workflow's gap step reads share/gap/jw_gap*.xml (../../share/gap from models/jw-knee24).
  mkdir -p "$job/paper/share"
  cp -r share/gap "$job/paper/share/"
  rm -rf "$job/paper/models/jw-knee24/results"
  echo "== kneesim run $job/paper/models/jw-knee24/paper_workflow.xml"
  start=$(date +%s)
  ./build/bin/kneesim run "$job/paper/models/jw-knee24/paper_workflow.xml"
  end=$(date +%s)
  results="$job/paper/models/jw-knee24/results/paper_workflow"
  echo "== the paper's workflow took $((end - start)) s; results in $results/"
  echo "   summary.json (identified K and E at the assumed nu, errors per trial and phase, contact areas),"
  echo "   plots/*.png (Figures 6-9), <trial>/ (IK motion, contact area, measured and predicted force),"
  echo "   gap/jw_gap/ and gap/jw_gap_c3d/ (gap_report.md, gap_report.json and plots of the gap diagnosis)"
  ran=1
else
  echo "== skipped the paper's workflow: JW's data (kgc4-jw/) are not in $data"
  echo "   (set KNEESIM_DATA_DIR to the folder holding kgc4-jw/ and opensim-ik-tests/)."
fi

# 2. OpenSim's IK regression case (about a second).
case_dir="$data/opensim-ik-tests"
if [ -f "$case_dir/subject01_Setup_InverseKinematics.xml" ]; then
  work=build/main-job/opensim-ik
  rm -rf "$work"
  mkdir -p "$work"
  cp "$case_dir"/* "$work"/
  echo "== kneesim run $work/subject01_Setup_InverseKinematics.xml"
  ./build/bin/kneesim -q run "$work/subject01_Setup_InverseKinematics.xml"
  echo "== kneesim compare-motion: kneesim's joint angles against OpenSim's stored answer (degrees; metres for pelvis_t*)"
  ./build/bin/kneesim compare-motion "$work/subject01_walk1_ik_test.mot" "$work/std_subject01_walk1_ik.mot" --tolerance 0.2
  ran=1
else
  echo "== skipped OpenSim's IK regression case: $case_dir is not there"
fi
if [ "$ran" = 0 ]; then
  echo "kneesim is built; no data were found, so the main job did not run."
fi

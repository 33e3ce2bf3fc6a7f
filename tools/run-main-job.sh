#!/bin/sh
# Builds and installs kneesim (tools/install.sh: the command, the engine, the Python module) and runs
# the main job:
#  1. Dao & Pouletaut 2015 end to end on subject JW (models/jw-knee24/paper_workflow.xml): IK from the
#     C3D files, implant contact area, eKnee forces, Hertz law identified on ngait_og3 and predicted on
#     stairupf1 and chairrise1; summary.json, .sto files and PNG plots (the paper's Figures 6-9);
#     then the sim-to-real gap diagnosis on the areas it computed (results/paper_workflow/gap/).
#  2. OpenSim's own inverse-kinematics regression case (gait2354) against OpenSim's stored answer.
# Both run on copies in build/main-job/. The data are the repository's data/ folder, or
# $KNEESIM_DATA_DIR: a folder with the same layout (kgc4-jw/, opensim-ik-tests/, ...; docs/data.md).
set -eu
cd "$(dirname "$0")/.."
data="${KNEESIM_DATA_DIR:-$(pwd)/data}"
for f in kgc4-jw/markers/jw_ngait_og3.c3d kgc4-jw/knee-forces/jw_ngait_og3_knee_forces.csv \
         opensim-ik-tests/subject01_Setup_InverseKinematics.xml; do
  if [ ! -f "$data/$f" ]; then
    echo "error: $data/$f not found (KNEESIM_DATA_DIR must name a folder laid out as the repository's data/)" >&2
    exit 1
  fi
done
data="$(cd "$data" && pwd)"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DKNEESIM_DATA_DIR="$data" >/dev/null
cmake --build build -j"$(nproc)"
# The kneesim command, the engine and the Python module, for python3 on PATH (tools/install.sh).
./tools/install.sh

# 1. The paper's workflow. The setup files name the data as ../../data relative to models/jw-knee24
#    and read share/gap/jw_gap*.xml (../../share/gap), so the copy keeps that layout:
#    build/main-job/paper/{models/jw-knee24, share/gap, data -> $data}.
job=build/main-job
rm -rf "$job/paper" "$job/shared"
mkdir -p "$job/paper/models" "$job/paper/share"
ln -s "$data" "$job/paper/data"
cp -r models/jw-knee24 "$job/paper/models/"
cp -r share/gap "$job/paper/share/"
rm -rf "$job/paper/models/jw-knee24/results"
echo "== kneesim run $job/paper/models/jw-knee24/paper_workflow.xml (data: $data)"
start=$(date +%s)
./build/bin/kneesim run "$job/paper/models/jw-knee24/paper_workflow.xml"
end=$(date +%s)
results="$job/paper/models/jw-knee24/results/paper_workflow"
echo "== the paper's workflow took $((end - start)) s; results in $results/"
echo "   summary.json (identified K and E at the assumed nu, errors per trial and phase, contact areas),"
echo "   plots/*.png (Figures 6-9; fig11: the knee force from muscle forces, MuscleChain), <trial>/ (IK motion,"
echo "   contact area, measured and predicted force, static optimization and the knee reaction),"
echo "   gap/jw_gap/ and gap/jw_gap_c3d/ (gap_report.md, gap_report.json and plots of the gap diagnosis)"

# 2. OpenSim's IK regression case (about a second).
work=$job/opensim-ik
rm -rf "$work"
mkdir -p "$work"
cp "$data"/opensim-ik-tests/* "$work"/
echo "== kneesim run $work/subject01_Setup_InverseKinematics.xml"
./build/bin/kneesim -q run "$work/subject01_Setup_InverseKinematics.xml"
echo "== kneesim compare-motion: kneesim's joint angles against OpenSim's stored answer (degrees; metres for pelvis_t*)"
./build/bin/kneesim compare-motion "$work/subject01_walk1_ik_test.mot" "$work/std_subject01_walk1_ik.mot" --tolerance 0.2

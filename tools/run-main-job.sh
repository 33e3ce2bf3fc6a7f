#!/bin/sh
# Builds kneesim and runs the main job. For now the main job is OpenSim's own inverse-kinematics
# regression case (gait2354, opensim-core Applications/IK/tests): `kneesim run` on a copy of its
# folder in build/main-job/, then the comparison with OpenSim's stored answer, column by column.
# The data are looked for in $KNEESIM_DATA_DIR, else ../shared/data next to the repository.
set -eu
cd "$(dirname "$0")/.."
data="${KNEESIM_DATA_DIR:-$(pwd)/../shared/data}"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DKNEESIM_DATA_DIR="$data" >/dev/null
cmake --build build -j"$(nproc)"

case_dir="$data/opensim-ik-tests"
if [ ! -f "$case_dir/subject01_Setup_InverseKinematics.xml" ]; then
  echo "kneesim is built; OpenSim's IK regression data are not in $case_dir, so the main job is skipped"
  echo "(set KNEESIM_DATA_DIR to the folder holding opensim-ik-tests/)."
  exit 0
fi
work=build/main-job/opensim-ik
rm -rf "$work"
mkdir -p "$work"
cp "$case_dir"/* "$work"/
echo "== kneesim run $work/subject01_Setup_InverseKinematics.xml"
./build/bin/kneesim run "$work/subject01_Setup_InverseKinematics.xml"
echo "== kneesim compare-motion: kneesim's joint angles against OpenSim's stored answer (degrees; metres for pelvis_t*)"
./build/bin/kneesim compare-motion "$work/subject01_walk1_ik_test.mot" "$work/std_subject01_walk1_ik.mot" --tolerance 0.2

#!/bin/sh
# The `kneesim batch` demonstration on JW's data (docs/batch.md, "Demonstration"): a cohort made of
# every JW trial with markers, each twice under two subject names (jw_a, jw_b), plus one corrupt
# trial (ngait_og7's C3D cut short):
#  1. --jobs 1 (the trials one after the other: the sum of the single runs), then --jobs 2: wall
#     and CPU time of each, and the two output trees compared byte for byte;
#  2. a --jobs 2 run killed (SIGKILL) once four trials have finished, then resumed with
#     --resume: compared byte for byte with the uninterrupted run;
#  3. the corrupt trial reported failed while every other one finishes (all three runs).
# Prints the figures; leaves the runs in $KNEESIM_DEMO_DIR (default build/batch-demo).
#   tools/batch-demo.sh            (data: $KNEESIM_DATA_DIR, else data/ or ../shared/data)
set -eu
cd "$(dirname "$0")/.."
src=$(pwd)
if [ -n "${KNEESIM_DATA_DIR:-}" ]; then data=$KNEESIM_DATA_DIR
elif [ -f data/kgc4-jw/markers/jw_ngait_og3.c3d ]; then data=$src/data
else data=$(cd .. && pwd)/shared/data; fi
exe=${KNEESIM:-$src/build/bin/kneesim}
[ -x "$exe" ] || { echo "build kneesim first (cmake --build build --target kneesim)"; exit 1; }
out=${KNEESIM_DEMO_DIR:-$src/build/batch-demo}
rm -rf "$out"
mkdir -p "$out"
. "$src/tests/cli/batch_common.sh"

# The manifest: tools per trial from what JW's data offer (knee forces for ngait_og3 and stairupf1).
jw=$data/kgc4-jw
model=$src/models/jw-knee24/jw_knee24.osim
tasks=$src/models/jw-knee24/jw_knee24_ik_tasks.xml
implant="$jw/implant/femoral_component.stl,$jw/implant/tibial_insert.stl,femoral_component,tibial_insert"
head -c 30000 "$jw/markers/jw_ngait_og7.c3d" >"$out/jw_corrupt.c3d"
m=$out/jw_cohort.csv
echo "subject,trial,activity,tools,model,ik_tasks,markers,knee_forces,femoral_component,insert,femoral_mesh,insert_mesh,body_mass" >"$m"
for subject in jw_a jw_b; do
  for c3d in "$jw"/markers/jw_*.c3d; do
    trial=$(basename "$c3d" .c3d | sed 's/^jw_//')
    case $trial in ngait*) activity=gait ;; stair*) activity=stairs ;; *) activity=stance ;; esac
    forces=$jw/knee-forces/jw_${trial}_knee_forces.csv
    if [ -f "$forces" ]; then tools="ik workflow"; else tools="ik contact"; forces=""; fi
    echo "$subject,$trial,$activity,$tools,$model,$tasks,$c3d,$forces,$implant,66.7" >>"$m"
  done
done
echo "jw_a,corrupt,gait,ik,$model,$tasks,$out/jw_corrupt.c3d,,,,,,66.7" >>"$m"
rows=$(($(wc -l <"$m") - 1))
echo "manifest: $m ($rows trials)"

# timed <label> <command...>: runs it, prints wall and CPU seconds (the children's included).
timed() {
  label=$1
  shift
  /usr/bin/time -f "%e %U %S" -o "$out/time.txt" "$@" >"$out/$label.out" 2>"$out/$label.err" || true
  # The last line: time(1) writes "Command exited with non-zero status 1" first when it does.
  tail -n 1 "$out/time.txt" | awk -v l="$label" -v load="$(cut -d' ' -f1-3 /proc/loadavg)" \
    '{ printf "%s: wall %.1f s, CPU %.1f s (load average %s)\n", l, $1, $2 + $3, load }'
}

echo "== 1. the sum of the single runs (--jobs 1) against --jobs 2"
timed jobs1 "$exe" batch "$m" --jobs 1 -o "$out/jobs1"
timed jobs2 "$exe" batch "$m" --jobs 2 -o "$out/jobs2"
sum=$(awk -F, 'NR > 1 && $5 != "" { s += $5 } END { printf "%.1f", s }' "$out/jobs1/batch_summary.csv")
echo "sum of the trials' own run times in the --jobs 1 run: $sum s"
cat "$out/jobs2.out"
if same_outputs "$out/jobs1" "$out/jobs2"; then echo "--jobs 1 and --jobs 2: the same bytes in every output"; else echo "--jobs 1 and --jobs 2 DIFFER"; fi

echo "== 2. killed once four trials have finished, then resumed"
"$exe" batch "$m" --jobs 2 -o "$out/killed" >"$out/killed.out" 2>&1 &
pid=$!
while [ "$(ls "$out"/killed/*/*/*.done 2>/dev/null | wc -l)" -lt 4 ]; do sleep 0.2; done
kill -KILL $pid
wait $pid 2>/dev/null || true
sleep 0.5
left=$(ps -eo args | grep -v grep | grep -c "run jw_._.*_batch.xml" || true)
echo "killed: $(ls "$out"/killed/*/*/*.done | wc -l) trial(s) had finished; $left trial process(es) left running"
timed resumed "$exe" batch "$m" --jobs 2 --resume -o "$out/killed"
echo "resumed: $(grep -c ',done-earlier,' "$out/killed/batch_summary.csv") skipped, $(grep -c ',done,' "$out/killed/batch_summary.csv") run again, $(grep -c ',failed,' "$out/killed/batch_summary.csv") failed"
if same_outputs "$out/jobs1" "$out/killed"; then echo "killed and resumed: the same bytes as the uninterrupted run"; else echo "killed and resumed: DIFFERENT from the uninterrupted run"; fi

echo "== 3. the corrupt trial"
grep ',corrupt,' "$out/jobs1/batch_summary.csv"
tail -n 1 "$out/jobs1.err"

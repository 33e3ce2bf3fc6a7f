#!/bin/sh
# `kneesim batch` as a user runs it on JW's data: a corrupt trial fails alone with its one-line
# error while the others finish; --jobs 2 writes the same bytes as --jobs 1; a batch killed
# mid-run and resumed writes the same bytes again; --resume skips what is finished; a trial's
# step can be re-run by hand from its folder; a bad manifest is one line.
#   batch_cli_test.sh <kneesim executable> <source dir> <data dir>
set -u
exe=$1 src=$2 data=$3
if [ ! -f "$data/kgc4-jw/markers/jw_ngait_og3.c3d" ]; then
  echo "JW's data are not in $data"
  exit 1
fi
. "$src/tests/cli/batch_common.sh"
tmp=$(mktemp -d "${TMPDIR:-/tmp}/kneesim_batch.XXXXXX")
trap 'rm -rf "$tmp"' EXIT INT TERM
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
m="$tmp/cohort.csv"
write_manifest "$m" "$src" "$data" "$tmp"

# --jobs 1: the corrupt trial fails (exit 1, one line), the two others finish.
"$exe" batch "$m" --jobs 1 -o "$tmp/j1" >"$tmp/out" 2>"$tmp/err"
[ $? = 1 ] || fail "a batch with a failed trial must exit 1"
tail -n 1 "$tmp/err" | grep -q "kneesim: error: .*cohort.csv: 1 of 3 trials failed or did not run" ||
  fail "last stderr line: $(tail -n 1 "$tmp/err")"
grep -q "^batch: \[3/3\]" "$tmp/err" || fail "no plain progress lines on a non-terminal: $(cat "$tmp/err")"
grep -q "^s1,ngait_og3,gait,done," "$tmp/j1/batch_summary.csv" || fail "s1/ngait_og3 not done: $(cat "$tmp/j1/batch_summary.csv")"
grep -q "^s2,ngait_og1,gait,done," "$tmp/j1/batch_summary.csv" || fail "s2/ngait_og1 not done"
grep -q "^s1,corrupt,gait,failed,.*jw_corrupt.c3d" "$tmp/j1/batch_summary.csv" ||
  fail "the corrupt trial's row does not name its file: $(grep corrupt "$tmp/j1/batch_summary.csv")"
# The summary's error cell is the C3D reader's own one line, starting with the file.
grep -q "^s1,corrupt,gait,failed,[0-9.]*,,,,,,,,,,,,,\"$tmp/jw_corrupt.c3d: data: truncated C3D data: .*\"\$" "$tmp/j1/batch_summary.csv" ||
  fail "the corrupt trial's error cell: $(grep corrupt "$tmp/j1/batch_summary.csv")"
[ "$(wc -l <"$tmp/j1/batch_summary.csv")" = 4 ] || fail "the summary must have a header and one line per trial"
[ -f "$tmp/j1/s1/corrupt/s1_corrupt.failed" ] || fail "no failure note for the corrupt trial"
[ -f "$tmp/j1/s1/corrupt/s1_corrupt.done" ] && fail "the corrupt trial has a completion marker"
grep -q "s1           ngait_og3      done" "$tmp/out" || fail "printed summary: $(cat "$tmp/out")"
grep -q "383.4" "$tmp/out" || fail "ngait_og3's force RMSE (383.4 N) not in the printed summary"

# --jobs 2: the same bytes.
"$exe" batch "$m" --jobs 2 -o "$tmp/j2" >/dev/null 2>&1
same_outputs "$tmp/j1" "$tmp/j2" || fail "--jobs 2 wrote other bytes than --jobs 1"

# Killed mid-run, then resumed: the same bytes. The kill comes once the first trial has finished
# (whatever is running then dies with the batch), so some trials are skipped and some redone.
"$exe" batch "$m" --jobs 2 -o "$tmp/k" >/dev/null 2>&1 &
pid=$!
i=0
while [ $i -lt 600 ] && ! ls "$tmp"/k/*/*/*.done >/dev/null 2>&1 && ! ls "$tmp"/k/*/*/*.failed >/dev/null 2>&1; do
  sleep 0.2
  i=$((i + 1))
done
kill -KILL $pid 2>/dev/null
wait $pid 2>/dev/null
# Trial processes of this batch only (their working folder is inside $tmp/k: another copy of this test
# may run at the same time), given up to 10 s to die on a loaded machine.
trials_alive() {
  for d in /proc/[0-9]*; do
    case "$(readlink "$d/cwd" 2>/dev/null)" in "$tmp"/k/*) return 0 ;; esac
  done
  return 1
}
i=0
while [ $i -lt 100 ] && trials_alive; do sleep 0.1; i=$((i + 1)); done
trials_alive && fail "trials still running 10 s after the batch was killed"
"$exe" batch "$m" --jobs 2 --resume -o "$tmp/k" >"$tmp/out" 2>&1
same_outputs "$tmp/j1" "$tmp/k" || fail "killed and resumed: other bytes than an uninterrupted run"

# --resume again: both finished trials skipped, the corrupt one tried again.
"$exe" batch "$m" --resume -o "$tmp/k" >"$tmp/out" 2>&1
grep -q "^s1,ngait_og3,gait,done-earlier," "$tmp/k/batch_summary.csv" || fail "--resume ran s1/ngait_og3 again"
grep -q "^s2,ngait_og1,gait,done-earlier," "$tmp/k/batch_summary.csv" || fail "--resume ran s2/ngait_og1 again"
grep -q "^s1,corrupt,gait,failed," "$tmp/k/batch_summary.csv" || fail "--resume skipped the failed trial"

# A damaged output makes its trial run again.
echo damaged >>"$tmp/k/s2/ngait_og1/s2_ngait_og1_contact_area.sto"
"$exe" batch "$m" --resume -o "$tmp/k" >/dev/null 2>&1
grep -q "^s2,ngait_og1,gait,done," "$tmp/k/batch_summary.csv" || fail "a damaged trial was not redone"
same_outputs "$tmp/j1" "$tmp/k" || fail "the redone trial differs"

# One step by hand from the trial's folder, as the setup's comment says.
(cd "$tmp/k/s2/ngait_og1" && "$exe" run s2_ngait_og1_contact.xml >/dev/null 2>&1) || fail "re-running a step by hand failed"
cmp -s "$tmp/k/s2/ngait_og1/s2_ngait_og1_contact_area.sto" "$tmp/j1/s2/ngait_og1/s2_ngait_og1_contact_area.sto" ||
  fail "the step re-run by hand wrote other bytes"

# --summary-only reads the files and runs nothing.
"$exe" batch "$m" --summary-only -o "$tmp/j1" >"$tmp/out" 2>&1
grep -q "2 of 3 trials finished, 1 failed" "$tmp/out" || fail "--summary-only: $(cat "$tmp/out")"

# A bad manifest: one line, exit 1, nothing run.
printf 'subject,trial,tools,model\ns1,t,ik+so,%s\n' "$src/models/jw-knee24/jw_knee24.osim" >"$tmp/bad.csv"
"$exe" batch "$tmp/bad.csv" >"$tmp/out" 2>"$tmp/err"
[ $? = 1 ] || fail "a bad manifest must exit 1"
[ "$(wc -l <"$tmp/err")" = 1 ] || fail "a bad manifest must be one line: $(cat "$tmp/err")"
grep -qF "bad.csv:2: row 1/tools: expected tools among ik, contact, workflow, got 'so'" "$tmp/err" ||
  fail "bad manifest message: $(cat "$tmp/err")"
[ -d "$tmp/bad_results" ] && fail "a bad manifest created its output folder"
printf 'subject,trial,tools,model,markers\ns1,t,ik,%s,%s\n' "$src/models/jw-knee24/jw_knee24.osim" "$tmp/none.c3d" >"$tmp/bad.csv"
"$exe" batch "$tmp/bad.csv" >"$tmp/out" 2>"$tmp/err"
[ $? = 1 ] && [ "$(wc -l <"$tmp/err")" = 1 ] &&
  grep -qF "bad.csv:2: row 1/markers: file not found: $tmp/none.c3d" "$tmp/err" || fail "a missing file: $(cat "$tmp/err")"

if [ $failures -gt 0 ]; then
  echo "$failures failure(s)"
  exit 1
fi
echo "kneesim batch: all checks passed"

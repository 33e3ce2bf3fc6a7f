#!/bin/sh
# Drives the kneesim command: --help, `kneesim run SETUP.xml`, the `kneesim ik` flag form and
# `kneesim compare-motion`; bad input must exit non-zero with ONE line on stderr naming the file
# and the element, and leave no output file behind.
#   kneesim_cli_test.sh <kneesim executable> <source dir> <data dir>
set -u
exe=$1 src=$2 data=$3
tmp=$(mktemp -d "${TMPDIR:-/tmp}/kneesim_cli.XXXXXX")
trap 'rm -rf "$tmp"' EXIT INT TERM
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

# expect_error <name> <expected exit> <substring> <command...>: exit status, one stderr line
# containing the substring, nothing on stdout.
expect_error() {
  name=$1 want=$2 needle=$3
  shift 3
  "$@" >"$tmp/out" 2>"$tmp/err"
  got=$?
  [ "$got" = "$want" ] || fail "$name: exit status $got, expected $want"
  lines=$(wc -l <"$tmp/err")
  [ "$lines" = 1 ] || { fail "$name: $lines lines on stderr, expected 1"; cat "$tmp/err"; }
  grep -qF -- "$needle" "$tmp/err" || fail "$name: stderr lacks '$needle': $(cat "$tmp/err")"
}

# A case folder with the chain fixture.
case_dir() {
  d="$tmp/$1"
  mkdir -p "$d/Geometry"
  cp "$src/tests/model/fixtures/chain40000.osim" "$d/"
  cp "$src/tests/model/fixtures/Geometry/box.stl" "$d/Geometry/"
  cp "$src/tests/ik/fixtures/chain_setup.xml" "$src/tests/ik/fixtures/chain.trc" "$d/"
  echo "$d"
}
# no_outputs <dir>: only the inputs are there.
no_outputs() {
  extra=$(cd "$1" && find . -type f ! -name chain40000.osim ! -name box.stl ! -name chain_setup.xml ! -name chain.trc | sort)
  [ -z "$extra" ] || fail "files left behind in $1: $extra"
}

# --help and usage errors.
"$exe" --help >"$tmp/help" 2>&1 || fail "--help exited with $?"
for word in run ik compare-motion; do grep -q "$word" "$tmp/help" || fail "--help does not mention $word"; done
"$exe" ik --help >"$tmp/help" 2>&1 || fail "ik --help exited with $?"
grep -q -- "--marker-rotation" "$tmp/help" || fail "ik --help does not mention --marker-rotation"
"$exe" >/dev/null 2>&1 && fail "no subcommand exited with 0"
"$exe" ik -m x.osim >/dev/null 2>&1 && fail "ik without --markers exited with 0"

# A good run of the chain fixture: exit 0, the summary, all five outputs.
d=$(case_dir good)
"$exe" run "$d/chain_setup.xml" >"$tmp/out" 2>"$tmp/err" || { fail "good run exited with $?"; cat "$tmp/err"; }
grep -q "IK: 20 of 20 frames solved" "$tmp/out" || fail "good run summary: $(head -3 "$tmp/out")"
for f in chain_ik.mot chain_ik_marker_errors.sto chain_ik_marker_error_table.sto chain_ik_marker_error_summary.csv \
         chain_ik_model_marker_locations.sto; do
  [ -f "$d/results/$f" ] || fail "good run did not write results/$f"
done

# Bad setups: one line naming the file, line and element; nothing written.
d=$(case_dir malformed)
sed -i 's|<weight>2</weight>|<weight>2</wieght>|' "$d/chain_setup.xml"
expect_error "malformed XML" 1 "$d/chain_setup.xml:" "$exe" run "$d/chain_setup.xml"
grep -qF "XML" "$tmp/err" || fail "malformed XML: $(cat "$tmp/err")"
no_outputs "$d"

d=$(case_dir nomodel)
sed -i 's|<model_file>chain40000.osim|<model_file>nope.osim|' "$d/chain_setup.xml"
expect_error "missing model" 1 "$d/chain_setup.xml:7: OpenSimDocument/InverseKinematicsTool[chain]/model_file: model file not found: $d/nope.osim" \
  "$exe" run "$d/chain_setup.xml"
no_outputs "$d"

d=$(case_dir range)
sed -i 's|<time_range>0 0.19|<time_range>5 6|' "$d/chain_setup.xml"
expect_error "time range" 1 "$d/chain_setup.xml:46: OpenSimDocument/InverseKinematicsTool[chain]/time_range: expected a time range" \
  "$exe" run "$d/chain_setup.xml"
no_outputs "$d"

d=$(case_dir units)
sed -i '3s|\tmm\t|\tfurlongs\t|' "$d/chain.trc"
expect_error "unknown units" 1 "$d/chain.trc:3:" "$exe" run "$d/chain_setup.xml"
no_outputs "$d"

d=$(case_dir tool)
sed -i 's|InverseKinematicsTool|ForwardTool|g' "$d/chain_setup.xml"
expect_error "unknown tool" 1 "unknown tool <ForwardTool>" "$exe" run "$d/chain_setup.xml"
no_outputs "$d"

expect_error "missing setup" 1 "$tmp/none.xml" "$exe" run "$tmp/none.xml"

# The flag form.
d=$(case_dir flags)
"$exe" -q ik -m "$d/chain40000.osim" -t "$d/chain.trc" -o "$d/out/flags.mot" --time-range 0 0.1 --accuracy 1e-8 \
  >"$tmp/out" 2>"$tmp/err" || { fail "ik flag form exited with $?"; cat "$tmp/err"; }
[ -f "$d/out/flags.mot" ] || fail "ik flag form wrote no motion"
[ -f "$d/out/flags_ik_marker_errors.sto" ] || fail "ik flag form wrote no error report"
[ -s "$tmp/out" ] && fail "-q printed a summary"
rows=$(grep -c '^0\.' "$d/out/flags.mot")
[ "$rows" = 11 ] || fail "ik flag form: $rows rows for 0..0.1 s at 100 Hz, expected 11"
expect_error "ik missing marker file" 1 "kneesim ik: --markers: marker file not found: $d/nope.trc" \
  "$exe" ik -m "$d/chain40000.osim" -t "$d/nope.trc" -o "$d/out2/x.mot"
[ -e "$d/out2" ] && fail "failed ik run created $d/out2"

# compare-motion: identical files pass; a tolerance of 0 fails only if they differ.
"$exe" compare-motion "$d/out/flags.mot" "$d/out/flags.mot" --tolerance 0 >"$tmp/out" 2>&1 \
  || fail "compare-motion of a file with itself exited with $?"
grep -q "PASS" "$tmp/out" || fail "compare-motion: $(tail -1 "$tmp/out")"
expect_error "compare-motion missing file" 1 "$tmp/none.mot" "$exe" compare-motion "$d/out/flags.mot" "$tmp/none.mot"
expect_error "synth unknown blind case" 1 "--cases: expected blind case names" \
  "$exe" synth "$src/share/gap/jw_gap.xml" --blind-suite --cases exponent,no_such_case
expect_error "synth malformed custom case" 1 "--cases: expected name:param=value" \
  "$exe" synth "$src/share/gap/jw_gap.xml" --blind-suite --cases "exponent:dm"
expect_error "gap unknown target" 1 "--targets: expected total, medial or lateral, got 'patellar'" \
  "$exe" gap "$src/share/gap/jw_gap.xml" --targets total,patellar
expect_error "synth one fold" 1 "--folds: expected 0 (leave one cycle out) or at least 2, got 1" \
  "$exe" synth "$src/share/gap/jw_gap.xml" --blind-suite --folds 1
expect_error "synth no seeds" 1 "--seeds: expected at least 1, got 0" \
  "$exe" synth "$src/share/gap/jw_gap.xml" --blind-suite --seeds 0
expect_error "synth negative noise" 1 "--noise: expected a standard deviation >= 0 N, got -1" \
  "$exe" synth "$src/share/gap/jw_gap.xml" --noise -1
expect_error "synth no replicates" 1 "--replicates: expected at least 1, got 0" \
  "$exe" synth "$src/share/gap/jw_gap.xml" --replicates 0

# OpenSim's regression case (data/opensim-ik-tests): kneesim run, then compare with OpenSim's answer.
if [ -f "$data/opensim-ik-tests/subject01_Setup_InverseKinematics.xml" ]; then
  mkdir -p "$tmp/opensim"
  cp "$data"/opensim-ik-tests/* "$tmp/opensim/"
  "$exe" run "$tmp/opensim/subject01_Setup_InverseKinematics.xml" >"$tmp/out" 2>"$tmp/err" \
    || { fail "OpenSim regression run exited with $?"; cat "$tmp/err"; }
  "$exe" compare-motion "$tmp/opensim/subject01_walk1_ik_test.mot" "$tmp/opensim/std_subject01_walk1_ik.mot" \
    --tolerance 0.02 >"$tmp/out" 2>&1 || { fail "OpenSim regression comparison exited with $?"; cat "$tmp/out"; }
  "$exe" compare-motion "$tmp/opensim/subject01_walk1_ik_test.mot" "$tmp/opensim/std_subject01_walk1_ik.mot" \
    --tolerance 0.0001 >/dev/null 2>&1
  [ $? = 3 ] || fail "compare-motion with a tolerance of 1e-4 deg should exit with 3"
else
  fail "$data/opensim-ik-tests/subject01_Setup_InverseKinematics.xml not found (docs/data.md)"
fi

[ "$failures" = 0 ] || { echo "$failures failure(s)"; exit 1; }
echo "kneesim command: all checks passed"

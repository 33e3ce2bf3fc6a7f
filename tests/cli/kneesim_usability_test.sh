#!/bin/sh
# The kneesim command as a well-kept tool: --version, global flags anywhere, `model info` and
# `model check`, compare-motion interpolating in time, bash completion and the manual page naming
# every subcommand.
#   kneesim_usability_test.sh <kneesim executable> <source dir> <data dir>
set -u
exe=$1 src=$2 data=$3
tmp=$(mktemp -d "${TMPDIR:-/tmp}/kneesim_usability.XXXXXX")
trap 'rm -rf "$tmp"' EXIT INT TERM
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

# --version prints the project's version.
version=$(grep -o 'project(kneesim VERSION [0-9.]*' "$src/CMakeLists.txt" | awk '{print $3}')
[ "$("$exe" --version)" = "kneesim $version" ] || fail "--version printed '$("$exe" --version)', expected 'kneesim $version'"

# -q after the subcommand is the global flag, not an error.
mkdir -p "$tmp/flags"
cp "$src/tests/model/fixtures/chain40000.osim" "$src/tests/ik/fixtures/chain.trc" "$tmp/flags/"
"$exe" ik -m "$tmp/flags/chain40000.osim" -t "$tmp/flags/chain.trc" -o "$tmp/flags/q.mot" -q >"$tmp/out" 2>"$tmp/err" \
  || { fail "ik ... -q exited with $?"; cat "$tmp/err"; }
[ -s "$tmp/out" ] && fail "-q after the subcommand still printed a summary"
# The IK motion's header is OpenSim's: "Coordinates" first, its two lines on units.
head -1 "$tmp/flags/q.mot" | grep -qx "Coordinates" || fail "IK motion's first line: $(head -1 "$tmp/flags/q.mot")"
grep -qx "Units are S.I. units (second, meters, Newtons, ...)" "$tmp/flags/q.mot" || fail "IK motion lacks OpenSim's units line"

# model info: the constraint fixture's joints, coordinates with ranges, constraints.
"$exe" model info "$src/tests/ik/fixtures/constraints40000.osim" >"$tmp/info" 2>&1 || fail "model info exited with $?"
for needle in "format: OpenSim document version 40000" "7 bodies besides ground" "FreeJoint ground -> cube" \
              "q_crank                     rotational  default         0  range -360.963 to 360.963" \
              "4 constraints:" "WeldConstraint crank - cube" "ConstantDistanceConstraint pendulum - rocker, distance 1.5 m" \
              "every component is simulated"; do
  grep -qF -- "$needle" "$tmp/info" || fail "model info lacks '$needle'"
done
# ... the muscles it simulates (arm26: 6 Thelen2003 muscles, TRIlong over 3 wraps) ...
"$exe" model info "$data/opensim-dynamics-tests/so/arm26.osim" >"$tmp/info" 2>&1
grep -qF "6 muscles (paths, lengths and moment arms; forces in static optimization and joint reaction):" "$tmp/info" \
  && grep -qF "TRIlong                  Thelen2003Muscle, max isometric force 798.52 N, 5 path points, 3 wraps" "$tmp/info" \
  || fail "model info does not list arm26's muscles: $(grep -i muscle "$tmp/info" | head -3)"
# ... and every component kept out, with its type; the ones that pose the model are flagged.
"$exe" model info "$src/tests/model/corpus/testMocoMetabolics_hanging_muscle_40600.osim" >"$tmp/info" 2>&1
grep -qF "muscle                   DeGrooteFregly2016Muscle (muscle)" "$tmp/info" || fail "model info: $(tail -3 "$tmp/info")"
sed 's|</ForceSet>|<objects><Blankevoort1991Ligament name="acl"/></objects></ForceSet>|' \
  "$src/tests/model/corpus/knee_patella_ligament.osim" | sed 's|<objects/>||' >"$tmp/ligament.osim"
"$exe" model info "$tmp/ligament.osim" >"$tmp/info" 2>&1
grep -qF "acl                      Blankevoort1991Ligament (ligament, poses the model in OpenSim)" "$tmp/info" \
  || fail "model info does not flag the ligament: $(tail -4 "$tmp/info")"
grep -q "^warning: .*1 ligament (Blankevoort1991Ligament) not simulated; in OpenSim they help decide where the bodies go" \
  "$tmp/info" || fail "model info: no kinematics warning: $(tail -2 "$tmp/info")"

# model check: OK and exit 0 on a good model; a one-line error and exit 1 on a missing one.
"$exe" model check "$src/tests/model/fixtures/shoulder40000.osim" >"$tmp/out" 2>&1 || fail "model check exited with $?"
grep -q ": OK; format 40000" "$tmp/out" || fail "model check: $(cat "$tmp/out")"
"$exe" model check "$tmp/nope.osim" >"$tmp/out" 2>"$tmp/err" && fail "model check of a missing file exited with 0"
grep -qF "$tmp/nope.osim: model file not found" "$tmp/err" || fail "model check missing file: $(cat "$tmp/err")"

# compare-motion: times that do not line up are interpolated, and it says so.
printf 'a\nversion=1\nnRows=3\nnColumns=2\ninDegrees=yes\nendheader\ntime\tx\n0.05\t0.5\n0.15\t2.0\n0.3\t9\n' >"$tmp/a.mot"
printf 'b\nversion=1\nnRows=3\nnColumns=2\ninDegrees=yes\nendheader\ntime\tx\n0\t0\n0.1\t1\n0.2\t4\n' >"$tmp/b.mot"
"$exe" compare-motion "$tmp/a.mot" "$tmp/b.mot" >"$tmp/out" 2>&1 || fail "compare-motion exited with $?"
grep -qF "2 rows compared (3 in $tmp/a.mot, 3 in $tmp/b.mot): 0 at the same time, 2 with $tmp/b.mot interpolated linearly, 1 outside its time span left out" "$tmp/out" \
  || fail "compare-motion: $(head -1 "$tmp/out")"
grep -q "x  *0.353553  *0.500000" "$tmp/out" || fail "compare-motion column: $(grep ' x ' "$tmp/out")"

# OpenSim's IK case (data/, always there): its TRC times have 3 decimals, OpenSim's answer
# more; every row compares.
if [ -f "$data/opensim-ik-tests/subject01_Setup_InverseKinematics.xml" ]; then
  mkdir -p "$tmp/opensim"
  cp "$data"/opensim-ik-tests/* "$tmp/opensim/"
  "$exe" -q run "$tmp/opensim/subject01_Setup_InverseKinematics.xml" || fail "OpenSim IK case exited with $?"
  "$exe" compare-motion "$tmp/opensim/subject01_walk1_ik_test.mot" "$tmp/opensim/std_subject01_walk1_ik.mot" >"$tmp/out" 2>&1
  grep -q "^73 rows compared" "$tmp/out" || fail "OpenSim IK comparison: $(head -1 "$tmp/out")"
else
  fail "no $data/opensim-ik-tests/subject01_Setup_InverseKinematics.xml (KNEESIM_DATA_DIR)"
fi

# Bash completion: subcommands, options of the subcommand typed, and `model`'s subcommands.
if command -v bash >/dev/null; then
  cat >"$tmp/complete.sh" <<EOS
KNEESIM_COMPLETION_COMMAND="$exe"
. "$src/tools/kneesim/kneesim.bash-completion"
complete_words() { COMP_WORDS=("\$@"); COMP_CWORD=\$((\${#COMP_WORDS[@]} - 1)); _kneesim; echo "\${COMPREPLY[*]}"; }
echo "top: \$(complete_words kneesim '')"
echo "co: \$(complete_words kneesim co)"
echo "ik: \$(complete_words kneesim ik --ma)"
echo "model: \$(complete_words kneesim model '')"
echo "check: \$(complete_words kneesim model check --fr)"
EOS
  bash "$tmp/complete.sh" >"$tmp/out" 2>&1 || fail "completion script failed: $(cat "$tmp/out")"
  grep -q "^top: .*run.*ik.*compare-motion.*model" "$tmp/out" || fail "completion of subcommands: $(grep top "$tmp/out")"
  grep -qx "co: compare-motion" "$tmp/out" || fail "completion of 'co': $(grep '^co' "$tmp/out")"
  grep -qx "ik: --markers --marker-rotation --marker-locations" "$tmp/out" || fail "completion of ik --ma: $(grep '^ik' "$tmp/out")"
  grep -qx "model: info check" "$tmp/out" || fail "completion of model: $(grep '^model' "$tmp/out")"
  grep -qx "check: --frames" "$tmp/out" || fail "completion of model check --fr: $(grep '^check' "$tmp/out")"
fi

# The manual page renders without warnings and has a section for every subcommand.
man=$src/tools/kneesim/kneesim.1
if command -v groff >/dev/null; then
  groff -man -Tutf8 -ww -z "$man" 2>"$tmp/err" || fail "groff failed on the manual page"
  [ -s "$tmp/err" ] && fail "groff warnings: $(cat "$tmp/err")"
fi
sed 's/\\-/-/g' "$man" >"$tmp/man"  # roff writes a hyphen as \-
for sub in $("$exe" --help | awk '/^Subcommands:$/{s=1;next} s && /^  [a-z]/{print $1}'); do
  grep -q "^\.SS $sub\b" "$tmp/man" || fail "the manual page has no section for '$sub'"
done
for sub in $("$exe" model --help | awk '/^Subcommands:$/{s=1;next} s && /^  [a-z]/{print $1}'); do
  grep -q "^\.SS model $sub\b" "$tmp/man" || fail "the manual page has no section for 'model $sub'"
  "$exe" model "$sub" --help >/dev/null || fail "model $sub --help exited with $?"
done

[ "$failures" = 0 ] || { echo "$failures failure(s)"; exit 1; }
echo "kneesim usability: all checks passed"

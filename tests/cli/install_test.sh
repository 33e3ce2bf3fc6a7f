#!/bin/sh
# A prefix install runs from any prefix: `cmake --install` into a scratch prefix, the prefix
# moved elsewhere, then the installed kneesim prints its version and runs the IK case (its
# RUNPATH is $ORIGIN/../lib); the engine finds its plugins under the prefix.
#   install_test.sh <build dir> <source dir> <data dir>
set -u
build=$1 src=$2 data=$3
tmp=$(mktemp -d "${TMPDIR:-/tmp}/kneesim_install.XXXXXX")
trap 'rm -rf "$tmp"' EXIT INT TERM
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

cmake --install "$build" --prefix "$tmp/p" >"$tmp/log" 2>&1 || { cat "$tmp/log"; echo "FAIL: cmake --install"; exit 1; }
mv "$tmp/p" "$tmp/moved"  # nothing may point into the prefix it was installed to
exe=$tmp/moved/bin/kneesim
[ -x "$exe" ] || { echo "FAIL: no $exe"; exit 1; }
runpath=$(readelf -d "$exe" | sed -n 's/.*R\(UN\)\{0,1\}PATH.*\[\(.*\)\]/\2/p')
[ "$runpath" = '$ORIGIN/../lib' ] || fail "RUNPATH of bin/kneesim is '$runpath', expected '\$ORIGIN/../lib'"
env -u LD_LIBRARY_PATH "$exe" --version >"$tmp/out" 2>&1 || fail "installed kneesim --version exited with $?: $(cat "$tmp/out")"
grep -q "^kneesim [0-9]" "$tmp/out" || fail "installed --version: $(cat "$tmp/out")"
[ -f "$tmp/moved/share/man/man1/kneesim.1" ] || fail "no manual page installed"
[ -f "$tmp/moved/share/bash-completion/completions/kneesim" ] || fail "no bash completion installed"

# The OpenSim IK case (data/, always there) from the moved prefix, against OpenSim's answer.
[ -f "$data/opensim-ik-tests/subject01_Setup_InverseKinematics.xml" ] \
  || { echo "FAIL: no $data/opensim-ik-tests/subject01_Setup_InverseKinematics.xml (KNEESIM_DATA_DIR)"; exit 1; }
mkdir -p "$tmp/case"
cp "$data"/opensim-ik-tests/* "$tmp/case/"
env -u LD_LIBRARY_PATH "$exe" -q run "$tmp/case/subject01_Setup_InverseKinematics.xml" >"$tmp/out" 2>&1 \
  || fail "installed kneesim run exited with $?: $(cat "$tmp/out")"
env -u LD_LIBRARY_PATH "$exe" compare-motion "$tmp/case/subject01_walk1_ik_test.mot" "$tmp/case/std_subject01_walk1_ik.mot" \
  --tolerance 0.2 >"$tmp/out" 2>&1 || fail "installed IK against OpenSim's answer: $(tail -2 "$tmp/out")"
# Plugins: installed under lib/kneesim/plugins, and the installed engine looks there first (the
# one-line error for a plugin that does not exist lists the folders it searched).
[ -f "$tmp/moved/lib/kneesim/plugins/libkneesim_hertz.so" ] || fail "no plugin installed under lib/kneesim/plugins"
sed 's|<plugins>[^<]*</plugins>|<plugins>no_such_plugin</plugins>|' "$src/share/gap/jw_gap.xml" >"$tmp/gap.xml"
env -u LD_LIBRARY_PATH "$exe" gap "$tmp/gap.xml" >"$tmp/out" 2>&1 && fail "a setup naming no_such_plugin exited with 0"
grep -qF "in: $tmp/moved/lib/kneesim/plugins," "$tmp/out" || fail "plugins not looked for under the moved prefix: $(cat "$tmp/out")"

[ "$failures" = 0 ] || { echo "$failures failure(s)"; exit 1; }
echo "prefix install: all checks passed"

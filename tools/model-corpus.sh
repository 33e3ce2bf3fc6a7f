#!/bin/sh
# Loads every OpenSim model (.osim) under DIR with kneesim and runs the IK round trip on it
# (`kneesim model check`), then prints a Markdown table: what loads, what passes, and for each
# model that does not, why (the one-line error). Fetches nothing: point it at a checkout of
# opensim-models, opensim-core or opensim-jam, or at tests/model/corpus (the suite does).
#   tools/model-corpus.sh DIR            (KNEESIM=path/to/kneesim, default: kneesim on PATH)
# Exit status: 0 when every model loads and passes, 1 otherwise.
set -u
if [ $# -ne 1 ] || [ ! -d "$1" ]; then
  echo "usage: $0 DIR   (every .osim under DIR; KNEESIM names the kneesim executable)" >&2
  exit 2
fi
dir=$1
exe=${KNEESIM:-kneesim}
tmp=$(mktemp -d "${TMPDIR:-/tmp}/kneesim_corpus.XXXXXX")
trap 'rm -rf "$tmp"' EXIT INT TERM

total=0 loaded=0 passed=0
echo "| model | result | format | bodies | coordinates | constraints (+couplers) | markers | IK RMS (mm) | constraint error | not simulated (posing) |"
echo "|---|---|---|---|---|---|---|---|---|---|"
find "$dir" -name '*.osim' -type f | LC_ALL=C sort >"$tmp/list"
while IFS= read -r f; do
  total=$((total + 1))
  name=${f#"$dir"/}
  if "$exe" model check --tsv "$f" >"$tmp/out" 2>"$tmp/err" </dev/null; then status=0; else status=$?; fi
  if [ -s "$tmp/out" ]; then
    loaded=$((loaded + 1))
    [ "$status" = 0 ] && passed=$((passed + 1))
    awk -F '\t' -v name="$name" '{
      printf "| %s | %s | %s | %s | %s | %s (+%s) | %s | %s | %s | %s (%s) |\n",
        name, ($2 == "OK" ? "loads, IK OK" : "loads, IK off"), $3, $4, $5, $6, $7, $8, $9, $11, $12, $13 }' "$tmp/out"
  else
    # The one-line error, without the file's path (the first column names it).
    why=$(head -1 "$tmp/err" | sed "s|kneesim: error: ||; s|$f:||" | sed 's/|/\\|/g')
    echo "| $name | does not load | | | | | | | | $why |"
  fi
done <"$tmp/list"
echo
echo "$total models: $loaded load, $passed pass the IK round trip (RMS <= 0.01 mm, constraints within 1e-6)."
[ "$total" -gt 0 ] && [ "$passed" = "$total" ]

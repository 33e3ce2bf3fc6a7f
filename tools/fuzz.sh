#!/bin/sh
# Builds the fuzz tree (clang, ASan + UBSan, libFuzzer; fuzz/ and docs/fuzzing.md) and runs each fuzz
# target for SECONDS: first on its reproducers (tests/*/fixtures/fuzz/<target>/, inputs that once
# failed), then fuzzing from its corpus. Prints per target the executions, exec/s, coverage (edges),
# corpus size and findings.
#
#   tools/fuzz.sh [options] SECONDS [TARGET...]      (every target when none is named)
#     --build-dir DIR  the fuzz tree (default: build-fuzz in the repository)
#     --out DIR        the campaign folder, outside the repository (default:
#                      ${KNEESIM_FUZZ_OUT:-$HOME/.cache/kneesim-fuzz}); it keeps each target's
#                      corpus (corpus/<target>, grown run after run), findings (findings/<target>/),
#                      logs (logs/<target>.log) and summary.tsv (a row per target and run)
#     --runs N         stop a target after N executions (or SECONDS, whichever comes first)
#     --seed N         libFuzzer's random seed (default: a new one per run); with --runs, a run
#                      repeats itself on the same code: the same inputs in the same order
#     --no-build       run the targets as built
#     --build-only     configure and build, run nothing
#     --check          the test suite's mode: each target starts from its seeds (its corpus and
#                      findings in --out are emptied first), one input may take 60 s (not 10: a
#                      loaded machine is no finding), and with --seed and --runs a run repeats
#                      itself (no timed corpus re-reading, no address randomisation when allowed)
#     --list           print the targets and exit
# A finding stops its target (libFuzzer's behaviour); the input is in findings/<target>/ and the log
# holds the report. The exit status is 1 when a target found something or a reproducer failed.
# Run long campaigns under `nice -n 19`.
set -eu
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$root/build-fuzz"
out="${KNEESIM_FUZZ_OUT:-${HOME:-/tmp}/.cache/kneesim-fuzz}"
runs=""
seed=""
do_build=1
run=1
check=0
list=0
while [ $# -gt 0 ]; do
  case "$1" in
    --build-dir) build="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --runs) runs="$2"; shift 2 ;;
    --seed) seed="$2"; shift 2 ;;
    --no-build) do_build=0; shift ;;
    --build-only) run=0; shift ;;
    --check) check=1; shift ;;
    --list) list=1; shift ;;
    -h|--help) sed -n '2,/^set -eu/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    --*) echo "fuzz.sh: unknown option $1" >&2; exit 2 ;;
    *) break ;;
  esac
done

all_targets=$(sed -n 's/^kneesim_fuzz_target(\([a-z0-9_]*\).*/\1/p' "$root/fuzz/targets.cmake")
if [ "$list" = 1 ]; then echo "$all_targets"; exit 0; fi
if [ "$run" = 1 ]; then
  [ $# -ge 1 ] || { echo "usage: tools/fuzz.sh [options] SECONDS [TARGET...] (--help)" >&2; exit 2; }
  seconds="$1"; shift
  case "$seconds" in ''|*[!0-9]*) echo "fuzz.sh: SECONDS must be a whole number, got '$seconds'" >&2; exit 2 ;; esac
fi
targets="${*:-$all_targets}"
for n in "$runs" "$seed"; do
  case "$n" in *[!0-9]*) echo "fuzz.sh: --runs and --seed take a whole number, got '$n'" >&2; exit 2 ;; esac
done
for t in $targets; do
  echo "$all_targets" | grep -qx "$t" || { echo "fuzz.sh: unknown target '$t' (tools/fuzz.sh --list)" >&2; exit 2; }
done

if [ "$do_build" = 1 ]; then
  command -v clang++ >/dev/null || { echo "fuzz.sh: clang++ not found (tools/install-deps.sh installs clang)" >&2; exit 2; }
  cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
        -DKNEESIM_FUZZ=ON >/dev/null
  fuzz_targets=""
  for t in $targets; do fuzz_targets="$fuzz_targets fuzz_$t"; done
  # shellcheck disable=SC2086
  cmake --build "$build" -j"${KNEESIM_FUZZ_BUILD_JOBS:-$(nproc)}" --target $fuzz_targets
fi
[ "$run" = 1 ] || exit 0

# libFuzzer's options for every target. The suite's mode repeats itself: no timed re-reading of the
# corpus folder (-reload) and, when setarch can, no address randomisation (compares of pointers
# steer libFuzzer's mutations).
options=""
[ -n "$runs" ] && options="$options -runs=$runs"
[ -n "$seed" ] && options="$options -seed=$seed"
norand=""
if [ "$check" = 1 ]; then
  options="$options -timeout=60 -reload=0"
  if setarch "$(uname -m)" -R true 2>/dev/null; then norand="setarch $(uname -m) -R"; fi
else
  options="$options -timeout=10"
fi

mkdir -p "$out/logs"
[ -f "$out/summary.tsv" ] || printf 'date\ttarget\tseconds\texecutions\texec_per_s\tedges\tfeatures\tcorpus\tfindings\n' >"$out/summary.tsv"
printf '%-20s %12s %8s %7s %7s %9s  %s\n' target executions exec/s edges corpus findings log
status=0
for t in $targets; do
  bin="$build/fuzz/fuzz_$t"
  [ -x "$bin" ] || { echo "fuzz.sh: $bin is not built" >&2; exit 2; }
  log="$out/logs/$t.log"
  findings="$out/findings/$t"
  corpus="$out/corpus/$t"
  if [ "$check" = 1 ]; then rm -rf "$findings" "$corpus"; fi
  mkdir -p "$findings" "$corpus"
  : >"$log"
  before=$(find "$findings" -type f | wc -l)
  # The inputs that once failed: each must now pass (be read or refused with an InputError).
  repro=$(find "$root"/tests/*/fixtures/fuzz/"$t" -type f 2>/dev/null | sort || true)
  if [ -n "$repro" ]; then
    # shellcheck disable=SC2086
    if ! "$bin" -rss_limit_mb=2048 -malloc_limit_mb=1024 -timeout=30 $repro >>"$log" 2>&1; then
      echo "fuzz.sh: $t: a reproducer fails again (see $log)" >&2
      status=1
      continue
    fi
  fi
  dict=""
  [ -f "$root/fuzz/dict/$t.dict" ] && dict="-dict=$root/fuzz/dict/$t.dict"
  set +e
  # shellcheck disable=SC2086
  $norand "$bin" -max_total_time="$seconds" $options $dict -print_final_stats=1 -rss_limit_mb=2048 \
    -malloc_limit_mb=1024 -max_len=65536 -artifact_prefix="$findings/" "$corpus" "$root/fuzz/corpus/$t" >>"$log" 2>&1
  rc=$?
  set -e
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -n 1)
  edges=$(grep -o 'cov: [0-9]*' "$log" | tail -n 1 | cut -d' ' -f2)
  features=$(grep -o 'ft: [0-9]*' "$log" | tail -n 1 | cut -d' ' -f2)
  size=$(find "$corpus" -type f | wc -l)
  new=$(( $(find "$findings" -type f | wc -l) - before ))
  if [ "$rc" != 0 ] && [ "$new" = 0 ]; then new=1; fi  # a failure that wrote no input (e.g. at start-up)
  [ "$new" = 0 ] || status=1
  printf '%-20s %12s %8s %7s %7s %9s  %s\n' "$t" "${execs:-?}" "${rate:-?}" "${edges:-?}" "$size" "$new" "$log"
  printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$(date -u +%Y-%m-%dT%H:%M:%SZ)" "$t" "$seconds" "${execs:-}" \
    "${rate:-}" "${edges:-}" "${features:-}" "$size" "$new" >>"$out/summary.tsv"
done
exit $status

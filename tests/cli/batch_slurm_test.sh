#!/bin/sh
# The Slurm submission of `kneesim batch --emit-slurm`, on a real single-node Slurm started here:
# its own munge key and socket, slurmctld and slurmd on localhost (proctrack/linuxproc, no
# cgroups, no accounting), configuration and state in a temporary folder. The job array and its
# dependent summary job must write the same bytes as `kneesim batch --jobs 2`, the corrupt trial
# failing alone both ways. Everything started here is stopped on exit.
# Skips (exit 77) unless it runs as root with slurm-wlm and munge installed
# (tools/install-deps.sh installs them).
#   batch_slurm_test.sh <kneesim executable> <source dir> <data dir>
set -u
exe=$1 src=$2 data=$3
for p in munged slurmctld slurmd sbatch squeue sinfo scancel; do
  command -v $p >/dev/null 2>&1 || PATH="$PATH:/usr/sbin"
  command -v $p >/dev/null 2>&1 || { echo "skipped: $p is not installed (apt-get install slurm-wlm munge)"; exit 77; }
done
[ "$(id -u)" = 0 ] || { echo "skipped: starting slurmd and munged needs root"; exit 77; }
if [ ! -f "$data/kgc4-jw/markers/jw_ngait_og3.c3d" ]; then
  echo "JW's data are not in $data"
  exit 1
fi
. "$src/tests/cli/batch_common.sh"
tmp=$(mktemp -d "${TMPDIR:-/tmp}/kneesim_slurm.XXXXXX")
chmod 755 "$tmp"
pids=""
cleanup() {
  [ -n "${SLURM_CONF:-}" ] && scancel --quiet --user=root >/dev/null 2>&1 && sleep 1
  for pid in $pids; do kill "$pid" 2>/dev/null; done
  for pid in $pids; do wait "$pid" 2>/dev/null; done
  rm -rf "$tmp"
}
trap cleanup EXIT
trap 'exit 1' INT TERM
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

# munge: a fresh key and a socket of our own.
mkdir -p "$tmp/munge" "$tmp/state" "$tmp/spool"
chmod 700 "$tmp/munge"
dd if=/dev/urandom of="$tmp/munge/munge.key" bs=1024 count=1 status=none
chmod 600 "$tmp/munge/munge.key"
munged -F --force --key-file="$tmp/munge/munge.key" --socket="$tmp/munge/munge.socket" \
  --pid-file="$tmp/munge/munged.pid" --log-file="$tmp/munge/munged.log" --seed-file="$tmp/munge/munged.seed" &
pids="$pids $!"

# Slurm: one node, this machine; ports chosen from this shell's pid to stay clear of another run.
host=$(hostname -s)
port=$((20000 + ($$ % 5000) * 2))
mem=$(awk '/MemTotal/ { print int($2 / 1024 * 0.8) }' /proc/meminfo)
cat >"$tmp/slurm.conf" <<CONF
ClusterName=kneesimtest
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$port
SlurmdPort=$((port + 1))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$tmp/munge/munge.socket
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool/%n
SlurmctldPidFile=$tmp/slurmctld.pid
SlurmdPidFile=$tmp/slurmd.pid
SlurmctldLogFile=$tmp/slurmctld.log
SlurmdLogFile=$tmp/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/builtin
MpiDefault=none
ReturnToService=2
MessageTimeout=60
NodeName=$host NodeAddr=127.0.0.1 CPUs=$(nproc) RealMemory=$mem State=UNKNOWN
PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$tmp/slurm.conf"
i=0
while [ ! -S "$tmp/munge/munge.socket" ] && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
slurmctld -D -c -f "$SLURM_CONF" >"$tmp/slurmctld.out" 2>&1 &
pids="$pids $!"
slurmd -D -f "$SLURM_CONF" -N "$host" >"$tmp/slurmd.out" 2>&1 &
pids="$pids $!"
i=0
until sinfo -h -o %t 2>/dev/null | grep -q idle; do
  i=$((i + 1))
  if [ $i -gt 120 ]; then
    echo "FAIL: the single-node Slurm did not come up"
    tail -n 20 "$tmp/slurmctld.log" "$tmp/slurmd.log" "$tmp/slurmctld.out" "$tmp/slurmd.out" 2>/dev/null
    exit 1
  fi
  sleep 0.5
done

# The submission, exactly as a user makes it.
m="$tmp/cohort.csv"
write_manifest "$m" "$src" "$data" "$tmp"
"$exe" batch "$m" --emit-slurm "$tmp/job" -o "$tmp/cluster" --time 00:30:00 --mem 1G >"$tmp/emit.out" 2>&1 ||
  { fail "--emit-slurm exited with $?"; cat "$tmp/emit.out"; }
sh "$tmp/job/submit.sh" >"$tmp/submit.out" 2>&1 || { fail "submit.sh exited with $?"; cat "$tmp/submit.out"; }
grep -q "submitted array job [0-9]* (3 tasks) and summary job [0-9]*" "$tmp/submit.out" || fail "submit.sh: $(cat "$tmp/submit.out")"
# Until squeue answers with no job left (on a loaded machine it can time out: an empty answer
# from a failed squeue is not an empty queue).
i=0
until queue=$(squeue -h 2>"$tmp/squeue.err") && [ -z "$queue" ]; do
  i=$((i + 1))
  [ $i -gt 1200 ] && { fail "jobs still queued after 10 minutes: $queue $(cat "$tmp/squeue.err")"; break; }
  sleep 0.5
done
[ -f "$tmp/cluster/batch_summary.csv" ] || { fail "the summary job wrote no batch_summary.csv"; cat "$tmp"/job/logs/* 2>/dev/null; }
grep -q "2 of 3 trials finished, 1 failed" "$tmp"/job/logs/*summary* 2>/dev/null || fail "summary job output: $(cat "$tmp"/job/logs/*summary* 2>/dev/null)"

# The same manifest on this machine: the same bytes.
"$exe" batch "$m" --jobs 2 -o "$tmp/local" >/dev/null 2>&1
same_outputs "$tmp/local" "$tmp/cluster" || fail "the Slurm run wrote other bytes than kneesim batch"
grep -q "^s1,corrupt,gait,failed,.*jw_corrupt.c3d" "$tmp/cluster/batch_summary.csv" || fail "the corrupt trial is not reported as failed"

if [ $failures -gt 0 ]; then
  echo "$failures failure(s)"
  tail -n 20 "$tmp/submit.out" "$tmp"/job/logs/* "$tmp/slurmctld.log" "$tmp/slurmd.log" 2>/dev/null
  exit 1
fi
echo "Slurm job array and kneesim batch: the same outputs"

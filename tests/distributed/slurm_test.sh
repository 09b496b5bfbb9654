#!/usr/bin/env bash
# A real single-node Slurm for one test: munged with its own key and socket, slurmctld and slurmd
# with a generated slurm.conf in a temporary folder (private ports, state and logs), then the job
# array of scripts/slurm (tile parts, then sample ranges) with its dependent merge job; the merged
# images must equal the one-process render byte for byte. Every daemon is stopped on exit. Exits 77
# (ctest's skip) with one line where it cannot run: not root, Slurm/munge not installed, or a
# hostname that does not resolve (a minimal container or chroot: slurmctld and slurmd find the node
# by that name, and without it sinfo would only time out).
# Usage: slurm_test.sh TRITRACE SCRIPTS_SLURM_DIR
# SLURM_TEST_HOST replaces `hostname -s` as the node's name (to check the skip with a bogus name).
set -euo pipefail
cli=$1
scripts=$(cd "$2" && pwd)
case "$cli" in */*) cli=$(readlink -f "$cli") ;; esac
skip() { echo "slurm_test: skipped: $*"; exit 77; }
fail() { echo "slurm_test: $*" >&2; exit 1; }
trap 'echo "slurm_test: failed at line $LINENO" >&2' ERR
host=${SLURM_TEST_HOST:-$(hostname -s)}
# The same lookup (NSS, getaddrinfo) that the daemons make; timeout bounds a slow resolver.
timeout 5 getent hosts "$host" >/dev/null ||
  skip "this machine's hostname '$host' does not resolve (getent hosts), and slurmctld and slurmd need it"
[ "$(id -u)" -eq 0 ] || skip "needs root to start slurmd and munged"
for tool in munged slurmctld slurmd sbatch squeue sacct scontrol; do
  command -v "$tool" >/dev/null || skip "$tool is not installed (scripts/install-deps.sh)"
done

dir=$(mktemp -d /tmp/tritrace-slurm.XXXXXX)
chmod 755 "$dir"
pids=()
# Every process of this test's Slurm (slurmstepd and job steps included) carries its SLURM_CONF.
own_processes() {
  local p
  for p in /proc/[0-9]*; do
    if { tr '\0' '\n' <"$p/environ"; } 2>/dev/null | grep -qx "SLURM_CONF=$dir/slurm.conf"; then
      echo "${p#/proc/}"
    fi
  done
}
cleanup() {
  if [ -n "${SLURM_CONF:-}" ]; then scancel --quiet --full -u root 2>/dev/null || true; fi
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
  for pid in "${pids[@]}"; do
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    kill -9 "$pid" 2>/dev/null || true
  done
  unset SLURM_CONF  # so that the scan's own tr and grep do not match
  for pid in $(own_processes); do kill -9 "$pid" 2>/dev/null || true; done
  rm -rf "$dir"
}
trap cleanup EXIT

# Ports nobody listens on (the machine may run other Slurms).
free_port() {
  local p
  for _ in $(seq 100); do
    p=$((20000 + RANDOM % 20000))
    if ! (exec 3<>"/dev/tcp/127.0.0.1/$p") 2>/dev/null; then echo "$p"; return; fi
  done
  fail "no free port"
}
ctld_port=$(free_port)
d_port=$(free_port)
[ "$ctld_port" != "$d_port" ] || d_port=$((d_port + 1))
cpus=$(nproc)

mkdir -p "$dir/munge" "$dir/state" "$dir/spool" "$dir/parts" "$dir/out"
dd if=/dev/urandom of="$dir/munge/munge.key" bs=1024 count=1 status=none
chmod 700 "$dir/munge"
chmod 400 "$dir/munge/munge.key"
munged --force --key-file="$dir/munge/munge.key" --socket="$dir/munge/munge.sock" \
  --pid-file="$dir/munge/munged.pid" --log-file="$dir/munge/munged.log" \
  --seed-file="$dir/munge/munged.seed" || skip "munged does not start here"
pids+=("$(cat "$dir/munge/munged.pid")")

cat >"$dir/slurm.conf" <<CONF
ClusterName=tritrace-test
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
SlurmctldPort=$ctld_port
SlurmdPort=$d_port
AuthType=auth/munge
AuthInfo=socket=$dir/munge/munge.sock
CredType=cred/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
MpiDefault=none
ReturnToService=2
SlurmdTimeout=30
InactiveLimit=0
MinJobAge=300
NodeName=$host CPUs=$cpus State=UNKNOWN
PartitionName=test Nodes=$host Default=YES MaxTime=INFINITE State=UP OverSubscribe=FORCE:4
CONF
export SLURM_CONF="$dir/slurm.conf"

slurmctld -D -i -f "$SLURM_CONF" >"$dir/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -f "$SLURM_CONF" -N "$host" >"$dir/slurmd.out" 2>&1 &
pids+=($!)

# Wait (at most 30 s, however long each sinfo takes) for the node to be idle.
deadline=$((SECONDS + 30))
while [ "$SECONDS" -lt "$deadline" ]; do
  state=$(timeout 5 sinfo -h -n "$host" -o %t 2>/dev/null || true)
  [ "$state" = "idle" ] && break
  sleep 0.2
done
if [ "${state:-}" != "idle" ]; then
  tail -n 5 "$dir/slurmctld.log" "$dir/slurmd.log" >&2 || true
  fail "the test's Slurm node did not come up (state '${state:-none}')"
fi

scene=(--scene cornell-area --spp 20 --width 48 --height 40 --threads 1 -q)
"$cli" render "${scene[@]}" -o "$dir/one.pfm"

# Waits (at most 120 s) until job $1 has ended (MinJobAge keeps its record), then checks that it
# completed. A merge whose array failed would wait forever: its dependency is reported instead.
wait_job() {
  local info st=
  for _ in $(seq "${SLURM_TEST_WAIT:-600}"); do
    info=$(scontrol -o show job "$1" 2>/dev/null || true)
    st=$(grep -o 'JobState=[A-Z_]*' <<<"$info" | head -n 1 || true)
    case "$st" in
      JobState=PENDING | JobState=RUNNING | JobState=CONFIGURING | JobState=COMPLETING | "") ;;
      *) break ;;
    esac
    if grep -q 'Reason=DependencyNeverSatisfied' <<<"$info"; then
      tail -n 3 "$dir"/out/*.log >&2 2>/dev/null || true
      fail "job $1 waits for an array task that failed"
    fi
    sleep 0.2
  done
  if [ "$st" != "JobState=COMPLETED" ]; then
    squeue -o "%i %T %r" >&2 || true
    tail -n 3 "$dir"/out/*.log >&2 2>/dev/null || true
    fail "job $1 ended as ${st:-unknown} (or did not end within 120 s)"
  fi
}

cd "$dir/out"
# Tile parts: 4 array tasks, then the merge.
ids=$("$scripts/submit.sh" -n 4 -o "$dir/tiles.pfm" -d "$dir/parts/tiles" -- \
  -- "$cli" render "${scene[@]}")
wait_job "${ids#* }"
cmp "$dir/one.pfm" "$dir/tiles.pfm" || fail "the merged tile parts differ from one process's image"
# Sample ranges: 3 array tasks over the 20 spp, which are 3 blocks of 8 (the last partial):
# [0, 8), [8, 16), [16, 20).
ids=$("$scripts/submit.sh" -n 3 --samples 20 -o "$dir/samples.pfm" -d "$dir/parts/samples" -- \
  -- "$cli" render "${scene[@]}")
wait_job "${ids#* }"
cmp "$dir/one.pfm" "$dir/samples.pfm" || fail "the merged sample ranges differ from one process's image"
echo "slurm_test: job arrays of tiles and of sample ranges, merged, match one process byte for byte"

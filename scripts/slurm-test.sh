#!/usr/bin/env bash
# The one-node Slurm test (run as root; idempotent): installs Debian's slurm-wlm and munge,
# starts a one-node cluster on localhost, runs a small campaign
# as a job array of 3 shards plus the dependent merge (`soig slurm`, with a partition, time,
# memory and CPUs that `sbatch --test-only` must accept), and compares the merged
# digest with a local single run's. Prints the timings; exits non-zero on any mismatch.
set -euo pipefail
cd "$(dirname "$0")/.."
[ "$(id -u)" = 0 ] || { echo "slurm-test: must run as root" >&2; exit 2; }
SHARDS=3
SETS=(--set images=6)
CAMPAIGN=campaigns/quickstart.toml
SOIG=$PWD/target/release/soig
[ -x "$SOIG" ] || cargo build --release --locked

if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y -qq slurm-wlm munge >/dev/null
fi

host=$(hostname -s)
grep -qE "^127\.0\.0\.1[[:space:]].*\b$host\b" /etc/hosts || echo "127.0.0.1 $host" >>/etc/hosts

# munge: a key, and munged as the munge user.
if [ ! -s /etc/munge/munge.key ]; then
    dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none
fi
chown munge:munge /etc/munge/munge.key && chmod 400 /etc/munge/munge.key
mkdir -p /run/munge && chown munge:munge /run/munge
munge -n 2>/dev/null | unmunge >/dev/null 2>&1 || su -s /bin/sh munge -c munged
munge -n | unmunge | grep Success >/dev/null

# slurm.conf: one node, no cgroups, root as SlurmUser.
mem=$(( $(free -m | awk '/^Mem:/ {print $2}') - 1024 ))
mkdir -p /etc/slurm /var/spool/slurmctld /var/spool/slurmd
cat >/etc/slurm/slurm.conf <<CONF
ClusterName=soig-test
SlurmctldHost=$host
AuthType=auth/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
SlurmUser=root
SlurmctldPidFile=/run/slurmctld.pid
SlurmdPidFile=/run/slurmd.pid
StateSaveLocation=/var/spool/slurmctld
SlurmdSpoolDir=/var/spool/slurmd
NodeName=$host CPUs=$(nproc) RealMemory=$mem State=UNKNOWN
PartitionName=test Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF

# Stop the daemons by their pid files, and wait until they are gone.
stop() {
    for p in /run/slurmd.pid /run/slurmctld.pid; do
        [ -s "$p" ] || continue
        pid=$(cat "$p")
        kill "$pid" 2>/dev/null || true
        for _ in $(seq 20); do kill -0 "$pid" 2>/dev/null || break; sleep 0.5; done
    done
}
stop
slurmctld -i
slurmd
trap stop EXIT
for _ in $(seq 30); do sinfo -h -o %T 2>/dev/null | grep -q idle && break; sleep 1; done
sinfo -h -o %T | grep idle >/dev/null || { echo "slurm-test: the node is not idle: $(sinfo)" >&2; exit 1; }

work=$(mktemp -d /tmp/soig-slurm-test.XXXXXX)
out="$work/out dir/quickstart"   # a space, so the quoting is tested too
"$SOIG" slurm "$CAMPAIGN" --shards "$SHARDS" "${SETS[@]}" --out "$out" --scripts "$work/jobs" \
    --partition test --time 01:00:00 --mem 1G --cpus-per-task 1 --sbatch=--requeue
# sbatch accepts the job files with those options (--test-only: checked, not queued).
for job in array merge; do
    (cd "$work/jobs" && sbatch --test-only "$job.sbatch") 2>&1 | grep "to start at" >/dev/null || {
        echo "slurm-test: sbatch --test-only refuses $job.sbatch:" >&2
        (cd "$work/jobs" && sbatch --test-only "$job.sbatch") >&2 || true
        exit 1
    }
done

t0=$(date +%s.%N)
ids=$("$work/jobs/submit.sh")
array=$(awk '/^array job/ {print $3}' <<<"$ids")
merge=$(awk '/^merge job/ {print $3}' <<<"$ids")
gone() { [ -z "$(squeue -h -j "$1" 2>/dev/null)" ]; }
deadline=$(( $(date +%s) + 900 ))
until gone "$array"; do
    [ "$(date +%s)" -lt "$deadline" ] || { echo "slurm-test: array $array timed out" >&2; exit 1; }
    sleep 1
done
t1=$(date +%s.%N)
until gone "$merge"; do
    [ "$(date +%s)" -lt "$deadline" ] || { echo "slurm-test: merge $merge timed out" >&2; exit 1; }
    sleep 1
done
t2=$(date +%s.%N)

t3=$(date +%s.%N)
local_digest=$("$SOIG" run "$CAMPAIGN" "${SETS[@]}" --out "$work/local" --quiet | awk '/^digest/ {print $2}')
t4=$(date +%s.%N)
merged_digest=$("$SOIG" verify "$out" --digest "$local_digest" | awk '/digest/ {print $NF}' | tail -1) || {
    echo "slurm-test: the merged output does not verify with the local digest $local_digest" >&2
    cat "$work/jobs"/*.out >&2 || true
    exit 1
}
printf 'slurm-test: %s shards, digest %s (local run: %s)\n' "$SHARDS" "$merged_digest" "$local_digest"
awk -v a="$t0" -v b="$t1" -v c="$t2" -v d="$t3" -v e="$t4" 'BEGIN {
    printf "slurm-test: array wall %.1f s, merge %.1f s, local single run %.1f s\n", b - a, c - b, e - d }'
rm -rf "$work"

#!/usr/bin/env bash
# A real single-node Slurm cluster on this machine, for the tests of `stickslip slurm`.
#
#   tests/slurm/cluster.sh start DIR   install slurm-wlm and munge when missing (Debian, as root),
#                                      write DIR/slurm.conf, start munged, slurmctld and slurmd,
#                                      wait until the node is idle; DIR/pids lists what it started
#   tests/slurm/cluster.sh stop DIR    stop exactly the processes listed in DIR/pids
#
# Clients find the cluster through SLURM_CONF=DIR/slurm.conf. Everything stays on the loopback.
# No init system runs here, so the daemons are started by hand; proctrack/linuxproc with
# task/none needs no cgroup set-up (proctrack/cgroup would drain the node without cgroup.conf).
set -euo pipefail

cmd=${1:?usage: cluster.sh start|stop DIR}
dir=${2:?usage: cluster.sh start|stop DIR}
mkdir -p "$dir"
dir=$(cd "$dir" && pwd)

stop() {
    [ -f "$dir/pids" ] || return 0
    while read -r pid; do
        kill "$pid" 2>/dev/null || true
    done <"$dir/pids"
    # Give them a moment, then make sure.
    for _ in $(seq 50); do
        alive=0
        while read -r pid; do
            kill -0 "$pid" 2>/dev/null && alive=1
        done <"$dir/pids"
        [ "$alive" = 0 ] && break
        sleep 0.1
    done
    while read -r pid; do
        kill -9 "$pid" 2>/dev/null || true
    done <"$dir/pids"
    rm -f "$dir/pids"
}

wait_for_file() {
    for _ in $(seq 100); do
        [ -s "$1" ] && return 0
        sleep 0.1
    done
    echo "cluster.sh: $1 did not appear; see the logs in $dir" >&2
    return 1
}

if [ "$cmd" = stop ]; then
    stop
    exit 0
fi
[ "$cmd" = start ] || { echo "cluster.sh: unknown command $cmd (start or stop)" >&2; exit 2; }

if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
    if [ "$(id -u)" != 0 ]; then
        echo "cluster.sh: slurm-wlm and munge are missing and only root can install them" >&2
        exit 1
    fi
    export DEBIAN_FRONTEND=noninteractive
    apt-get install -y --no-install-recommends slurm-wlm munge >"$dir/apt.log" 2>&1 ||
        { apt-get update >>"$dir/apt.log" 2>&1 &&
          apt-get install -y --no-install-recommends slurm-wlm munge >>"$dir/apt.log" 2>&1; } ||
        { echo "cluster.sh: installing slurm-wlm and munge failed; see $dir/apt.log" >&2; exit 1; }
fi

stop
: >"$dir/pids"
host=$(hostname -s)
mkdir -p "$dir/state" "$dir/spool" "$dir/munge"

# munge: our own socket and key copy, so an existing munged on the machine is left alone.
if [ ! -f /etc/munge/munge.key ]; then
    mkdir -p /etc/munge
    dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none
    chown munge:munge /etc/munge/munge.key 2>/dev/null || true
    chmod 400 /etc/munge/munge.key
fi
chown munge:munge "$dir/munge" 2>/dev/null || true
chmod 700 "$dir/munge"
socket="$dir/munge/munge.socket"
runuser -u munge -- /usr/sbin/munged --socket="$socket" --pid-file="$dir/munge/munged.pid" \
    --log-file="$dir/munge/munged.log" --seed-file="$dir/munge/munged.seed" --force
wait_for_file "$dir/munge/munged.pid"
cat "$dir/munge/munged.pid" >>"$dir/pids"

# The node's hardware line, as slurmd sees it.
node=$(slurmd -C | head -1)
cpus=$(sed -n 's/.*CPUs=\([0-9]*\).*/\1/p' <<<"$node")
cat >"$dir/slurm.conf" <<EOF
ClusterName=stickslip-test
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=16817
SlurmdPort=16818
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$socket
CredType=cred/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
JobCompType=jobcomp/none
AccountingStorageType=accounting_storage/none
SlurmctldTimeout=30
SlurmdTimeout=30
InactiveLimit=0
MinJobAge=300
KillWait=5
$node NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=test Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF="$dir/slurm.conf"

slurmctld -i -f "$SLURM_CONF"
wait_for_file "$dir/slurmctld.pid"
cat "$dir/slurmctld.pid" >>"$dir/pids"
slurmd -f "$SLURM_CONF"
wait_for_file "$dir/slurmd.pid"
cat "$dir/slurmd.pid" >>"$dir/pids"

# Until the node takes work; a node drained by an earlier run is resumed.
for _ in $(seq 200); do
    state=$(sinfo -h -n "$host" -o %t 2>/dev/null || true)
    case "$state" in
        idle*|mix*|alloc*) echo "cluster.sh: node $host ($cpus CPUs) is $state; SLURM_CONF=$SLURM_CONF"; exit 0 ;;
        drain*|drng*|down*) scontrol update NodeName="$host" State=RESUME >/dev/null 2>&1 || true ;;
    esac
    sleep 0.1
done
echo "cluster.sh: the node did not become idle (state '$state'); see $dir/slurmctld.log and $dir/slurmd.log" >&2
exit 1

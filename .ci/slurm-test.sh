#!/usr/bin/env bash
# A single-node Slurm cluster on this machine for tests/slurm.rs: installs Debian's slurm-wlm
# and munge if missing, writes a minimal slurm.conf (this host's name and CPUs from
# `slurmd -C`; no cgroups: proctrack/linuxproc, task/none), starts munged, slurmctld and slurmd,
# and waits (bounded) until `sinfo` shows the node idle. Needs root.
#
# MaxArraySize is small here (PORELAB_SLURM_MAX_ARRAY_SIZE, default 5: array task ids 0-4), so
# that tests/slurm.rs's 6-job sweep has more jobs than one array may hold and must be split.
#
#   .ci/slurm-test.sh          start (or confirm) the cluster; exit 0 when sinfo shows it idle
#   .ci/slurm-test.sh stop     stop the daemons it started (by their pid files)
#
# No slurmdbd: job states come from squeue/scontrol (sacct needs an accounting database).
set -euo pipefail

STATE=/var/spool/porelab-slurm
PIDS="$STATE/pids"

stop() {
    for f in slurmd slurmctld munged; do
        if [[ -f "$PIDS/$f.pid" ]]; then
            kill "$(cat "$PIDS/$f.pid")" 2>/dev/null || true
            rm -f "$PIDS/$f.pid"
        fi
    done
}

if [[ "${1:-}" == stop ]]; then
    stop
    exit 0
fi

if [[ $(id -u) -ne 0 ]]; then
    echo "slurm-test: not root: cannot install or start Slurm" >&2
    exit 1
fi

if timeout 10 sinfo -h -o %T 2>/dev/null | grep -q idle; then
    echo "slurm-test: a cluster already answers: $(sinfo -h -o '%N %T %c')"
    exit 0
fi

if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null || ! command -v munged >/dev/null; then
    echo "slurm-test: installing slurm-wlm and munge"
    export DEBIAN_FRONTEND=noninteractive
    timeout 600 apt-get update -qq
    timeout 900 apt-get install -y -qq slurm-wlm munge >/dev/null
fi

mkdir -p "$STATE"/{ctld,d,log} "$PIDS" /etc/slurm /run/munge /var/log/munge /var/lib/munge
if [[ ! -s /etc/munge/munge.key ]]; then
    dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none
fi
chown -R munge:munge /etc/munge /run/munge /var/log/munge /var/lib/munge
chmod 0700 /etc/munge
chmod 0400 /etc/munge/munge.key

# Never overwrite a slurm.conf this script did not write (a real cluster's).
MARK="# Written by porelab's .ci/slurm-test.sh"
if [[ -f /etc/slurm/slurm.conf ]] && ! head -n 1 /etc/slurm/slurm.conf | grep -qF "$MARK"; then
    echo "slurm-test: /etc/slurm/slurm.conf exists and was not written by this script: left alone" >&2
    exit 1
fi

# The node line as slurmd itself sees this machine (NodeName, CPUs, sockets, memory).
NODE=$(slurmd -C | head -n 1)
HOST=$(hostname -s)
cat >/etc/slurm/slurm.conf <<EOF
$MARK: one node, no cgroups, no accounting database.
ClusterName=porelab
SlurmctldHost=$HOST
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
ReturnToService=2
MinJobAge=600
MaxArraySize=${PORELAB_SLURM_MAX_ARRAY_SIZE:-5}
StateSaveLocation=$STATE/ctld
SlurmdSpoolDir=$STATE/d
SlurmctldPidFile=$PIDS/slurmctld.pid
SlurmdPidFile=$PIDS/slurmd.pid
SlurmctldLogFile=$STATE/log/slurmctld.log
SlurmdLogFile=$STATE/log/slurmd.log
$NODE State=UNKNOWN
PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF

if ! pgrep -u munge -x munged >/dev/null; then
    runuser -u munge -- munged --pid-file=/run/munge/munged.pid
    cp /run/munge/munged.pid "$PIDS/munged.pid" 2>/dev/null || true
fi
if ! timeout 10 munge -n | unmunge >/dev/null 2>&1; then
    echo "slurm-test: munged does not answer (munge -n | unmunge failed)" >&2
    exit 1
fi
[[ -f "$PIDS/slurmctld.pid" ]] && kill -0 "$(cat "$PIDS/slurmctld.pid")" 2>/dev/null || slurmctld
[[ -f "$PIDS/slurmd.pid" ]] && kill -0 "$(cat "$PIDS/slurmd.pid")" 2>/dev/null || slurmd

for _ in $(seq 1 60); do
    if timeout 5 sinfo -h -o %T 2>/dev/null | grep -q idle; then
        echo "slurm-test: cluster up: $(sinfo -h -o 'node %N, %c CPUs, %T')"
        exit 0
    fi
    sleep 1
done
echo "slurm-test: the node did not become idle within 60 s; sinfo says: $(sinfo 2>&1 | tr '\n' ' ')" >&2
tail -n 5 "$STATE"/log/*.log >&2 || true
exit 1

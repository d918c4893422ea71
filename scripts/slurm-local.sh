#!/usr/bin/env bash
# A real single-node Slurm for the sweep tests (docs/testing.md; the recipe measured in
# ../shared/PLATFORM.md): Debian's slurmctld, slurmd and munge, run in the foreground by this
# script with their own configuration and state under STATE (default /tmp/fluxswarm-slurm),
# so nothing in /etc/slurm is touched. Only the MUNGE key in /etc/munge is created when missing.
#
#   bash scripts/slurm-local.sh start   # installs the packages if needed, starts the daemons,
#                                       # waits for the node, prints `export SLURM_CONF=...`
#   bash scripts/slurm-local.sh stop    # stops the daemons it started, by their PIDs
#
# Needs root (or sudo without a password): the daemons run as root, as on a one-node cluster.
set -euo pipefail
STATE=${FLUXSWARM_SLURM_STATE:-/tmp/fluxswarm-slurm}
log() { echo "slurm-local: $*" >&2; }

SUDO=""
if [ "$(id -u)" != 0 ]; then
    if sudo -n true 2>/dev/null; then SUDO="sudo -n"; else
        log "needs root or passwordless sudo to run slurmctld, slurmd and munged"
        exit 1
    fi
fi

stop() {
    for name in slurmd slurmctld munged; do
        local f="$STATE/$name.pid"
        [ -f "$f" ] || continue
        local pid
        pid=$(cat "$f")
        if kill -0 "$pid" 2>/dev/null; then
            $SUDO kill -TERM "$pid" 2>/dev/null || true
            for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
            kill -0 "$pid" 2>/dev/null && $SUDO kill -KILL "$pid" 2>/dev/null || true
        fi
        rm -f "$f"
    done
}

start() {
    if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null ||
        ! command -v sbatch >/dev/null || ! command -v munged >/dev/null; then
        log "installing slurmctld slurmd slurm-client munge"
        $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
            slurmctld slurmd slurm-client munge >/dev/null 2>&1 || {
            $SUDO apt-get update -qq >/dev/null 2>&1
            $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
                --no-install-recommends slurmctld slurmd slurm-client munge >/dev/null
        }
    fi
    stop
    $SUDO mkdir -p "$STATE/ctld" "$STATE/d" "$STATE/log" "$STATE/munge"
    $SUDO chmod 755 "$STATE"
    if [ ! -s /etc/munge/munge.key ]; then
        $SUDO mkdir -p /etc/munge
        $SUDO dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none
    fi
    $SUDO chmod 400 /etc/munge/munge.key
    local host
    host=$(hostname -s)
    $SUDO tee "$STATE/slurm.conf" >/dev/null <<CONF
ClusterName=fluxswarm-local
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$STATE/munge/munge.socket
StateSaveLocation=$STATE/ctld
SlurmdSpoolDir=$STATE/d
SlurmctldPidFile=$STATE/ctld/slurmctld.pid
SlurmdPidFile=$STATE/d/slurmd.pid
SlurmctldLogFile=$STATE/log/slurmctld.log
SlurmdLogFile=$STATE/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
KillWait=30
NodeName=$host CPUs=$(nproc) RealMemory=8000 State=UNKNOWN
PartitionName=local Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
    export SLURM_CONF="$STATE/slurm.conf"
    # Foreground daemons (-F, -D) in the background, so their PIDs are ours to stop; munged runs
    # as root (--force), as the other two do.
    $SUDO /usr/sbin/munged -F --force --socket="$STATE/munge/munge.socket" \
        --pid-file="$STATE/munge/munged.pid" --log-file="$STATE/log/munged.log" \
        --seed-file="$STATE/munge/munged.seed" >>"$STATE/log/munged.out" 2>&1 &
    echo $! | $SUDO tee "$STATE/munged.pid" >/dev/null
    for _ in $(seq 50); do [ -S "$STATE/munge/munge.socket" ] && break; sleep 0.1; done
    $SUDO env SLURM_CONF="$SLURM_CONF" /usr/sbin/slurmctld -D -f "$SLURM_CONF" \
        >>"$STATE/log/slurmctld.out" 2>&1 &
    echo $! | $SUDO tee "$STATE/slurmctld.pid" >/dev/null
    sleep 1
    $SUDO env SLURM_CONF="$SLURM_CONF" /usr/sbin/slurmd -D -f "$SLURM_CONF" \
        >>"$STATE/log/slurmd.out" 2>&1 &
    echo $! | $SUDO tee "$STATE/slurmd.pid" >/dev/null
    for _ in $(seq 100); do
        if sinfo -h -o %t 2>/dev/null | grep -qE '^(idle|mix|alloc)'; then
            log "node $host is up ($(sinfo -h -o '%t %c CPUs'))"
            echo "export SLURM_CONF=$SLURM_CONF"
            return 0
        fi
        sleep 0.2
    done
    log "the node did not come up in 20 s; logs in $STATE/log:"
    tail -5 "$STATE"/log/*.log >&2 || true
    stop
    return 1
}

case "${1:-}" in
start) start ;;
stop) stop ;;
*)
    echo "usage: $0 start|stop" >&2
    exit 2
    ;;
esac

#!/usr/bin/env bash
# A throwaway single-node Slurm cluster: munged (its own key and socket),
# slurmctld and slurmd, all state under one directory.
#   cluster.sh start DIR   writes DIR/slurm.conf, starts the daemons, waits
#                          until the node is idle; prints `export SLURM_CONF=...`
#   cluster.sh stop DIR    stops them (and is harmless when none runs)
# Needs root and Debian's slurmctld, slurmd, slurm-client and munge
# (`make slurm` installs them). Ports: the first free pair from
# SLURM_TEST_PORT (default 6917) on, so a real cluster's 6817/6818 and
# another test cluster are left alone.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
cmd=${1:?usage: cluster.sh start|stop DIR}
dir=${2:?usage: cluster.sh start|stop DIR}
mkdir -p "$dir"
dir=$(cd "$dir" && pwd)
conf=$dir/slurm.conf

# Every daemon is told at once (each takes a second or two to end), then
# waited for, and killed after 5 s.
stop() {
    local pids=() d pid
    for d in slurmd slurmctld munged; do
        if [[ -f $dir/$d.pid ]]; then
            pids+=("$(cat "$dir/$d.pid")")
            kill "${pids[-1]}" 2>/dev/null || true
            rm -f "$dir/$d.pid"
        fi
    done
    for pid in "${pids[@]}"; do
        for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
        kill -9 "$pid" 2>/dev/null || true
    done
}

case $cmd in
stop)
    stop
    ;;
start)
    stop
    for t in munged mungekey slurmctld slurmd sbatch; do
        command -v "$t" >/dev/null || { echo "cluster.sh: $t not found (make slurm installs it)" >&2; exit 1; }
    done
    rm -rf "$dir/ctld" "$dir/spool"
    mkdir -p "$dir/ctld" "$dir/spool"
    host=$(hostname -s)
    cpus=$(nproc)
    mem=$(( $(awk '/MemTotal/ {print $2}' /proc/meminfo) / 1024 * 9 / 10 ))
    # The first pair of free ports from SLURM_TEST_PORT on: another
    # cluster (a second checkout's tests) keeps its own.
    port=${SLURM_TEST_PORT:-6917}
    busy() { (exec 3<>"/dev/tcp/127.0.0.1/$1") 2>/dev/null; }
    while busy "$port" || busy $((port + 1)); do port=$((port + 2)); done
    sed -e "s|@STATE@|$dir|g" -e "s|@HOST@|$host|g" -e "s|@CPUS@|$cpus|g" \
        -e "s|@MEM@|$mem|g" -e "s|@CTLD_PORT@|$port|g" -e "s|@SLURMD_PORT@|$((port + 1))|g" \
        "$here/slurm.conf.in" > "$conf"
    [[ -f $dir/munge.key ]] || mungekey --create --keyfile="$dir/munge.key"
    chmod 600 "$dir/munge.key"
    munged --force --key-file="$dir/munge.key" --socket="$dir/munge.sock" \
        --pid-file="$dir/munged.pid" --log-file="$dir/munged.log" --seed-file="$dir/munged.seed"
    slurmctld -f "$conf"
    slurmd -f "$conf"
    export SLURM_CONF=$conf
    for _ in $(seq 150); do
        state=$(sinfo -h -N -o '%T' 2>/dev/null | head -1 || true)
        [[ $state == idle* ]] && break
        sleep 0.2
    done
    if [[ ${state:-} != idle* ]]; then
        echo "cluster.sh: the node did not come up (state '${state:-none}'); logs in $dir" >&2
        tail -5 "$dir/slurmctld.log" "$dir/slurmd.log" >&2 || true
        stop
        exit 1
    fi
    echo "export SLURM_CONF=$conf"
    ;;
*)
    echo "usage: cluster.sh start|stop DIR" >&2
    exit 2
    ;;
esac

#!/usr/bin/env bash
# The Slurm test (`make slurm-test`, opt-in; issue 52): installs Slurm and
# munge from the Debian packages when missing, starts a single-node cluster
# on this machine (munged, slurmctld and one slurmd, localhost only, in a
# temporary directory, on ports 16817-16818), submits a 4-part reference of
# scenes/area_light_plane.toml and its dependent merge through
# scripts/slurm/submit.sh (sbatch), waits for them, and checks the merged
# cache entry against a single-process `mdas reference` of the same spec:
# the same entry name and every pixel within 16·2⁻²⁴ relative (the bound
# tests/cli.rs states for a merge). Stops the daemons on exit.
#   MDAS=path/to/mdas scripts/slurm/test.sh   (default: builds target/release/mdas)
set -euo pipefail
cd "$(dirname "$0")/../.."
root=$PWD

if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
    echo "Installing slurm-wlm and munge (Debian packages) ..." >&2
    apt-get install -y -q slurm-wlm munge >/dev/null
fi
if [ -z "${MDAS:-}" ]; then
    cargo build --release --bin mdas
    MDAS=$root/target/release/mdas
fi
MDAS=$(realpath "$MDAS")
./.ci/ensure-vulkan.sh
./.ci/mitsuba-venv.sh
python=$root/target/mitsuba-venv/bin/python

dir=$(mktemp -d /tmp/mdas-slurm-XXXXXX)
cleanup() {
    for pid in "$dir"/slurmd.pid "$dir"/slurmctld.pid "$dir"/munge/munged.pid; do
        [ -f "$pid" ] && kill "$(cat "$pid")" 2>/dev/null || true
    done
    sleep 1
    rm -rf "$dir"
}
trap cleanup EXIT
mkdir -p "$dir"/{state,spool,log,munge,work}
chmod 700 "$dir/munge"
cat > "$dir/slurm.conf" <<EOF
ClusterName=mdastest
SlurmctldHost=localhost(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$dir/munge/munge.socket.2
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldPort=16817
SlurmdPort=16818
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
ReturnToService=2
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
JobCompType=jobcomp/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$(nproc) State=UNKNOWN
PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$dir/slurm.conf
dd if=/dev/urandom of="$dir/munge/munge.key" bs=1024 count=1 2>/dev/null
chmod 400 "$dir/munge/munge.key"
munged --force --key-file="$dir/munge/munge.key" --socket="$dir/munge/munge.socket.2" \
    --pid-file="$dir/munge/munged.pid" --log-file="$dir/munge/munged.log" \
    --seed-file="$dir/munge/munge.seed"
slurmctld
sleep 2
slurmd -N localhost
for _ in $(seq 1 30); do
    sinfo -h -o %t 2>/dev/null | grep -q idle && break
    sleep 1
done
sinfo

scene=$root/scenes/area_light_plane.toml
spp=64
MDAS=$MDAS scripts/slurm/submit.sh "$scene" "$spp" 4 0.25 "$dir/work/parts" "$dir/work/cache" -- --chdir="$dir/work"
deadline=$((SECONDS + 600))
while [ -n "$(squeue -h)" ]; do
    if [ $SECONDS -gt $deadline ]; then
        squeue; echo "FAIL: the jobs did not finish in 600 s" >&2; exit 1
    fi
    sleep 2
done
cat "$dir"/work/*.out
merged=$(ls "$dir"/work/cache/*.exr 2>/dev/null || true)
[ -n "$merged" ] || { echo "FAIL: the merge job wrote no cache entry" >&2; exit 1; }

"$MDAS" -q reference "$scene" --spp "$spp" --scale 0.25 --cache "$dir/work/single"
single=$(ls "$dir"/work/single/*.exr)
[ "$(basename "$merged")" = "$(basename "$single")" ] || {
    echo "FAIL: merged entry $(basename "$merged"), one process $(basename "$single")" >&2; exit 1; }
"$python" - "$merged" "$single" <<'EOF'
import sys
import mitsuba as mi
import numpy as np
mi.set_variant("scalar_rgb")
a, b = (np.array(mi.Bitmap(p))[..., :3].astype(np.float64) for p in sys.argv[1:3])
bound = 16 * 2.0 ** -24 * np.abs(b)
worst = np.max(np.abs(a - b) / np.maximum(np.abs(b), 1e-30))
print(f"merged against one process: worst relative difference {worst:.3g} (bound 16·2^-24 = {16 * 2.0 ** -24:.3g})")
sys.exit(0 if np.all(np.abs(a - b) <= bound) else 1)
EOF
echo "slurm test: PASS"

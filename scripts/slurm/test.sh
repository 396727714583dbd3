#!/usr/bin/env bash
# The Slurm test (`make slurm-test`, opt-in; issue 52): installs Slurm and
# munge from the Debian packages when missing, starts a single-node cluster
# on this machine (munged, slurmctld and one slurmd, localhost only, in a
# temporary directory, on ports 16817-16818), submits a 4-part reference of
# scenes/area_light_plane.toml and its dependent merge through
# scripts/slurm/submit.sh (sbatch), waits for them, and checks the merged
# cache entry against a single-process `mdas reference` of the same spec:
# the same entry name and every pixel within 16·2⁻²⁴ relative (the bound
# tests/cli.rs states for a merge); then a 3-part sweep and its merge job
# through scripts/slurm/submit-run.sh, checked against a one-process sweep
# field for field but the times. Stops the daemons on exit.
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

# A 3-part sweep through the array and its merge job, against one process:
# equal field for field but the measured times and the provenance's
# command line and time (as tests/cli.rs checks without Slurm).
args=(--scale 0.25 --ref-spp "$spp" --spps 2,4,8 --seeds 2 --repeats 1 --cache "$dir/work/cache")
MDAS=$MDAS SBATCH_OPTIONS="--chdir=$dir/work" scripts/slurm/submit-run.sh sweep "$scene" 3 \
    "$dir/work/sweep-parts" "$dir/work/sweep-merged" "${args[@]}"
deadline=$((SECONDS + 600))
while [ -n "$(squeue -h)" ]; do
    if [ $SECONDS -gt $deadline ]; then
        squeue; echo "FAIL: the sweep jobs did not finish in 600 s" >&2; exit 1
    fi
    sleep 2
done
cat "$dir"/work/mdas-run-*.out "$dir"/work/mdas-merge-run-*.out
# Every sweep part found the merged reference (same scene, spp, scale and
# default seed): the cache still holds that one entry, none rendered anew.
entries=$(ls "$dir"/work/cache/*.exr | wc -l)
[ "$entries" = 1 ] || {
    echo "FAIL: the sweep parts rendered their own reference ($entries cache entries, expected the merged one only)" >&2
    ls "$dir"/work/cache >&2; exit 1; }
"$MDAS" -q sweep "$scene" "${args[@]}" --out "$dir/work/sweep-one" > /dev/null
"$python" - "$dir/work/sweep-merged/sweep.json" "$dir/work/sweep-one/sweep.json" <<'EOF'
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:3])
assert len(a.pop("merged_from")) == 3, "three parts"
for d in (a, b):
    for r in d["rows"]:
        r.pop("time_ms")
    for k in ("command_line", "timestamp_utc"):
        d["provenance"].pop(k)
if a != b:
    sys.exit(f"FAIL: the merged sweep differs from one process's:\n{a}\n{b}")
print(f"merged sweep ({len(a['rows'])} points from 3 parts) equals one process's but its times")
EOF
echo "slurm test: PASS"

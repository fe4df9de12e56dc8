#!/bin/bash
# Submits a sharded command as a Slurm array and its merge as a dependent job:
#   xtask/scale/slurm/submit.sh N COMMAND ARGS... --out DIR [-- SBATCH OPTIONS...]
# e.g. submit.sh 16 suite --range development --out /shared/zmp/dev -- --partition=short
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
if [[ $# -lt 2 ]]; then
    echo "usage: $0 N COMMAND ARGS... --out DIR [-- SBATCH OPTIONS...]" >&2
    exit 2
fi
n=$1
shift
cmd=()
while [[ $# -gt 0 && "$1" != "--" ]]; do
    cmd+=("$1")
    shift
done
[[ "${1:-}" == "--" ]] && shift
out=""
for ((k = 0; k < ${#cmd[@]}; k++)); do
    [[ "${cmd[$k]}" == "--out" ]] && out=${cmd[$((k + 1))]:-}
done
if [[ -z "$out" ]]; then
    echo "$0: the command needs --out DIR" >&2
    exit 2
fi
jid=$(sbatch --parsable "$@" --array="1-$n" "$here/suite.sbatch" "${cmd[@]}")
mid=$(sbatch --parsable "$@" --dependency="afterany:${jid%%;*}" "$here/merge.sbatch" "$out")
echo "array job $jid ($n shards), merge job $mid -> $out"

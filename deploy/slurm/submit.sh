#!/usr/bin/env bash
# Submits SCENE as a Slurm array of PARTS render tasks and a merge that waits for all of them.
#   deploy/slurm/submit.sh SCENE PARTS OUT [render flags...]
set -euo pipefail
if [ $# -lt 3 ]; then
  sed -n '2,3p' "$0" | sed 's/^# \{0,1\}//'
  exit 2
fi
scene=$1 parts=$2 out=$3
shift 3
here=$(cd "$(dirname "$0")" && pwd)
# A folder per submission: parts of an earlier render never mix with these.
parts_dir=${PARTS_DIR:-$PWD/lancer-parts-$(date +%Y%m%d-%H%M%S)}
# Through the environment (--export=ALL), so flags may hold commas.
export SCENE=$scene PARTS_DIR=$parts_dir OUT=$out RENDER_FLAGS="$*" AOV_DIR=${AOV_DIR:-}
array=$(sbatch --parsable --array="0-$((parts - 1))" --export=ALL "$here/render.sbatch")
array=${array%%;*} # `id;cluster` on federated clusters
sbatch --dependency="afterok:$array" --export=ALL "$here/merge.sbatch"

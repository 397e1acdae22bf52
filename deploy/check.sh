#!/usr/bin/env bash
# Checks the recipes in deploy/ on this machine: GNU parallel for real (4 parts on the cores
# here), the Slurm and Kubernetes steps run as their schedulers would run them (the part index
# from SLURM_ARRAY_TASK_ID or JOB_COMPLETION_INDEX, into the same folder layout, then their merge
# step); every merged image compared bit for bit with a whole render. Also the scripts' syntax
# and the manifests' YAML. Installs GNU parallel (Debian) where missing.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --locked -p lancer-cli
export LANCER=$PWD/target/release/lancer
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
scene=scenes/glass.toml
flags=(--width 320 --samples 2)
parts=4

same() { # same IMAGE AOV_DIR: bit for bit the whole render's
  cmp "$work/whole.png" "$1"
  for f in "$work"/whole-aov/*.exr "$work"/whole-aov/*.png; do
    cmp "$f" "$2/$(basename "$f")"
  done
}

for s in deploy/parallel.sh deploy/slurm/*.sh deploy/slurm/*.sbatch deploy/k8s/*.sh; do
  bash -n "$s"
done
"$LANCER" render "$scene" "${flags[@]}" -o "$work/whole.png" --aov "$work/whole-aov" --quiet

if ! command -v parallel >/dev/null 2>&1; then
  apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q parallel
fi
AOV=1 deploy/parallel.sh "$scene" "$parts" "$work/parallel.png" "${flags[@]}"
same "$work/parallel.png" "$work/parallel.png.aov"
echo "deploy: GNU parallel, $parts parts: the same bits as a whole render"
# The --sshlogin path with this machine as the only host (`:`), parts in a shared folder.
SSHLOGIN=: PARTS_DIR="$work/shared" AOV=1 deploy/parallel.sh "$PWD/$scene" "$parts" "$work/ssh.png" "${flags[@]}"
same "$work/ssh.png" "$work/ssh.png.aov"
echo "deploy: GNU parallel through --sshlogin (this machine), $parts parts: the same bits"

export SCENE=$scene RENDER_FLAGS="${flags[*]}" PARTS_DIR=$work/slurm-parts
for i in $(seq 0 $((parts - 1))); do
  SLURM_ARRAY_TASK_ID=$i SLURM_ARRAY_TASK_COUNT=$parts SLURM_CPUS_PER_TASK=1 bash deploy/slurm/render.sbatch
done
OUT=$work/slurm/render.png AOV_DIR=$work/slurm/aov bash deploy/slurm/merge.sbatch
same "$work/slurm/render.png" "$work/slurm/aov"
echo "deploy: Slurm array steps, $parts parts: the same bits as a whole render"

export PARTS=$parts WORK_DIR=$work/k8s
for i in $(seq 0 $((parts - 1))); do
  JOB_COMPLETION_INDEX=$i bash deploy/k8s/part.sh
done
OUT=$work/k8s/out/render.png AOV_DIR=$work/k8s/out/aov bash deploy/k8s/merge.sh
same "$work/k8s/out/render.png" "$work/k8s/out/aov"
echo "deploy: Kubernetes Indexed Job steps, $parts parts: the same bits as a whole render"

if ! python3 -c "import yaml" 2>/dev/null; then
  apt-get install -y -q python3-yaml >/dev/null 2>&1 || true
fi
python3 - <<'PY'
import sys
try:
    import yaml
except ImportError:
    print("deploy: PyYAML missing, manifests not parsed"); sys.exit(0)
for f in ["deploy/k8s/render-job.yaml", "deploy/k8s/merge-job.yaml"]:
    job = yaml.safe_load(open(f))
    assert job["kind"] == "Job", f
    spec = job["spec"]
    if f.endswith("render-job.yaml"):
        assert spec["completionMode"] == "Indexed"
        env = {e["name"]: e["value"] for e in spec["template"]["spec"]["containers"][0]["env"]}
        assert int(env["PARTS"]) == spec["completions"], "PARTS must equal completions"
print("deploy: Kubernetes manifests parse; PARTS equals completions")
PY

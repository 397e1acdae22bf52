#!/usr/bin/env bash
# Renders SCENE in PARTS parts with GNU parallel, then merges them into OUT (and OUT's per-term
# images into OUT.aov/ when AOV=1). Extra arguments go to every `lancer render`.
#
#   deploy/parallel.sh SCENE PARTS OUT [render flags...]
#   SSHLOGIN=host1,host2 deploy/parallel.sh scenes/glass.toml 16 glass.png --width 3840 --samples 64
#
# Locally the parts run as many at once as there are cores. With SSHLOGIN (GNU parallel's
# --sshlogin list, `:` for this machine) they run on those hosts: each needs `lancer` on its PATH
# (or LANCER set to its path there), and the scene (with its meshes and textures) and PARTS_DIR
# must be on a folder every host sees at the same path (NFS): give both as absolute paths.
set -euo pipefail
if [ $# -lt 3 ]; then
  sed -n '2,12p' "$0" | sed 's/^# \{0,1\}//'
  exit 2
fi
scene=$1 parts=$2 out=$3
shift 3
lancer=${LANCER:-lancer}
if [ -n "${SSHLOGIN:-}" ]; then
  : "${PARTS_DIR:?with SSHLOGIN, set PARTS_DIR to a folder every host sees at the same path}"
  mkdir -p "$PARTS_DIR"
  work=$(mktemp -d "$PARTS_DIR/lancer-parts.XXXXXX")
  remote=(--sshlogin "$SSHLOGIN")
else
  work=$(mktemp -d "${TMPDIR:-/tmp}/lancer-parts.XXXXXX")
  remote=()
fi
trap 'rm -rf "$work"' EXIT
# -q: each argument goes to lancer as it is (paths and flags with spaces survive).
seq 0 $((parts - 1)) | parallel --will-cite -q --halt now,fail=1 ${remote[@]+"${remote[@]}"} \
  "$lancer" render "$scene" --tile "{}/$parts" -o "$work/part-{}.lpart" --quiet "$@"
aov=()
if [ "${AOV:-0}" = 1 ]; then
  aov=(--aov "$out.aov")
fi
"$lancer" merge "$work"/part-*.lpart -o "$out" ${aov[@]+"${aov[@]}"}

#!/usr/bin/env bash
# Renders SCENE in PARTS parts with GNU parallel, then merges them into OUT (and OUT's per-term
# images into OUT.aov/ when AOV=1). Extra arguments go to every `lancer render`.
#
#   deploy/parallel.sh SCENE PARTS OUT [render flags...]
#   SSHLOGIN=host1,host2 deploy/parallel.sh scenes/glass.toml 16 glass.png --width 3840 --samples 64
#
# Locally the parts run as many at once as there are cores. With SSHLOGIN (GNU parallel's
# --sshlogin list, `:` for this machine) they run on those hosts: each needs `lancer` on its PATH
# (or LANCER set to its path there) and the scene, with its meshes and textures, at the same
# path; each part file comes back here (--return) and is removed there (--cleanup).
set -euo pipefail
if [ $# -lt 3 ]; then
  sed -n '2,12p' "$0" | sed 's/^# \{0,1\}//'
  exit 2
fi
scene=$1 parts=$2 out=$3
shift 3
lancer=${LANCER:-lancer}
work=$(mktemp -d "${TMPDIR:-/tmp}/lancer-parts.XXXXXX")
trap 'rm -rf "$work"' EXIT
remote=()
if [ -n "${SSHLOGIN:-}" ]; then
  remote=(--sshlogin "$SSHLOGIN" --return "$work/part-{}.lpart" --cleanup)
fi
seq 0 $((parts - 1)) | parallel --will-cite --halt now,fail=1 "${remote[@]}" \
  "$lancer" render "$scene" --tile "{}/$parts" -o "$work/part-{}.lpart" --quiet "$@"
aov=()
if [ "${AOV:-0}" = 1 ]; then
  aov=(--aov "$out.aov")
fi
"$lancer" merge "$work"/part-*.lpart -o "$out" "${aov[@]}"

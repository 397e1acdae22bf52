#!/usr/bin/env bash
# The merge after the Indexed Job: every part in /work/parts into OUT (and AOV_DIR when set).
set -euo pipefail
: "${OUT:?}"
work=${WORK_DIR:-/work}
mkdir -p "$(dirname "$OUT")"
aov=()
if [ -n "${AOV_DIR:-}" ]; then
  aov=(--aov "$AOV_DIR")
fi
"${LANCER:-lancer}" merge "$work"/parts/part-*.lpart -o "$OUT" ${aov[@]+"${aov[@]}"}

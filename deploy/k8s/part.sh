#!/usr/bin/env bash
# One part of a Kubernetes Indexed Job: part JOB_COMPLETION_INDEX of PARTS of SCENE, into
# /work/parts (a volume shared with the merge). RENDER_FLAGS: extra `lancer render` flags.
set -euo pipefail
: "${SCENE:?}" "${PARTS:?}" "${JOB_COMPLETION_INDEX:?run as an Indexed Job}"
work=${WORK_DIR:-/work}
mkdir -p "$work/parts"
# shellcheck disable=SC2086 # RENDER_FLAGS is a list of flags
"${LANCER:-lancer}" render "$SCENE" --tile "$JOB_COMPLETION_INDEX/$PARTS" \
  -o "$work/parts/part-$JOB_COMPLETION_INDEX.lpart" --quiet ${RENDER_FLAGS:-}

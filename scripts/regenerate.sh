#!/usr/bin/env bash
# Regenerates the checked-in models in generated/ from models/ (run from anywhere).
set -euo pipefail
cd "$(dirname "$0")/.."
spacearm=${SPACEARM:-build/cli/spacearm}
for scene in models/paper_reference.yaml models/paper_geared.yaml models/paper_geared_armature.yaml \
             models/paper_flexible.yaml; do
  "$spacearm" generate "$scene" -o generated "$@"
done

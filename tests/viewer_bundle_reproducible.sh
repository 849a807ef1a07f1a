#!/usr/bin/env bash
# CTest: the viewer's bundle is reproducible: built again from web/ and the locked packages, it
# is the same bytes as the one compiled into spacearm. About 1 s.
# Usage: viewer_bundle_reproducible.sh SOURCE_DIR BUILD_WEB_DIR
set -euo pipefail
source_dir=$1 web=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
node "$source_dir/web/build.mjs" "$web/node_modules" "$work" > /dev/null
cmp "$work/viewer.js" "$web/viewer.js" && cmp "$work/viewer_bundle.inc" "$web/viewer_bundle.inc"
echo "the bundle is the same bytes ($(wc -c < "$work/viewer.js") bytes)"

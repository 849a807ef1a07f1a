#!/usr/bin/env bash
# `pip install` from the checkout, offline (--no-index, Debian's setuptools), into a new virtual
# environment that sees Debian's numpy; then the package is imported from outside the checkout
# and evaluates a mass matrix. Reuses the test build's CMake folder (the module is built there).
# Usage: tests/pip_install.sh SOURCE_DIR BUILD_DIR CACHE_DIR
set -euo pipefail
src=$1 build=$2 cache=$3
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
/usr/bin/python3 -m venv --system-site-packages "$scratch/venv"
(cd "$src" && SPACEARM_BUILD_DIR="$build" "$scratch/venv/bin/pip" install --quiet \
  --no-build-isolation --no-index .)
cd "$scratch"
"$scratch/venv/bin/python" - "$src" "$cache" <<'PY'
import sys
import numpy as np
import spacearm
src, cache = sys.argv[1:]
assert spacearm.__file__.startswith(sys.prefix), spacearm.__file__  # the installed copy
m = spacearm.load(src + "/models/paper_geared.yaml", params={"p": 10}, cache_dir=cache)
M = m.mass_matrix([0, 0, 0.1, 0.2, 0.3, 0.4])
assert M.shape == (6, 6) and np.allclose(M, M.T) and np.all(np.linalg.eigvalsh(M) > 0)
import spacearm.dask_sweep  # the whole package is installed
print("pip_install: spacearm", spacearm.__file__)
PY

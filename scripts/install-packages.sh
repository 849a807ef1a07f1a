#!/usr/bin/env bash
# Installs the given Debian packages that are not installed yet (apt-get; needs root only
# when something is missing). Used by setup.sh, bench.sh and fuzz.sh.
#   scripts/install-packages.sh PACKAGE...
set -euo pipefail
missing=()
for p in "$@"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed" || missing+=("$p")
done
((${#missing[@]})) || exit 0
echo "spacearm: installing ${missing[*]}"
if [[ $(id -u) -ne 0 ]]; then
  echo "spacearm: run as root (or install these packages first): ${missing[*]}" >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq "${missing[@]}" >/dev/null

#!/usr/bin/env bash
# Generates every scene the project keeps (models/, bench/scenes/, tests/scenes/, examples/), with
# and without common-subexpression elimination, into a folder; or compares two such folders.
# A refactor of the generator must leave every file byte-identical, apart from the lines that
# state the C interface's version and facts (the filter below names them). Record a baseline
# with the generator before the change (build an older commit where needed): issue 30 changed
# the headers once on purpose (all kHas_ flags and the layout printed), so older baselines
# differ there.
#   scripts/generation_identity.sh record DIR [SPACEARM]   (default SPACEARM: build/cli/spacearm)
#   scripts/generation_identity.sh compare OLD_DIR NEW_DIR
#   scripts/generation_identity.sh check OLD_SPACEARM [NEW_SPACEARM]   (record both, compare)
set -euo pipefail
cd "$(dirname "$0")/.."

usage() { sed -n '2,9p' "$0" | sed 's/^# \{0,1\}//'; exit 2; }

scenes() {
  ls models/*.yaml bench/scenes/*.yaml tests/scenes/*.yaml examples/*/*.yaml |
    grep -v '_study\.yaml$' | grep -v '/my_study\.yaml$'
}

record() {
  local out=$1 spacearm=${2:-build/cli/spacearm}
  [[ -x $spacearm ]] || { echo "generation_identity: no generator at $spacearm" >&2; exit 2; }
  mkdir -p "$out"
  local n=0 total
  total=$(scenes | wc -l)
  for scene in $(scenes); do
    n=$((n + 1))
    local stem
    stem=$(basename "$(dirname "$scene")")__$(basename "$scene" .yaml)
    echo "[$n/$total] $scene" >&2
    # A refusal (the baseline past the closed form's reach) is kept as its message.
    "$spacearm" generate "$scene" -o "$out" --file-stem "$stem" >/dev/null 2>"$out/$stem.error" &&
      rm "$out/$stem.error"
    "$spacearm" generate "$scene" -o "$out" --file-stem "${stem}_plain" --plain >/dev/null \
      2>"$out/${stem}_plain.error" && rm "$out/${stem}_plain.error"
  done
  # The banner's regeneration command names the output folder: the same for every recording.
  for f in "$out"/*; do
    sed -i "s|-o $out |-o OUT |" "$f"
  done
}

# Lines allowed to differ: the C interface's version and the facts it states about the model.
interface_lines='kCInterfaceVersion|spacearm_c_interface_version|spacearm_free_floating|spacearm_passive_forces|spacearm_configuration_layout|spacearm_num_base|spacearm_num_end_effectors'

compare() {
  local old=$1 new=$2 status=0
  for f in "$old"/*; do
    local g=$new/$(basename "$f")
    if [[ ! -f $g ]]; then echo "missing in $new: $(basename "$f")"; status=1; continue; fi
    if ! diff -q <(grep -Ev "$interface_lines" "$f") <(grep -Ev "$interface_lines" "$g") >/dev/null; then
      echo "differs: $(basename "$f")"
      diff <(grep -Ev "$interface_lines" "$f") <(grep -Ev "$interface_lines" "$g") | head -20 || true
      status=1
    fi
  done
  for g in "$new"/*; do
    [[ -f $old/$(basename "$g") ]] || { echo "new in $new: $(basename "$g")"; status=1; }
  done
  local count
  count=$(ls "$old" | wc -l)
  if ((status == 0)); then echo "generation_identity: all $count files identical (interface lines aside)"; fi
  return $status
}

case "${1:-}" in
  record) [[ $# -ge 2 ]] || usage; record "$2" "${3:-}" ;;
  compare) [[ $# -eq 3 ]] || usage; compare "$2" "$3" ;;
  check)
    [[ $# -ge 2 ]] || usage
    work=$(mktemp -d)
    trap 'rm -rf "$work"' EXIT
    record "$work/old" "$2"
    record "$work/new" "${3:-build/cli/spacearm}"
    compare "$work/old" "$work/new" ;;
  *) usage ;;
esac

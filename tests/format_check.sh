#!/usr/bin/env bash
# Every hand-written C++ file is formatted by .clang-format (100 columns); generated files opt
# out in their banner. Prints the files to reformat with: clang-format -i FILE...
set -euo pipefail
cd "$1"
files=$(git ls-files '*.cpp' '*.hpp' | grep -v '^generated/' || true)
if [[ -z "$files" ]]; then
  echo "format_check: no sources found under $1 (not a git checkout?)" >&2
  exit 1
fi
bad=$(for f in $files; do clang-format --dry-run --Werror "$f" >/dev/null 2>&1 || echo "$f"; done)
if [[ -n "$bad" ]]; then
  echo "format_check: not formatted by .clang-format; run: clang-format -i" $bad >&2
  exit 1
fi
echo "format_check: $(echo $files | wc -w) files formatted"

#!/bin/bash
# README.md's "Writing a plugin" shows a source file whole: the fenced
# ```c block that follows the line "<!-- FILE -->" must equal FILE, so
# the code users copy is the code the tests build and conform-check.
# Usage: test_readme_code.sh README.md path/to/FILE.c
set -u
readme=$1 file=$2
name=$(basename "$file")
block=$(awk -v mark="<!-- $name -->" '
  $0 == mark { armed = 1; next }
  armed && /^```c$/ { inside = 1; next }
  inside && /^```$/ { exit }
  inside { print }' "$readme")
if [ -z "$block" ]; then
  echo "FAIL: $readme has no \`\`\`c block after the line <!-- $name -->: add the marker and the block"
  exit 1
fi
if ! diff -u <(printf '%s\n' "$block") "$file"; then
  echo "FAIL: the code in $readme after <!-- $name --> differs from $file (diff above): copy the file into README.md"
  exit 1
fi
echo "ok: $readme shows $name whole ($(wc -l < "$file") lines)"

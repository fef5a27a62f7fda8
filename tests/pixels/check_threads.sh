#!/usr/bin/env bash
# Runs pixel_hashes.sh on 1 and on 3 threads and compares the two lists.
set -u
[ $# -eq 3 ] || { echo "usage: $0 RTK_EXE SOURCE_ROOT OUT_DIR" >&2; exit 2; }
here=$(dirname "$0")
"$here/pixel_hashes.sh" "$1" "$2" "$3/t1" 1 > "$3/hashes-1.txt" || exit 1
"$here/pixel_hashes.sh" "$1" "$2" "$3/t3" 3 > "$3/hashes-3.txt" || exit 1
"$here/pixel_hashes.sh" --compare "$3/hashes-1.txt" "$3/hashes-3.txt"

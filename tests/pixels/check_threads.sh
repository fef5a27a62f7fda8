#!/usr/bin/env bash
# Runs pixel_hashes.sh on 1 and on 3 threads, and on 1 thread with
# RTK_BATCH=off (integrators' li one camera ray at a time instead of
# li_batch), and compares the lists: renders depend on neither.
set -u
[ $# -eq 3 ] || { echo "usage: $0 RTK_EXE SOURCE_ROOT OUT_DIR" >&2; exit 2; }
here=$(dirname "$0")
"$here/pixel_hashes.sh" "$1" "$2" "$3/t1" 1 > "$3/hashes-1.txt" || exit 1
"$here/pixel_hashes.sh" "$1" "$2" "$3/t3" 3 > "$3/hashes-3.txt" || exit 1
RTK_BATCH=off "$here/pixel_hashes.sh" "$1" "$2" "$3/t1-li" 1 > "$3/hashes-1-li.txt" || exit 1
status=0
echo "1 thread against 3 threads:"
"$here/pixel_hashes.sh" --compare "$3/hashes-1.txt" "$3/hashes-3.txt" || status=1
echo "batches (li_batch) against one ray at a time (RTK_BATCH=off):"
"$here/pixel_hashes.sh" --compare "$3/hashes-1.txt" "$3/hashes-1-li.txt" || status=1
exit $status

#!/usr/bin/env bash
# The A/B harnesses of tools/ab-build and tools/ab-trace still compile,
# link against the build's static kernel and run: a plugin against
# itself builds the same tree, and the unmodified wide traversal gives
# the kernel's answers on every ray.
#   test_ab.sh SOURCE_ROOT BUILD_DIR SANITIZE
set -u
src=$1 build=$2 sanitize=$3
if [ "$sanitize" != none ]; then
    echo "skip: the harnesses link the kernel without the sanitizers this build ($sanitize) needs"
    exit 77
fi
command -v cc >/dev/null && command -v c++ >/dev/null || { echo "skip: no cc/c++ to compile the harnesses"; exit 77; }
passed=0 failed=0
check() { if [ "$1" = 0 ]; then echo "ok    $2"; passed=$((passed + 1)); else echo "FAIL  $2"; failed=$((failed + 1)); fi; }
mesh=$src/scenes/cornell/cornell.obj
sah=$build/plugins/accelerators/sah.so

out=$(bash "$src/tools/ab-build/ab.sh" "$build" "$mesh" "$sah" "$sah" 4 2 2>&1)
status=$?
grep -q "build B/A time: median" <<<"$out"
check $((status + $?)) "ab-build: sah against itself, 2 threads, 4 rounds (same tree, timed)"
[ "$status" = 0 ] || echo "$out" | tail -5 | sed 's/^/    /'

out=$(bash "$src/tools/ab-trace/ab.sh" "$build" "$mesh" "$src/kernel/accel/bvh_wide_trace.c" sah 4 2>&1)
status=$?
grep -q "answers differing: 0 primary, 0 AO" <<<"$out"
check $((status + $?)) "ab-trace: the unmodified traversal against the kernel's, every answer equal"
[ "$status" = 0 ] && grep -q "answers differing: 0 primary, 0 AO" <<<"$out" || echo "$out" | tail -5 | sed 's/^/    /'

echo "$passed passed, $failed failed"
[ "$failed" = 0 ]

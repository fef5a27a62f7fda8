#!/usr/bin/env bash
# Runs one libFuzzer target for RTK_FUZZ_SECONDS (default 60) from a
# corpus seeded with the given files, and fails on any finding: a crash,
# a sanitizer report, a leak, an input taking over 10 s or a process over
# 2 GiB. Findings are kept in FINDINGS_DIR with the input that caused them.
# usage: run_fuzz.sh FUZZER SOURCE_ROOT FINDINGS_DIR [SEED_PATTERN...]
# Seed patterns are globs relative to SOURCE_ROOT (absolute ones as given).
set -u
fuzzer=$1
src=$2
findings=$3
shift 3
seconds=${RTK_FUZZ_SECONDS:-60}
case "$seconds" in
'' | *[!0-9]*) echo "run_fuzz.sh: RTK_FUZZ_SECONDS must be a whole number of seconds, not '$seconds'" >&2; exit 2 ;;
esac
corpus=$(mktemp -d)
work=$(mktemp -d)
trap 'rm -rf "$corpus" "$work"' EXIT
seeds=0
shopt -s nullglob
for pattern in "$@"; do
    [[ $pattern = /* ]] || pattern="$src/$pattern"
    for f in $pattern; do
        [ -f "$f" ] || continue
        cp "$f" "$corpus/seed-$seeds-$(basename "$f")"
        seeds=$((seeds + 1))
    done
done
mkdir -p "$findings"
echo "$(basename "$fuzzer"): $seconds s from $seeds seed files"
# detect_leaks: a leak on any input is a finding; the loaders' temporary
# files go to a private TMPDIR that is removed afterwards.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:intercept_tls_get_addr=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}
TMPDIR=$work "$fuzzer" "$corpus" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
    -malloc_limit_mb=2048 -print_final_stats=1 -artifact_prefix="$findings/" 2>"$work/log"
status=$?
grep -E '^#[0-9]+ +(DONE|INITED)|stat::number_of_executed_units|stat::peak_rss_mb|cov: ' "$work/log" | tail -4
if [ $status -ne 0 ]; then
    tail -60 "$work/log"
    echo "FAIL  $(basename "$fuzzer"): a finding (exit $status); its input is in $findings"
    exit 1
fi
echo "ok    $(basename "$fuzzer"): no finding in $seconds s"

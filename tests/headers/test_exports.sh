#!/usr/bin/env bash
# librtk.so's dynamic symbol table is exactly what its headers say it
# exports: the SDK (RTK_API in include/rtk/) and the kernel services the
# tools call (RTK_KERNEL_API in kernel/); no std:: template instantiations
# from the C++ adapters, no helpers, and none of the tools' entry points
# (tools/tools.h), which live in the rtk_tools library.
# usage: test_exports.sh LIBRTK.so SOURCE_ROOT
set -u
lib=$1 src=$2
if ! command -v nm >/dev/null; then
    echo "SKIP  no nm on PATH (apt-get install binutils)"
    exit 77
fi
declared() { # names of the functions declared after macro $1 in files $2...
    local macro=$1; shift
    grep -h -o -E "^$macro [^(]*[ *]rtk_[a-z0-9_]+\(" "$@" | grep -o -E 'rtk_[a-z0-9_]+\($' | tr -d '(' | sort -u
}
tmp=$(mktemp -d) || exit 1
trap 'rm -rf "$tmp"' EXIT
nm -D --defined-only "$lib" | awk '{print $3}' | grep -v -E '^(_edata|_end|__bss_start|_init|_fini)$' | sort -u > "$tmp/exported"
declared RTK_API "$src"/include/rtk/*.h > "$tmp/sdk"
declared RTK_KERNEL_API "$src"/kernel/*/*.h > "$tmp/kernel"
grep -h -o -E '^[a-z_]+ \**(rtk_[a-z0-9_]+)\(' "$src/tools/tools.h" | grep -o -E 'rtk_[a-z0-9_]+' | sort -u > "$tmp/tools"
sort -u "$tmp/sdk" "$tmp/kernel" > "$tmp/declared"
failed=0
check() { if [ "$1" = 0 ]; then echo "ok    $2"; else echo "FAIL  $2"; failed=$((failed + 1)); fi; }
extra=$(comm -23 "$tmp/exported" "$tmp/declared")
missing=$(comm -13 "$tmp/exported" "$tmp/declared")
tools=$(comm -12 "$tmp/exported" "$tmp/tools")
[ -z "$extra" ]; check $? "librtk.so exports nothing undeclared${extra:+: $(echo $extra | head -c 400)}"
[ -z "$missing" ]; check $? "librtk.so exports every declared function${missing:+ (missing: $(echo $missing | head -c 400))}"
[ -z "$tools" ] && [ -s "$tmp/tools" ]; check $? "no tool entry point is in librtk.so${tools:+: $tools}"
[ "$(wc -l < "$tmp/sdk")" -ge 40 ]; check $? "the SDK declares $(wc -l < "$tmp/sdk") functions"
echo "      exports: $(wc -l < "$tmp/exported") = $(wc -l < "$tmp/sdk") SDK (RTK_API) + $(wc -l < "$tmp/kernel") kernel services for the tools (RTK_KERNEL_API)"
echo "$((4 - failed)) passed, $failed failed"
[ "$failed" = 0 ]

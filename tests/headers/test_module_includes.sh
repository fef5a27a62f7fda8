#!/usr/bin/env bash
# The kernel's module folders meet only through their module headers: a
# file under kernel/M/ may include any header of M, but of another module
# N only kernel/N/N.h; no kernel file includes the tools; internal.h is gone.
# usage: test_module_includes.sh SOURCE_ROOT
set -u
cd "$1/kernel" || exit 1
failed=0 checked=0
while IFS= read -r file; do
    mod=${file%%/*}
    while IFS= read -r inc; do
        checked=$((checked + 1))
        target=$(realpath -m --relative-to=. "$(dirname "$file")/$inc")
        tmod=${target%%/*}
        if [ ! -e "$target" ]; then
            echo "FAIL  kernel/$file includes \"$inc\", which is not a kernel file"; failed=$((failed + 1))
        elif [ "$tmod" != "$mod" ] && [ "$target" != "$tmod/$tmod.h" ]; then
            echo "FAIL  kernel/$file includes kernel/$target: another module's files are reached through kernel/$tmod/$tmod.h"
            failed=$((failed + 1))
        fi
    done < <(sed -n 's/^#include "\([^"]*\)".*/\1/p' "$file" | grep -v '^bvh_wide_isa\.inc$')
done < <(find . -mindepth 2 \( -name '*.c' -o -name '*.h' -o -name '*.cpp' -o -name '*.inc' \) | sed 's|^\./||' | sort)
if [ -e internal.h ] || [ -n "$(find . -name internal.h)" ]; then
    echo "FAIL  kernel/internal.h exists: declarations belong in their module's header"; failed=$((failed + 1))
fi
loose=$(find . -maxdepth 1 \( -name '*.c' -o -name '*.h' -o -name '*.cpp' \) | sed 's|^\./||')
if [ -n "$loose" ]; then
    echo "FAIL  source files outside a module folder: $loose"; failed=$((failed + 1))
fi
[ "$checked" -gt 40 ] || { echo "FAIL  only $checked includes found: is $1/kernel the kernel?"; failed=$((failed + 1)); }
if [ "$failed" = 0 ]; then
    echo "ok    $checked includes under kernel/ keep to their module or another module's header"
    echo "1 passed, 0 failed"
else
    echo "0 passed, $failed failed"
    exit 1
fi

#!/usr/bin/env bash
# librtk.so's dynamic symbol table holds its API (rtk_*) and nothing else:
# no std:: template instantiations from the C++ adapters, no helpers.
# usage: test_exports.sh LIBRTK.so
set -u
lib=$1
if ! command -v nm >/dev/null; then
    echo "SKIP  no nm on PATH (apt-get install binutils)"
    exit 77
fi
syms=$(nm -D --defined-only "$lib" | awk '{print $3}' | grep -v -E '^(rtk_|_edata$|_end$|__bss_start$|_init$|_fini$)')
api=$(nm -D --defined-only "$lib" | awk '{print $3}' | grep -c '^rtk_')
if [ -n "$syms" ]; then
    echo "FAIL  librtk.so exports symbols outside its API:"
    echo "$syms" | head -20 | sed 's/^/    /'
    echo "0 passed, 1 failed"
    exit 1
fi
if [ "$api" -lt 40 ]; then
    echo "FAIL  librtk.so exports only $api rtk_ functions"
    echo "0 passed, 1 failed"
    exit 1
fi
echo "ok    librtk.so exports $api rtk_ functions and nothing else"
echo "1 passed, 0 failed"

#!/usr/bin/env bash
# Runs a command that must fail with a message containing FRAGMENT.
# usage: expect_refusal.sh FRAGMENT CMD [ARG...]
fragment=$1
shift
out=$("$@" 2>&1)
status=$?
echo "$out"
if [ $status -eq 0 ]; then
    echo "FAIL: '$*' succeeded; expected a refusal mentioning: $fragment"
    exit 1
fi
if ! grep -qF -- "$fragment" <<<"$out"; then
    echo "FAIL: refused, but the message lacks: $fragment"
    exit 1
fi
echo "ok: refused with '$fragment'"

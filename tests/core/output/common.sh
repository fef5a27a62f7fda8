# Shared by the tests/core/output scripts (sourced): counters and the check of a
# write that had to fail.
passed=0
failed=0
ok() { passed=$((passed + 1)); echo "ok    $1"; }
bad() { failed=$((failed + 1)); echo "FAIL  $1"; }
show() { sed 's/^/    /' "$1"; }

# check_refused NAME STATUS LOG DIR TARGET OLD REASON: the render failed
# (exit 1..127) saying REASON, that its temporary was removed and that the
# previous file is unchanged; DIR holds no temporary; TARGET equals OLD.
check_refused() {
    local name=$1 status=$2 log=$3 dir=$4 target=$5 old=$6 reason=$7 leftovers
    leftovers=$(ls -A "$dir" | grep '\.tmp' || true)
    if [ "$status" -eq 0 ] || [ "$status" -ge 128 ]; then
        bad "$name: exit $status"; show "$log"
    elif ! grep -q "$reason while writing its temporary file .*which was removed; the previous file is unchanged" "$log"; then
        bad "$name: the message does not say '$reason' and that the old file is kept"; show "$log"
    elif [ -n "$leftovers" ]; then
        bad "$name: temporary files left: $leftovers"
    elif ! cmp -s "$target" "$old"; then
        bad "$name: the previous output changed"
    else
        ok "$name: refused, previous file kept, nothing left"
    fi
}

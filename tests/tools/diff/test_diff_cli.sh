#!/usr/bin/env bash
# End-to-end checks of `rtk diff` on images that test_diff --fixtures writes
# with rtk_image_write: the exact text and CSV output, NaN reporting, error
# images, and the exit status and message of each usage or input error.
# usage: test_diff_cli.sh RTK TEST_DIFF
set -u
rtk=$1
test_diff=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
passed=0
failed=0

ok() { passed=$((passed + 1)); echo "ok    $1"; }
bad() { failed=$((failed + 1)); echo "FAIL  $1"; }
# expect NAME STATUS PATTERN... -- CMD...: runs CMD, checks its exit status
# and that its output (stdout and stderr) has every pattern.
expect() {
    local name=$1 want=$2
    shift 2
    local patterns=()
    while [ "$1" != "--" ]; do patterns+=("$1"); shift; done
    shift
    local out status
    out=$("$@" 2>&1)
    status=$?
    if [ $status -ne "$want" ]; then
        bad "$name (exit $status, expected $want)"; echo "$out" | sed 's/^/    /'; return
    fi
    for p in "${patterns[@]}"; do
        if ! grep -qF -- "$p" <<<"$out"; then
            bad "$name (no '$p' in output)"; echo "$out" | sed 's/^/    /'; return
        fi
    done
    ok "$name"
}
# line KEY VALUES: one line of the text output, as rtk diff pads it.
line() { printf '%-20s %s' "$1" "$2"; }

if ! "$test_diff" --fixtures "$tmp"; then
    echo "cannot write the fixtures"
    exit 1
fi
cd "$tmp" || exit 1

# test.exr: the 4x2 reference ref.exr (0.5 everywhere) with R of pixel
# (0,0) at 1.0 and G of pixel (1,0) at 0.25; epsilon 0.01.
out=$("$rtk" diff test.exr ref.exr 2>"$tmp/stderr")
status=$?
[ $status -eq 0 ] && ok "diff exits 0" || bad "diff exits 0 (exit $status)"
want=(
    "$(line test test.exr)"
    "$(line reference ref.exr)"
    "$(line size 4x2)"
    "$(line epsilon 0.01)"
    "$(line psnr_peak 1)"
    "$(line overall_channels 'R G B')"
    "$(line samples 'R 8 G 8 B 8 A 8 overall 24')"
    "$(line excluded 'R 0 G 0 B 0 A 0 overall 0')"
    "$(line nonfinite_test 'R 0 G 0 B 0 A 0 overall 0')"
    "$(line nonfinite_reference 'R 0 G 0 B 0 A 0 overall 0')"
    "$(line rmse 'R 0.176776695 G 0.0883883476 B 0 A 0 overall 0.114108866')"
    "$(line mse 'R 0.03125 G 0.0078125 B 0 A 0 overall 0.0130208333')"
    "$(line relmse 'R 0.120192308 G 0.0300480769 B 0 A 0 overall 0.0500801282')"
    "$(line mape 'R 0.12254902 G 0.0612745098 B 0 A 0 overall 0.0612745098')"
    "$(line smape 'R 0.082781457 G 0.0822368421 B 0 A 0 overall 0.0550060997')"
    "$(line psnr 'R 15.0514998 G 21.0720997 B inf A inf overall 18.8536122')"
    "$(line mean_error 'R 0.0625 G -0.03125 B 0 A 0 overall 0.0104166667')"
)
if [ "$out" = "$(printf '%s\n' "${want[@]}")" ]; then
    ok "text output is exactly the hand-computed metrics"
else
    bad "text output is exactly the hand-computed metrics"
    diff <(printf '%s\n' "${want[@]}") <(echo "$out") | sed 's/^/    /'
fi
[ ! -s "$tmp/stderr" ] && ok "nothing on stderr without NaN/Inf" || bad "nothing on stderr without NaN/Inf"

out=$("$rtk" diff test.exr ref.exr --csv --epsilon 1)
want_csv="channel,samples,excluded,nonfinite_test,nonfinite_reference,rmse,mse,relmse,mape,smape,psnr,mean_error,epsilon,psnr_peak
R,8,0,0,0,0.176776695,0.03125,0.025,0.0416666667,0.05,15.0514998,0.0625,1,1
G,8,0,0,0,0.0883883476,0.0078125,0.00625,0.0208333333,0.0357142857,21.0720997,-0.03125,1,1
B,8,0,0,0,0,0,0,0,0,inf,0,1,1
A,8,0,0,0,0,0,0,0,0,inf,0,1,1
overall,24,0,0,0,0.114108866,0.0130208333,0.0104166667,0.0208333333,0.0285714286,18.8536122,0.0104166667,1,1"
if [ "$out" = "$want_csv" ]; then
    ok "--csv: a header and one row per channel, --epsilon applied"
else
    bad "--csv: a header and one row per channel, --epsilon applied"
    diff <(echo "$want_csv") <(echo "$out") | sed 's/^/    /'
fi

expect "NaN in the test image is counted, reported and left out" 0 \
    "$(line excluded 'R 0 G 0 B 1 A 0 overall 1')" "$(line nonfinite_test 'R 0 G 0 B 1 A 0 overall 1')" \
    "$(line samples 'R 8 G 8 B 7 A 8 overall 23')" "warning: 1 samples with NaN or Inf left out" \
    -- "$rtk" diff nan.exr ref.exr
expect "a PNG against itself" 0 "$(line mse 'R 0 G 0 B 0 A 0 overall 0')" -- "$rtk" diff ref.png ref.png

expect "sizes differ: exit 2 naming both files and sizes" 2 "test.exr" "(4x2)" "small.exr" "(2x2)" "sizes differ" \
    -- "$rtk" diff test.exr small.exr
expect "grey against colour: exit 2 naming both files and their channels" 2 "grey.exr" "(1 channel, grey)" \
    "ref.exr" "(3 channels, RGB)" "convert one of them" -- "$rtk" diff grey.exr ref.exr
expect "alpha on one side only is said, compared as 1" 0 "'ref.exr' has no alpha channel: its A is compared as 1" \
    -- "$rtk" diff zero.exr ref.exr
expect "missing reference: exit 2 naming the file and the reason" 2 "missing.exr" "No such file or directory" \
    -- "$rtk" diff test.exr missing.exr
expect "missing test image: exit 2 naming the file" 2 "gone.png" "No such file or directory" \
    -- "$rtk" diff gone.png ref.exr
echo "not an image" >junk.exr
expect "unreadable file: exit 2 naming the file" 2 "junk.exr" -- "$rtk" diff junk.exr ref.exr
expect "one image only is a usage error" 2 "needs two images" -- "$rtk" diff test.exr
expect "--epsilon 0 is a usage error" 2 "--epsilon" -- "$rtk" diff test.exr ref.exr --epsilon 0
expect "--epsilon text is a usage error" 2 "not 'abc'" -- "$rtk" diff test.exr ref.exr --epsilon abc
expect "unknown option is a usage error" 2 "--frob" -- "$rtk" diff test.exr ref.exr --frob
expect "--help gives the exit status" 0 "rtk diff A B" "--error-image" "2 usage or input error" -- "$rtk" diff --help

expect "--error-image .exr is written" 0 "rmse" -- "$rtk" diff test.exr ref.exr --error-image err.exr
# zero.exr is RGBA, all 0: err.exr's A (|1 - 1|) compares to 0 too.
expect "the error EXR holds |A - B|" 0 "$(line mse 'R 0.03125 G 0.0078125 B 0 A 0 overall 0.0130208333')" \
    -- "$rtk" diff err.exr zero.exr
expect "--error-image .png heat map is written" 0 "rmse" -- "$rtk" diff nan.exr ref.exr --error-image heat.png
[ -s heat.png ] && ok "heat map file exists" || bad "heat map file exists"
expect "unwritable error image: metrics, then exit 1 naming it" 1 "rmse" "no/such/dir/e.png" \
    -- "$rtk" diff test.exr ref.exr --error-image no/such/dir/e.png
ls | grep -q '\.tmp' && bad "no temporary file left behind" || ok "no temporary file left behind"

echo "$passed passed, $failed failed"
[ $failed -eq 0 ]

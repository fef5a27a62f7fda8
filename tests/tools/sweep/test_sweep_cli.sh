#!/usr/bin/env bash
# End-to-end checks of `rtk sweep` on a 16x16 Cornell box AO: the CSV's
# columns and rows, the reference cached by the first run and reused by the
# second, no temporary files left, errors that name a bad axis value, and
# the plot (drawn when gnuplot is there; a missing gnuplot is an error only
# with --plot). No timing is checked.
# usage: test_sweep_cli.sh RTK SOURCE_ROOT
set -u
rtk=$1
root=$2
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

cfg=$root/scenes/cornell/cornell-ao.cfg
small=(--set film.width=16 --set film.height=16 --set integrator.rays=2 --threads 2
       --spp 1,2,4 --seeds 2 --reference-spp 256)
out=$tmp/out

expect "first sweep renders the reference" 0 \
    "(rendered: 256 spp, independent sampler, box filter" \
    "independent" "stratified" "RMSE slope" "csv        $out/sweep.csv (12 rows)" -- \
    "$rtk" sweep "$cfg" "${small[@]}" --samplers independent,stratified --out "$out"

csv=$out/sweep.csv
header="scene,integrator,sampler,accelerator,filter,params,spp,seed,threads,build_s,render_s,rays,mrays_per_s,rmse,relmse,mape,nan_count,excluded,load_s,cpu_s,combination"
[ "$(head -n 1 "$csv")" = "$header" ] && ok "CSV header" || bad "CSV header: $(head -n 1 "$csv")"
rows=$(tail -n +2 "$csv" | wc -l)
[ "$rows" -eq 12 ] && ok "CSV has 2 samplers x 3 spp x 2 seeds = 12 rows" || bad "CSV rows: $rows"
awk -F, 'NR > 1 && NF != 21 { exit 1 }' "$csv" && ok "every row has 21 fields" || bad "a row has != 21 fields"
# The runs in order: sampler slowest, then spp, then seed.
want_keys="independent,1,1 independent,1,2 independent,2,1 independent,2,2 independent,4,1 independent,4,2
stratified,1,1 stratified,1,2 stratified,2,1 stratified,2,2 stratified,4,1 stratified,4,2"
got_keys=$(awk -F, 'NR > 1 { printf "%s%s,%s,%s", (NR > 2 ? " " : ""), $3, $7, $8 }' "$csv")
[ "$got_keys" = "$(echo $want_keys)" ] && ok "rows: sampler, spp, seed" || bad "rows: $got_keys"
awk -F, 'NR > 1 && ($1 != "cornell.obj" || $2 != "ao" || $5 != "box" || $9 != 2) { exit 1 }' "$csv" &&
    ok "scene, integrator, filter, threads columns" || bad "scene/integrator/filter/threads columns"
# Errors are finite and positive, rays counted, no NaN samples.
awk -F, 'NR > 1 && !($12 > 0 && $14 > 0 && $15 > 0 && $16 > 0 && $17 == 0 && $18 == 0) { exit 1 }' "$csv" &&
    ok "rays, rmse, relmse, mape > 0; nan_count = excluded = 0" || bad "a row has a bad metric"
# More samples, less error: mean RMSE at 4 spp below 1 spp for each sampler.
awk -F, 'NR > 1 { s[$3 "," $7] += $14 }
    END { if (!(s["independent,4"] < s["independent,1"] && s["stratified,4"] < s["stratified,1"])) exit 1 }' "$csv" &&
    ok "RMSE falls with spp" || bad "RMSE does not fall with spp"
for f in sweep.txt sweep.dat sweep.gp; do
    [ -s "$out/$f" ] && ok "$f written" || bad "$f missing"
done
refs=$(ls "$out"/reference-*.exr 2>/dev/null | wc -l)
[ "$refs" -eq 1 ] && ok "one cached reference" || bad "$refs cached references"
leftovers=$(ls -A "$out" | grep -E '\.tmp|^\.sweep-run' || true)
[ -z "$leftovers" ] && ok "no temporary files left" || bad "left behind: $leftovers"
if command -v gnuplot >/dev/null; then
    if [ "$(head -c 8 "$out/sweep.png" | od -An -tx1 | tr -d ' \n')" = 89504e470d0a1a0a ]; then
        ok "sweep.png is a PNG"
    else
        bad "sweep.png missing or not a PNG"
    fi
else
    echo "skip  sweep.png (gnuplot not installed)"
fi

ref_before=$(ls "$out"/reference-*.exr)
expect "second sweep reuses the reference" 0 "(cached, reused)" -- \
    "$rtk" sweep "$cfg" "${small[@]}" --samplers independent,stratified --out "$out"
[ "$(ls "$out"/reference-*.exr)" = "$ref_before" ] && ok "still one reference, the same file" ||
    bad "reference files changed"
expect "per-filter references: box reused, triangle rendered" 0 "(cached, reused)" \
    "(rendered: 256 spp, independent sampler, triangle filter" -- \
    "$rtk" sweep "$cfg" "${small[@]}" --samplers independent --filters box,triangle --reference-filter same \
    --spp 1 --seeds 1 --out "$out"
expect "another resolution renders another reference" 0 "(rendered: 256 spp" -- \
    "$rtk" sweep "$cfg" "${small[@]}" --set film.width=8 --samplers independent --spp 1,2 --seeds 1 \
    --out "$out"

expect "bad sampler named" 1 "--samplers value 'bogus'" "sampler.type=bogus" -- \
    "$rtk" sweep "$cfg" "${small[@]}" --samplers independent,bogus --out "$tmp/bad"
expect "bad filter named" 1 "--filters value 'nosuch'" -- \
    "$rtk" sweep "$cfg" "${small[@]}" --filters box,nosuch --out "$tmp/bad"
expect "bad --param key named" 1 "--param integrator.nosuch value '3'" "integrator.nosuch=3" -- \
    "$rtk" sweep "$cfg" "${small[@]}" --param integrator.nosuch=3 --out "$tmp/bad"
expect "out-of-range --param value named" 1 "--param integrator.rays value '0'" "integrator.rays=0" -- \
    "$rtk" sweep "$cfg" "${small[@]}" --param integrator.rays=4,0 --out "$tmp/bad"
expect "spp must increase" 1 "spp values must increase: 2 after 4" -- \
    "$rtk" sweep "$cfg" "${small[@]}" --spp 1,4,2 --out "$tmp/bad"
expect "malformed --param" 2 "--param needs KEY=V1,V2" -- \
    "$rtk" sweep "$cfg" --param integrator.rays --out "$tmp/bad"
expect "missing config" 1 "nosuch.cfg: cannot read config" -- \
    "$rtk" sweep "$tmp/nosuch.cfg" --out "$tmp/bad"
expect "reference of another size" 1 "is 16x16, but combination" -- \
    "$rtk" sweep "$cfg" "${small[@]}" --set film.width=8 --reference "$ref_before" --out "$tmp/bad"
expect "given reference used" 0 "reference  $ref_before (given)" -- \
    "$rtk" sweep "$cfg" "${small[@]}" --reference "$ref_before" --spp 1 --seeds 1 --out "$tmp/given"
[ -z "$(ls "$tmp/given" | grep reference- || true)" ] && ok "no reference rendered when one is given" ||
    bad "a reference was rendered although one was given"

# No gnuplot on PATH: the script and data stay, exit 0; with --plot, exit 1.
expect "no gnuplot: script left, exit 0" 0 "plot       not drawn (gnuplot not found" -- \
    env PATH=/nonexistent "$rtk" sweep "$cfg" "${small[@]}" --spp 1 --seeds 1 --out "$tmp/noplot"
[ -s "$tmp/noplot/sweep.gp" ] && [ ! -e "$tmp/noplot/sweep.png" ] && ok "script kept, no PNG" ||
    bad "no-gnuplot files"
expect "no gnuplot with --plot: error" 1 "gnuplot not found on PATH" "gnuplot sweep.gp" -- \
    env PATH=/nonexistent "$rtk" sweep "$cfg" "${small[@]}" --spp 1 --seeds 1 --plot --out "$tmp/noplot"

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]

#!/usr/bin/env bash
# Here, after a GPU check (run.sh's render step): compares each render
# through cuda's device program (ao on the meshes, path in the Cornell
# box) with sah's at the same seed, the noise measured by sah's render at
# another seed. The GPU's image is within noise when |mean error| <= 3
# standard errors of the mean, the standard error being rmse(cpu1, cpu0) /
# sqrt(pixels) (two independent renders differ by sqrt(2) sigma a pixel;
# the GPU's shares cpu0's seed, so its error is at most that; R, G and B
# of a pixel come from the same rays, hence pixels, not samples).
#
#   tools/gpu-check/compare.sh DIR [RTK]   (DIR: the fetched $OUT; RTK: default build/tools/rtk)
set -u
dir=$1
rtk=${2:-build/tools/rtk}
[ -x "$rtk" ] || { echo "compare.sh: $rtk is not built" >&2; exit 2; }
shopt -s nullglob
tars=("$dir"/renders-*.tar.gz)
[ ${#tars[@]} -gt 0 ] || { echo "compare.sh: no renders-*.tar.gz in $dir" >&2; exit 2; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
bad=0
for t in "${tars[@]}"; do
    m=$(basename "$t" .tar.gz)
    m=${m#renders-}
    mkdir -p "$tmp/$m" && tar xzf "$t" -C "$tmp/$m" || { echo "$m: cannot unpack $t"; bad=1; continue; }
    r=$tmp/$m
    gpu=$("$rtk" diff "$r/$m-cuda.pfm" "$r/$m-cpu0.pfm" --csv 2>/dev/null | awk -F, '$1 == "overall"')
    ref=$("$rtk" diff "$r/$m-cpu1.pfm" "$r/$m-cpu0.pfm" --csv 2>/dev/null | awk -F, '$1 == "overall"')
    size=$("$rtk" diff "$r/$m-cpu1.pfm" "$r/$m-cpu0.pfm" 2>/dev/null | awk '$1 == "size" { print $2 }')
    if [ -z "$gpu" ] || [ -z "$ref" ] || [ -z "$size" ]; then
        echo "$m: rtk diff failed on $r"; bad=1; continue
    fi
    # csv: channel,samples,excluded,nonfinite_test,nonfinite_reference,rmse,mse,relmse,mape,smape,psnr,mean_error,...
    awk -F, -v m="$m" -v size="$size" -v gpu="$gpu" -v ref="$ref" 'BEGIN {
        split(gpu, g, ","); split(ref, c, ","); split(size, wh, "x")
        px = wh[1] * wh[2]; se = c[6] / sqrt(px); me = g[12]
        ame = me < 0 ? -me : me
        ok = ame <= 3 * se
        fmt = "%s: GPU - CPU mean error %.3g (%.2f standard errors of %.3g), rmse %.4g; CPU seed 1 - seed 0 rmse %.4g: %s\n"
        printf fmt, m, me, (se > 0 ? me / se : 0), se, g[6], c[6], (ok ? "within noise" : "NOT within noise")
        exit !ok }' || bad=1
done
exit $bad

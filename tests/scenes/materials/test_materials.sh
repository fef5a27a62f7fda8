#!/bin/bash
# Every config in scenes/materials/ renders at 32 x 32, 4 spp, and its
# image is not black and took no NaN or infinite sample: rtk exits 0, the
# report says "0 NaN/Inf samples dropped" and its linear mean has a
# luminance above 0.005 (the smallest shipped scene gives about 0.1).
# Usage: test_materials.sh RTK SOURCE_ROOT OUT_DIR [RTK_RENDER_OPTION...]
# (the options are added to every render, e.g. to see the test fail).
set -u
[ $# -ge 3 ] || { echo "usage: $0 RTK SOURCE_ROOT OUT_DIR [RTK_RENDER_OPTION...]" >&2; exit 2; }
rtk=$1 src=$2 out=$3
shift 3
mkdir -p "$out" || exit 2
fails=0 count=0
for cfg in "$src"/scenes/materials/*.cfg; do
    [ -f "$cfg" ] || continue
    count=$((count + 1))
    name=$(basename "$cfg" .cfg)
    if ! report=$("$rtk" render "$cfg" --no-cache --set film.width=32 --set film.height=32 --set film.spp=4 \
                  -o "$out/$name.exr" "$@" 2>&1); then
        echo "FAIL  $name: rtk render failed:"
        echo "$report"
        fails=$((fails + 1))
        continue
    fi
    mean=$(sed -n 's/^mean *\([^ ]*\) \([^ ]*\) \([^ ]*\) (linear RGB)$/\1 \2 \3/p' <<<"$report")
    nans=$(sed -n 's/.* \([0-9]*\) NaN\/Inf samples dropped$/\1/p' <<<"$report")
    if [ -z "$mean" ] || [ "$nans" != 0 ]; then
        echo "FAIL  $name: no mean in the report, or NaN/Inf samples ('$nans'):"
        echo "$report"
        fails=$((fails + 1))
    elif ! awk -v m="$mean" 'BEGIN { split(m, c, " "); y = 0.2126 * c[1] + 0.7152 * c[2] + 0.0722 * c[3];
                                      exit !(y == y && y > 0.005 && y < 1e6) }'; then
        echo "FAIL  $name: mean $mean (linear RGB) is black or not finite"
        fails=$((fails + 1))
    else
        echo "ok    $name: mean $mean"
    fi
done
if [ "$count" -lt 3 ]; then
    echo "FAIL  found $count configs in $src/scenes/materials, expected 3 or more"
    fails=$((fails + 1))
fi
echo "$fails failed"
exit $((fails > 0))

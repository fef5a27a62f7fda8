#!/bin/bash
# The 10,000-bunny scene (scenes/instances/bunnies.cfg) renders, and its
# memory grows by the instance records only: the same scene with one
# bunny, rendered the same way, peaks at most 2 x the reported instance
# bytes + 2 MiB lower. (The top-level build's temporary arrays take less
# than the records; 2 MiB covers allocator and page granularity.)
# Usage: test_bunnies.sh RTK SOURCE_ROOT SANITIZE (meson's b_sanitize:
# under a sanitizer peak memory includes shadow memory and quarantine, so
# only the render is checked)
set -u
rtk=$1
src=$2
sanitize=${3:-none}
bunny="$src/../shared/data/meshes/bunny.obj"
if [ ! -f "$bunny" ]; then
    echo "skip: $bunny not found (../shared/data is absent)"
    exit 77
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0
ok() { echo "ok    $*"; }
bad() { echo "FAIL  $*"; fails=$((fails + 1)); }
small=(--set film.width=96 --set film.height=54 --set film.spp=1 --no-cache --threads 2)

# As shipped, at a small size.
if out=$("$rtk" render "$src/scenes/instances/bunnies.cfg" "${small[@]}" -o "$tmp/shipped.png" 2>&1) &&
    [ -s "$tmp/shipped.png" ] && grep -q "10000 instances of 1 mesh place 754080000 triangles" <<<"$out"; then
    ok "scenes/instances/bunnies.cfg renders: $(grep '^load' <<<"$out")"
else
    bad "scenes/instances/bunnies.cfg: $out"
fi

# The same scene with 10,000 and with 1 bunny.
peak() { sed -n 's/^memory *\([0-9.]*\) MiB peak.*/\1/p' <<<"$1"; }
for n in 100 1; do
    cat >"$tmp/grid$n.cfg" <<CFG
scene = "$src/scenes/instances/ground.obj";
instances = ( { file = "$bunny"; grid = [$n, 1, $n]; spacing = [1.2, 0.0, 1.2]; } );
camera = { position = [-4.0, 6.0, -4.0]; look_at = [30.0, -0.5, 30.0]; fov = 45.0; };
accelerator = { plugin = "sah"; };
integrator = { plugin = "ao"; rays = 2; distance = 3.0; };
CFG
    if ! out=$("$rtk" render "$tmp/grid$n.cfg" "${small[@]}" -o "$tmp/grid$n.png" 2>&1); then
        bad "grid $n x $n: $out"
        exit 1
    fi
    eval "out$n=\$out"
done
p100=$(peak "$out100")
p1=$(peak "$out1")
inst=$(sed -n 's/.*instances \([0-9.]*\) MiB$/\1/p' <<<"$out100")
geo=$(sed -n 's/.*geometry \([0-9.]*\) MiB, BVH \([0-9.]*\) MiB.*/\1 + \2/p' <<<"$out100")
if [ "$sanitize" != none ]; then
    echo "skip  peak memory under -Db_sanitize=$sanitize: $p100 vs $p1 MiB (instance records $inst MiB)"
elif [ -n "$p100" ] && [ -n "$p1" ] && [ -n "$inst" ] &&
    awk -v a="$p100" -v b="$p1" -v i="$inst" 'BEGIN { exit !(a - b <= 2 * i + 2) }'; then
    ok "peak memory: 10,000 bunnies $p100 MiB, one bunny $p1 MiB (difference <= 2 x $inst MiB of instance records + 2 MiB); geometry + BVH $geo MiB either way"
else
    bad "peak memory: 10,000 bunnies '$p100' MiB vs one '$p1' MiB, instance records '$inst' MiB"
fi
echo "$fails failed"
exit $((fails > 0))

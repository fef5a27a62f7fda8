#!/usr/bin/env bash
# A/B of wide traversal variants, or of rtk against Embree, in one process.
#   tools/ab-trace/ab.sh BUILD_DIR MESH.obj VARIANT.c|embree [ACCEL] [ROUNDS]
# VARIANT.c is a modified copy of kernel/bvh_wide.c: it is compiled with the
# kernel's flags, its external symbols renamed rtk_* -> B_*, and linked
# beside BUILD_DIR's kernel (A). "embree" compares ACCEL (default sah)
# with the embree plugin. Environment: AB_CAMERA=EX,EY,EZ,LX,LY,LZ,FOV
# (default: the bench recipe's camera), AB_REBUILD=1 (the variant builds
# its own wide tree, for changes to the collapse), AB_SET=KEY=VALUE (a
# parameter of ACCEL for the variant's tree, with AB_REBUILD), AB_BUILD=1
# (time the wide builds, one thread, instead of the tracing; the trees
# must be the same unless AB_DIFFERENT=1), AB_WRAP=COMMAND (run the
# program under it: perf record, valgrind), AB_CFLAGS (more flags for
# the variant's compilation, after the kernel's), AB_AO_SCALE=F (AO
# rays' tfar times F), AB_REPEAT=K (each ray traced K times in a row);
# AB_DIFFERENT=1 also times tracers that answer differently. Prints the
# median and quartiles over ROUNDS (default 400) of B's time over A's.
set -euo pipefail
[ $# -ge 3 ] || { sed -n '2,18p' "$0" >&2; exit 2; }
. "$(dirname "$0")/../ab-harness.sh"
variant=$3
[ "$variant" = embree ] && variant=$src/kernel/bvh_wide.c
# Under its own name: bvh_wide.c includes itself (the AVX node loop), and
# the variant must read its own loop, not the kernel's.
cp "$variant" "$out/bvh_wide.c"
cc "${inc[@]}" -fvisibility=hidden -D_FILE_OFFSET_BITS=64 -std=c11 -O2 -g -D_GNU_SOURCE -fPIC -pthread \
   -ffp-contract=off -fno-semantic-interposition -DRTK_BUILDING_KERNEL ${AB_CFLAGS:-} -c "$out/bvh_wide.c" -o "$out/variant.o"
renames=()
for sym in $(nm "$out/variant.o" | awk '$2 ~ /^[TDBR]$/ && $3 ~ /^rtk_/ {print $3}'); do
    renames+=(--redefine-sym "$sym=B_${sym#rtk_}")
done
objcopy "${renames[@]}" "$out/variant.o" "$out/variant_b.o"
ab_compile "$src/tools/ab-trace/ab.c"
ab_link "$out/variant_b.o"
RTK_PLUGIN_PATH=$build/plugins/accelerators ${AB_WRAP:-} "$out/ab" "$2" "$3" "${4:-sah}" "${5:-400}"

#!/usr/bin/env bash
# A/B of two builds of an accelerator plugin, in one process.
#   tools/ab-build/ab.sh BUILD_DIR MESH.obj A.so B.so [ROUNDS] [THREADS]
# A.so and B.so are two builds of one accelerator (say BUILD_DIR's
# plugins/accelerators/sah.so and a copy built from a modified sah.c).
# Both build the mesh's tree from the kernel's inputs, first once each
# to check that the trees match byte for byte, then ROUNDS times each
# (default 40), alternating, on THREADS threads (default 1). Prints the
# median and quartiles of B's build time over A's. Environment:
# AB_SET=KEY=VALUE (a parameter for both), AB_DIFFERENT=1 (time them
# even when the trees differ), AB_WRAP=COMMAND (run the program under
# it: perf record, valgrind).
set -euo pipefail
[ $# -ge 4 ] || { sed -n '2,13p' "$0" >&2; exit 2; }
src=$(cd "$(dirname "$0")/../.." && pwd)
build=$(cd "$1" && pwd)
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
inc=(-I"$build/kernel" -I"$src/kernel" -I"$build/include" -I"$src/include")
cc "${inc[@]}" -std=c11 -O2 -g -D_GNU_SOURCE -pthread -c "$src/tools/ab-build/ab.c" -o "$out/ab.o"
# The kernel linked in and exported: the plugins' calls into librtk
# resolve to it, the copy whose state (errors, thread pool) ab reads.
c++ -o "$out/ab" "$out/ab.o" -Wl,--whole-archive "$build/kernel/librtk_static.a" \
    -Wl,--no-whole-archive "$build/kernel/librtk_bench.a" -Wl,--export-dynamic -lm -pthread -ldl \
    $(pkg-config --libs tinygltf tinyobjloader libconfig 2>/dev/null || echo -ltinygltf -ltinyobjloader -lconfig)
${AB_WRAP:-} "$out/ab" "$2" "$(realpath "$3")" "$(realpath "$4")" "${5:-40}" "${6:-1}"

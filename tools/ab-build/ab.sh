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
. "$(dirname "$0")/../ab-harness.sh"
ab_compile "$src/tools/ab-build/ab.c"
ab_link
${AB_WRAP:-} "$out/ab" "$2" "$(realpath "$3")" "$(realpath "$4")" "${5:-40}" "${6:-1}"

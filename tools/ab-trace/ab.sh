#!/usr/bin/env bash
# A/B of wide traversal variants, or of rtk against Embree, in one process.
#   tools/ab-trace/ab.sh BUILD_DIR MESH.obj VARIANT.c|embree [ACCEL] [ROUNDS]
# VARIANT.c is a modified copy of kernel/accel/bvh_wide_trace.c (or of
# bvh_wide_build.c, for changes to the collapse: see AB_REBUILD); the
# other of the two is the kernel's own. Both are compiled with the
# kernel's flags (BUILD_DIR's compile_commands.json), their external
# symbols renamed rtk_* -> B_*, and linked beside BUILD_DIR's kernel (A).
# "embree" compares ACCEL (default sah) with the embree plugin.
# Environment: AB_ISA=FILE (a modified copy of bvh_wide_isa.inc, the AVX
# node loop, that VARIANT.c includes instead of the kernel's),
# AB_CAMERA=EX,EY,EZ,LX,LY,LZ,FOV (default: the bench recipe's camera),
# AB_REBUILD=1 (the variant builds its own wide tree, for changes to the
# collapse), AB_SET=KEY=VALUE (a parameter of ACCEL for the variant's
# tree, with AB_REBUILD), AB_BUILD=1 (time the wide builds, one thread,
# instead of the tracing; the trees must be the same unless
# AB_DIFFERENT=1), AB_WRAP=COMMAND (run the program under it: perf
# record, valgrind), AB_CFLAGS (more flags for the variant's compilation,
# after the kernel's), AB_AO_SCALE=F (AO rays' tfar times F), AB_REPEAT=K
# (each ray traced K times in a row), AB_BATCH=N (B traces N rays to a
# call through its batch functions), AB_BATCH_A=N (the same for A);
# AB_DIFFERENT=1 also times tracers that answer differently. Prints the
# median and quartiles over ROUNDS (default 400) of B's time over A's.
set -euo pipefail
[ $# -ge 3 ] || { sed -n '2,23p' "$0" >&2; exit 2; }
. "$(dirname "$0")/../ab-harness.sh"
variant=$3
[ "$variant" = embree ] && variant=$src/kernel/accel/bvh_wide_trace.c
[ -f "$variant" ] || { echo "ab.sh: $variant: no such file (give a copy of kernel/accel/bvh_wide_trace.c, or embree)" >&2; exit 2; }
isa=${AB_ISA:-$src/kernel/accel/bvh_wide_isa.inc}
[ -f "$isa" ] || { echo "ab.sh: AB_ISA=$isa: no such file (give a copy of kernel/accel/bvh_wide_isa.inc)" >&2; exit 2; }
# In a folder of its own beside its bvh_wide_isa.inc: the variant's
# #include "bvh_wide_isa.inc" finds that one before the kernel's.
mkdir "$out/variant"
cp "$variant" "$out/variant/variant.c"
cp "$isa" "$out/variant/bvh_wide_isa.inc"

# kernel_cc SOURCE KERNEL_FILE OBJECT [FLAGS...]: compiles SOURCE with the
# command BUILD_DIR compiles kernel/accel/KERNEL_FILE with, the kernel's
# accel folder on the include path, then FLAGS.
kernel_cc() {
    python3 - "$build/compile_commands.json" "$src/kernel/accel" "$@" <<'PY'
import json, os, shlex, subprocess, sys
db, accel, source, name, obj, extra = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5], sys.argv[6:]
for e in json.load(open(db)):
    if os.path.normpath(os.path.join(e["directory"], e["file"])) == os.path.join(accel, name) and \
            "librtk_static" in e["output"]:
        break
else:
    sys.exit("ab.sh: %s compiles no kernel/accel/%s: build it from this source tree" % (db, name))
args, out = [], []
words = iter(shlex.split(e["command"]))
for w in words:
    if w in ("-MD", "-MMD"):
        continue
    if w in ("-MQ", "-MF", "-o"):
        next(words)
    elif w == "-c":
        next(words)
    else:
        args.append(w)
cmd = args[:1] + ["-I" + accel] + args[1:] + extra + ["-c", source, "-o", obj]
sys.exit(subprocess.run(cmd, cwd=e["directory"]).returncode)
PY
}

kernel_cc "$out/variant/variant.c" bvh_wide_trace.c "$out/variant.o" ${AB_CFLAGS:-}
# The half VARIANT.c is not: the kernel's build or traversal.
if nm "$out/variant.o" | grep -q ' T rtk_wide_build$'; then
    kernel_cc "$src/kernel/accel/bvh_wide_trace.c" bvh_wide_trace.c "$out/other.o"
else
    kernel_cc "$src/kernel/accel/bvh_wide_build.c" bvh_wide_build.c "$out/other.o"
fi
renames=()
for sym in $(nm "$out/variant.o" "$out/other.o" | awk '$2 ~ /^[TDBR]$/ && $3 ~ /^rtk_/ {print $3}' | sort -u); do
    renames+=(--redefine-sym "$sym=B_${sym#rtk_}")
done
objcopy "${renames[@]}" "$out/variant.o" "$out/variant_b.o"
objcopy "${renames[@]}" "$out/other.o" "$out/other_b.o"
ab_compile "$src/tools/ab-trace/ab.c"
ab_link "$out/variant_b.o" "$out/other_b.o"
RTK_PLUGIN_PATH=$build/plugins/accelerators ${AB_WRAP:-} "$out/ab" "$2" "$3" "${4:-sah}" "${5:-400}"

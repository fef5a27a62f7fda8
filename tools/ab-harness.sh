# Sourced by tools/ab-trace/ab.sh and tools/ab-build/ab.sh after their
# usage check, with BUILD_DIR as $1. Sets src (the source tree), build,
# out (a temporary directory, removed on exit) and inc (the kernel's
# include flags); ab_compile FILE.c compiles a harness into $out/ab.o,
# ab_link [OBJECT...] links it (and the objects) into $out/ab with
# build's static kernel, exported: plugins loaded at run time then call
# the kernel copy the harness reads (errors, thread pool).
src=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=$(cd "$1" && pwd)
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
inc=(-I"$build/kernel" -I"$src/kernel" -I"$src/tools" -I"$build/include" -I"$src/include")

ab_compile() {
    cc "${inc[@]}" -std=c11 -O2 -g -D_GNU_SOURCE -pthread -c "$1" -o "$out/ab.o"
}

ab_link() {
    c++ -o "$out/ab" "$out/ab.o" "$@" -Wl,--whole-archive "$build/kernel/librtk_static.a" \
        -Wl,--no-whole-archive "$build/tools/librtk_tools.a" -Wl,--export-dynamic -lm -pthread -ldl \
        $(pkg-config --libs tinygltf tinyobjloader libconfig 2>/dev/null || echo -ltinygltf -ltinyobjloader -lconfig) \
        $(pkg-config --libs OpenEXR libpng) \
        $(grep -q RTK_HAVE_DRACO "$build/build.ninja" && pkg-config --libs draco) \
        $(grep -q RTK_HAVE_MESHOPT "$build/build.ninja" && echo -lmeshoptimizer)
}

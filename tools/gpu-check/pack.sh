#!/usr/bin/env bash
# Packs what run.sh needs on a lent GPU machine, where no Debian package
# is installed, into .gpu/bundle.tar.xz: rtk installed from BUILD_DIR
# (meson install into a staging folder), every shared library its programs,
# plugins and the tests/cuda programs load, with the loader itself (run.sh
# starts each program as `ld-linux-x86-64.so.2 --library-path ...`), the
# Cornell box, the four meshes and the showroom from ../shared/data. About
# 28 MB.
#
#   tools/gpu-check/pack.sh [BUILD_DIR]      (from the checkout's root; default build)
#
# Then, through the device tool: command `bash tools/gpu-check/run.sh`,
# carry [".gpu"] (docs/testing.md, "The GPU check").
set -euo pipefail
build=${1:-build}
root=$(pwd)
data=$root/../shared/data
[ -f "$root/meson.build" ] && [ -d "$build" ] || { echo "pack.sh: run from the checkout's root, with $build built" >&2; exit 2; }
[ -f "$build/plugins/accelerators/cuda.so" ] || { echo "pack.sh: $build has no cuda plugin (nvcc not found when it was set up)" >&2; exit 2; }
[ -d "$data/meshes" ] || { echo "pack.sh: $data/meshes is not there" >&2; exit 2; }
exclude=$(git rev-parse --git-path info/exclude) # a worktree's .git is a file
grep -qx '/.gpu/' "$exclude" 2>/dev/null || { mkdir -p "$(dirname "$exclude")"; echo '/.gpu/' >>"$exclude"; }
ninja -C "$build" >/dev/null
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
b=$stage/rtk
meson install -C "$build" --destdir "$stage/dest" >/dev/null
mkdir -p "$b/bin" "$b/lib" "$b/sys" "$b/tests" "$b/src" "$b/shared/data/meshes" "$b/shared/data/showroom"
prefix=$(find "$stage/dest" -type f -name 'librtk.so.*' | head -1)
libdir=$(dirname "$prefix")
cp -a "$libdir"/librtk.so* "$b/lib/"
cp -a "$libdir/rtk" "$b/lib/"
rm -f "$b/lib/rtk/rtk_image.so" # OpenImageIO's 250 libraries stay behind: nothing here writes an image
cp "$(find "$stage/dest" -type f -path '*/bin/rtk')" "$b/bin/"
for t in isect traverse sampler bsdf material texture lights program path_program textured_program; do
    cp "$build/tests/cuda/test_${t}_cuda" "$b/tests/"
done
mkdir -p "$b/src/scenes"
cp -r "$root/scenes/cornell" "$b/src/scenes/"
mkdir -p "$b/src/tests/scenes"
cp -r "$root/tests/scenes/textured" "$b/src/tests/scenes/"
cp "$data"/meshes/{bunny,armadillo,elephant,dragon}.obj "$b/shared/data/meshes/"
[ -f "$data/showroom/showroom.obj" ] && cp "$data/showroom/showroom.obj" "$b/shared/data/showroom/"
# The closure of shared libraries, glibc and the loader included; librtk is ours.
elves=("$b/bin/rtk" "$b"/lib/librtk.so.* "$b"/lib/rtk/plugins/*.so "$b"/tests/*)
ldd "${elves[@]}" 2>/dev/null | awk '$2 == "=>" && $3 ~ /^\// { print $3 } $1 ~ /^\/.*ld-linux/ { print $1 }' |
    sort -u | grep -v '/librtk\.so' | while read -r lib; do cp -L "$lib" "$b/sys/"; done
cp -L /lib64/ld-linux-x86-64.so.2 "$b/sys/"
git -C "$root" rev-parse --short HEAD >"$b/commit"
mkdir -p .gpu
XZ_OPT=-T0 tar cJf .gpu/bundle.tar.xz -C "$stage" rtk
echo "pack.sh: .gpu/bundle.tar.xz $(du -h .gpu/bundle.tar.xz | cut -f1) ($(ls "$b/sys" | wc -l) libraries, commit $(cat "$b/commit"))"

#!/usr/bin/env bash
# rtk as a user installs and uses it (README "Install and use as a library"):
# `meson install` of this build into a temporary DESTDIR, the prefix then
# moved elsewhere; an out-of-tree filter and an embedding program built
# with cc and pkg-config alone; the installed rtk's plugins, conform and
# render with the plugin found through RTK_PLUGIN_PATH, --plugin-path and
# the installed plugin directory; README's embedding example as printed
# there; and one BVH cache shared by the installed rtk and the build
# tree's, alternating without rebuilds.
# Skips (77) only without a C compiler or pkg-config.
# usage: test_install.sh BUILD_ROOT TEST_SOURCE_DIR BUILD_TREE_RTK MESON...
set -u
build=$1
here=$2
build_rtk=$3
shift 3
meson=("$@")
cc=${CC:-cc}
for tool in "$cc" pkg-config; do
    if ! command -v "$tool" >/dev/null; then
        echo "SKIP  no '$tool' on PATH: cannot build a plugin the way a user does (apt-get install gcc pkg-config)"
        exit 77
    fi
done
# Outside the build tree: an install inside it would count as the build tree.
tmp=$(mktemp -d /tmp/rtk-install-test-XXXXXX)
trap 'rm -rf "$tmp"' EXIT
unset LD_LIBRARY_PATH RTK_PLUGIN_PATH
export XDG_CACHE_HOME=$tmp/xdg
passed=0
failed=0

ok() { passed=$((passed + 1)); echo "ok    $1"; }
bad() { failed=$((failed + 1)); echo "FAIL  $1"; [ -n "${2:-}" ] && echo "$2" | sed 's/^/    /'; }
# check NAME CONDITION-COMMAND...
check() { local name=$1; shift; if "$@"; then ok "$name"; else bad "$name" "$out"; fi; }
has() { grep -qF -- "$1" <<<"$out"; }
lacks() { ! grep -qF -- "$1" <<<"$out"; }
matches() { grep -qE -- "$1" <<<"$out"; }
lacks_match() { ! grep -qE -- "$1" <<<"$out"; }
run() { out=$("$@" 2>&1); status=$?; }
succeeded() { [ "$status" -eq 0 ]; }
nonempty() { [ -s "$1" ]; }

run "${meson[@]}" install -C "$build" --no-rebuild --destdir "$tmp/stage" --quiet
check "meson install --destdir" succeeded
installed_rtk=$(find "$tmp/stage" -path '*/bin/rtk' -type f)
if [ -z "$installed_rtk" ]; then
    bad "the install holds bin/rtk" "$(cd "$tmp/stage" && find . | head -n 40)"
    echo "$passed passed, $failed failed"
    exit 1
fi
# The prefix moved away from where it was installed: nothing may depend
# on the configured prefix or the DESTDIR.
mv "$(dirname "$(dirname "$installed_rtk")")" "$tmp/prefix"
rm -rf "$tmp/stage"
p=$tmp/prefix
rtk=$p/bin/rtk

pc=$(find "$p" -name rtk.pc)
check "rtk.pc installed under libdir/pkgconfig" [ -n "$pc" -a "$(basename "$(dirname "$pc")")" = pkgconfig ]
export PKG_CONFIG_PATH
PKG_CONFIG_PATH=$(dirname "$pc")
run pkg-config --cflags rtk
check "pkg-config --cflags: the moved prefix's include directory" [ $status -eq 0 -a -f "$(sed -n 's/^-I\([^ ]*\).*/\1/p' <<<"$out")/rtk/rtk.h" ]
plugindir=$(realpath -m "$(pkg-config --variable=plugindir rtk)")
check "pkg-config plugindir: the shipped plugins are there" [ -f "$plugindir/box.so" ]
run ldd "$plugindir/box.so"
check "an installed plugin's RPATH finds the installed librtk" has "$p/"
check "an installed plugin needs nothing ldd cannot find" lacks "not found"

run "$rtk" plugins
check "installed rtk plugins: runs (RPATH finds librtk)" succeeded
for name in headlight ao arealight whitted path heatmap sah lbvh median box gaussian; do
    check "installed rtk plugins: lists $name" matches "^[a-z]+ +$name "
done
check "installed rtk plugins: nothing refused" lacks "refused"
run "$rtk" plugins box
check "installed rtk plugins box: loaded from the install" has "file: $plugindir/box.so"
check "installed rtk plugins box: not from the build tree" lacks "$build"

# The plugin and the program are built exactly as README shows.
mkdir -p "$tmp/plug"
run "$cc" -shared -fPIC -Wall -Wextra -Werror $(pkg-config --cflags rtk) "$here/oot_tent.c" -o "$tmp/plug/oot_tent.so"
check "out-of-tree plugin: cc \$(pkg-config --cflags rtk)" succeeded
run "$rtk" conform "$tmp/plug/oot_tent.so"
check "installed rtk conform on it: passes" succeeded
check "installed rtk conform on it: counts its checks" matches '^[1-9][0-9]* passed, 0 failed'

cat >"$tmp/quad.obj" <<'OBJ'
v -1 -1 0
v 1 -1 0
v 1 1 0
v -1 1 0
v -3 -3 -1
v 3 -3 -1
v 0 3 -1
f 1 2 3 4
f 5 6 7
OBJ
cat >"$tmp/quad.cfg" <<'CFG'
scene = "quad.obj";
camera = { position = [0.3, 0.2, 4.0]; look_at = [0.0, 0.0, 0.0]; };
film = { width = 24; height = 16; spp = 2; output = "quad.png"; };
CFG
render_with() { run env "$@" render "$tmp/quad.cfg" --set filter.plugin=oot_tent --no-cache; }
render_with RTK_PLUGIN_PATH="$tmp/plug" "$rtk" -o "$tmp/env.png"
check "render with the plugin through RTK_PLUGIN_PATH" [ $status -eq 0 ]
check "RTK_PLUGIN_PATH render: image written" nonempty "$tmp/env.png"
render_with "$rtk" --plugin-path "$tmp/plug" -o "$tmp/flag.png"
check "render with the plugin through --plugin-path: image written" [ $status -eq 0 -a -s "$tmp/flag.png" ]
render_with "$rtk" -o "$tmp/none.png"
check "without a path the plugin is not found" [ $status -ne 0 -a ! -e "$tmp/none.png" ]
check "without a path: the error names the plugin" has "oot_tent"
cp "$tmp/plug/oot_tent.so" "$plugindir/"
run "$rtk" plugins oot_tent
check "installed into plugindir: rtk plugins finds it there" has "file: $plugindir/oot_tent.so"
render_with "$rtk" -o "$tmp/installed.png"
check "installed into plugindir: renders with it" [ $status -eq 0 -a -s "$tmp/installed.png" ]
identical() { cmp -s "$1" "$2" && cmp -s "$1" "$3"; }
check "the same image however the plugin was found" identical "$tmp/env.png" "$tmp/flag.png" "$tmp/installed.png"
# The image module comes from the install too (the dynamic loader says
# which file it opened).
run env LD_DEBUG=files "$rtk" diff "$tmp/env.png" "$tmp/flag.png"
check "installed rtk diff reads the images" succeeded
check "the image module is the installed one" matches "file=$p/.*/rtk_image.so"
check "no image module from the build tree" lacks_match "file=$build/.*/rtk_image.so"

run "$cc" -Wall -Wextra -Werror "$here/embed.c" -o "$tmp/embed" $(pkg-config --cflags --libs rtk) \
    -Wl,-rpath,"$(pkg-config --variable=libdir rtk)"
check "embedding program: cc \$(pkg-config --cflags --libs rtk)" succeeded
run "$tmp/embed" "$tmp/quad.cfg" "$tmp/embedded.png"
check "embedding program: runs against the installed librtk" succeeded
check "embedding program: its registry is the install's" has "box: $plugindir/box.so"
check "embedding program: image written" nonempty "$tmp/embedded.png"

# README's example program, as README prints it, built by README's command.
awk '/^    \/\* render\.c: /{on = 1} on && !/^(    |$)/{exit} on' "$here/../../README.md" | sed 's/^    //' >"$tmp/render.c"
out=$(head -n 3 "$tmp/render.c")
check "README's embedding example found" grep -q "int main" "$tmp/render.c"
run "$cc" "$tmp/render.c" $(pkg-config --cflags --libs rtk) -Wl,-rpath,$(pkg-config --variable=libdir rtk) -o "$tmp/render"
check "README's example: builds as README shows" succeeded
rm -f "$tmp/quad.png"
run "$tmp/render" "$tmp/quad.cfg"
check "README's example: renders and reports" [ $status -eq 0 -a -s "$tmp/quad.png" ]
check "README's example: prints the report" has "Mrays/s"

# One cache for two builds: the install and the build tree alternate, each
# loading its own tree after its first render.
cached() { run env "$1" render "$tmp/quad.cfg" --set cache="$tmp/cache" -o "$tmp/cached.png"; }
cached "$rtk"
check "cache, installed rtk, first: saved" has "saved to cache"
cached "$build_rtk"
check "cache, build tree's rtk, first: saved beside it" has "saved to cache"
check "cache, build tree's rtk, first: the installed rtk's tree is not stale to it" lacks "stale"
for round in 2 3; do
    cached "$rtk"
    check "cache, installed rtk, round $round: from cache" has "(from cache"
    check "cache, installed rtk, round $round: no warning" lacks "warning"
    cached "$build_rtk"
    check "cache, build tree's rtk, round $round: from cache" has "(from cache"
    check "cache, build tree's rtk, round $round: no warning" lacks "warning"
done
check "cache: one tree per build" [ "$(find "$tmp/cache" -name '*.bvh' | wc -l)" -eq 2 ]

echo "$passed passed, $failed failed"
[ $failed -eq 0 ]

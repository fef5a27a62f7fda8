#!/usr/bin/env bash
# The BVH cache through the rtk command: a second render loads what the
# first saved and makes the same image; a damaged cache is one warning and
# a rebuild; cache_limit removes old trees; --no-cache and cache = "off"
# leave no file; the default directory follows XDG_CACHE_HOME and HOME; a
# cache directory that cannot be created never fails a render.
# usage: test_cache_cli.sh RTK
set -u
rtk=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
passed=0
failed=0

ok() { passed=$((passed + 1)); echo "ok    $1"; }
bad() { failed=$((failed + 1)); echo "FAIL  $1"; [ -n "${2:-}" ] && echo "$2" | sed 's/^/    /'; }
# check NAME CONDITION-COMMAND...
check() { local name=$1; shift; if "$@"; then ok "$name"; else bad "$name" "$out"; fi; }
has() { grep -qF -- "$1" <<<"$out"; }
lacks() { ! grep -qF -- "$1" <<<"$out"; }
count() { find "$1" -name '*.bvh' 2>/dev/null | wc -l; }
render() { out=$(env "$@" 2>&1); status=$?; }

# A ring of quads: a few hundred triangles.
{
    for i in $(seq 0 99); do
        a=$(awk -v i="$i" 'BEGIN { printf "%.6f %.6f", cos(i * 0.0628318), sin(i * 0.0628318) }')
        set -- $a
        echo "v $1 $2 -0.2"
        echo "v $1 $2 0.2"
    done
    for i in $(seq 0 99); do
        j=$(((i + 1) % 100))
        echo "f $((2 * i + 1)) $((2 * j + 1)) $((2 * j + 2)) $((2 * i + 2))"
    done
} >"$tmp/ring.obj"
cat >"$tmp/ring.cfg" <<'CFG'
scene = "ring.obj";
camera = { position = [0.0, 0.5, 3.0]; look_at = [0.0, 0.0, 0.0]; };
film = { width = 24; height = 16; spp = 1; output = "ring.png"; };
CFG
base=(XDG_CACHE_HOME="$tmp/xdg" HOME="$tmp/home" "$rtk" render "$tmp/ring.cfg")

render "${base[@]}" --set cache="$tmp/c" -o "$tmp/first.png"
check "first render saves the BVH" [ $status -eq 0 ]
check "report says where it was saved" has "saved to cache $tmp/c/"
check "one cache file written" [ "$(count "$tmp/c")" -eq 1 ]
render "${base[@]}" --set cache="$tmp/c" -o "$tmp/second.png"
check "second render loads it" has "(from cache $tmp/c/"
check "second render warns about nothing" lacks "warning"
check "same image either way" cmp -s "$tmp/first.png" "$tmp/second.png"

file=$(find "$tmp/c" -name '*.bvh' | head -n 1)
head -c 50 "$file" >"$tmp/cut" && cat "$tmp/cut" >"$file"
render "${base[@]}" --set cache="$tmp/c" -o "$tmp/third.png"
check "truncated cache: render succeeds" [ $status -eq 0 ]
check "truncated cache: one warning naming the file" [ "$(grep -c warning <<<"$out")" -eq 1 ]
check "truncated cache: the warning says why" has "$file: truncated"
check "truncated cache: rebuilt and saved again" has "saved to cache $file"
check "truncated cache: same image" cmp -s "$tmp/first.png" "$tmp/third.png"
render "${base[@]}" --set cache="$tmp/c" -o "$tmp/fourth.png"
check "after the rebuild the cache loads" has "(from cache $file)"

printf 'garbage' >"$file"
render "${base[@]}" --set cache="$tmp/c" --set accelerator.max_leaf=2
check "other parameters: a file of its own, the damaged one untouched" \
    [ "$(count "$tmp/c")" -eq 2 -a "$(cat "$file")" = garbage ]

# cache_limit (MB): an old tree past the limit goes, the render's own stay.
head -c 2097152 /dev/zero >"$tmp/c/0000000000000001-0000000000000002.bvh"
touch -d '1 hour ago' "$tmp/c/0000000000000001-0000000000000002.bvh"
kept=$(count "$tmp/c")
render "${base[@]}" --set cache="$tmp/c" --set cache_limit=1
check "cache_limit: the old 2 MB tree is removed" [ $status -eq 0 -a ! -e "$tmp/c/0000000000000001-0000000000000002.bvh" ]
check "cache_limit: the render says so" has "removed 1 old file (2.0 MB) to stay within cache_limit = 1 MB"
check "cache_limit: the other trees stay" [ "$(count "$tmp/c")" -eq $((kept - 1)) ]
render "${base[@]}" --set cache="$tmp/c" --set cache_limit=-1
refused_naming() { [ $status -ne 0 ] && has "$1"; }
check "cache_limit below 0: an error naming the setting" refused_naming "cache_limit"

render "${base[@]}" --no-cache -o "$tmp/plain.png"
check "--no-cache renders" [ $status -eq 0 ]
check "--no-cache: nothing about a cache in the report" lacks "cache"
check "--no-cache: the default directory is not created" [ ! -e "$tmp/xdg/rtk" ]
render "${base[@]}" --set cache=off
check "cache = off: no cache either" [ $status -eq 0 -a ! -e "$tmp/xdg/rtk" ]

render "${base[@]}"
check "default directory: \$XDG_CACHE_HOME/rtk" [ "$(count "$tmp/xdg/rtk")" -eq 1 ]
render env -u XDG_CACHE_HOME HOME="$tmp/home" "$rtk" render "$tmp/ring.cfg"
check "default directory without XDG_CACHE_HOME: \$HOME/.cache/rtk" [ "$(count "$tmp/home/.cache/rtk")" -eq 1 ]

printf 'scene = "ring.obj";\ncache = "bvh-cache";\nfilm = { width = 8; height = 8; spp = 1; };\n' >"$tmp/rel.cfg"
render HOME="$tmp/home" "$rtk" render "$tmp/rel.cfg"
check "relative cache directory: next to the config" [ "$(count "$tmp/bvh-cache")" -eq 1 ]
printf 'scene = "ring.obj";\ncache = "";\n' >"$tmp/empty.cfg"
render HOME="$tmp/home" "$rtk" render "$tmp/empty.cfg"
check "empty cache setting: an error" [ $status -ne 0 ]
check "empty cache setting: the error names file and line" has "empty.cfg:2"

echo x >"$tmp/blocker"
render "${base[@]}" --set cache="$tmp/blocker/sub"
check "uncreatable cache directory: the render still succeeds" [ $status -eq 0 ]
check "uncreatable cache directory: one warning" [ "$(grep -c warning <<<"$out")" -eq 1 ]
check "uncreatable cache directory: the warning names it" has "$tmp/blocker/sub"

check "no temporary files left in a cache" [ "$(find "$tmp" -name '*.tmp*' | wc -l)" -eq 0 ]

echo "$passed passed, $failed failed"
[ $failed -eq 0 ]

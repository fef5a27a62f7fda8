#!/usr/bin/env bash
# The rtk command on hostile scenes: files outside the scene's folders
# (refused, naming --allow-outside-files, which lets them be read), a FIFO
# as the scene (refused at once, not a hang), the texture budget
# (textures.memory) and a scene that names devices.
# usage: test_cli.sh RTK
set -u
rtk=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
export XDG_CACHE_HOME="$tmp/cache"
passed=0
failed=0
ok() { passed=$((passed + 1)); echo "ok    $1"; }
bad() { failed=$((failed + 1)); echo "FAIL  $1"; }
# expect NAME STATUS(0|fail) PATTERN... [! ABSENT] -- CMD...: exit status, patterns present (after !, absent)
expect() {
    local name=$1 want=$2
    shift 2
    local present=() absent=() into=present
    while [ "$1" != "--" ]; do
        if [ "$1" = "!" ]; then into=absent; else eval "$into+=(\"\$1\")"; fi
        shift
    done
    shift
    local out status
    out=$(timeout 60 "$@" 2>&1)
    status=$?
    if [ $status -eq 124 ]; then bad "$name (hung: killed after 60 s)"; return; fi
    if [ "$want" = 0 ] && [ $status -ne 0 ]; then bad "$name (exit $status)"; echo "$out" | sed 's/^/    /'; return; fi
    if [ "$want" = fail ] && [ $status -eq 0 ]; then bad "$name (succeeded)"; echo "$out" | sed 's/^/    /'; return; fi
    for p in "${present[@]}"; do
        grep -qF -- "$p" <<<"$out" || { bad "$name (no '$p' in output)"; echo "$out" | sed 's/^/    /'; return; }
    done
    for p in "${absent[@]+"${absent[@]}"}"; do
        ! grep -qF -- "$p" <<<"$out" || { bad "$name ('$p' in output)"; echo "$out" | sed 's/^/    /'; return; }
    done
    ok "$name"
}

# A triangle whose buffer lies two folders up, outside scene/a/b's reach.
mkdir -p "$tmp/scene/a/b" "$tmp/outside"
printf '\0\0\0\0\0\0\0\0\0\0\0\0\0\0\x80\x3f\0\0\0\0\0\0\0\0\0\0\0\0\0\0\x80\x3f\0\0\0\0' >"$tmp/outside/tri.bin"
cat >"$tmp/scene/a/b/tri.gltf" <<'JSON'
{"asset":{"version":"2.0"},"buffers":[{"uri":"../../../outside/tri.bin","byteLength":36}],
 "bufferViews":[{"buffer":0,"byteLength":36}],
 "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],
 "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}],"scene":0}
JSON
cat >"$tmp/scene/a/b/tri.cfg" <<'CFG'
scene = "tri.gltf";
film = { width = 8; height = 8; spp = 1; };
CFG
expect "a buffer outside the scene's folders is refused, naming the flag" fail \
    "lies outside the folders" "--allow-outside-files" ! "requestedBytes" -- \
    "$rtk" render "$tmp/scene/a/b/tri.cfg" -o "$tmp/out.png" -q
expect "--allow-outside-files lets it be read" 0 -- \
    "$rtk" render "$tmp/scene/a/b/tri.cfg" -o "$tmp/out.png" -q --allow-outside-files

expect "rtk bench keeps the boundary" fail "lies outside the folders" "--allow-outside-files" -- \
    "$rtk" bench "$tmp/scene/a/b/tri.cfg" --accel median --threads 1 --runs 1 --width 8 --height 8
expect "rtk bench --allow-outside-files lets it be read" 0 "median" -- \
    "$rtk" bench "$tmp/scene/a/b/tri.cfg" --accel median --threads 1 --runs 1 --width 8 --height 8 \
    --allow-outside-files

# The config's folder is readable: the same buffer with the config beside it.
cat >"$tmp/outside/tri.cfg" <<CFG
scene = "../scene/a/b/tri.gltf";
film = { width = 8; height = 8; spp = 1; };
CFG
expect "files under the config's folder are readable" 0 -- \
    "$rtk" render "$tmp/outside/tri.cfg" -o "$tmp/out.png" -q

# A FIFO as the scene, with nothing writing to it: an error at once.
mkfifo "$tmp/scene/pipe.obj"
printf 'scene = "pipe.obj";\n' >"$tmp/scene/pipe.cfg"
expect "a FIFO as the scene is refused without blocking" fail "FIFO" "regular files" -- \
    "$rtk" render "$tmp/scene/pipe.cfg" -o "$tmp/out.png" -q

# A texture budget of 1 MB: a 512x512 texture (4 MiB as float RGBA) is not decoded.
printf 'P5\n512 512\n255\n' >"$tmp/scene/big.pgm"
head -c $((512 * 512)) /dev/zero >>"$tmp/scene/big.pgm"
printf 'newmtl m\nmap_Kd big.pgm\n' >"$tmp/scene/quad.mtl"
printf 'mtllib quad.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nusemtl m\nf 1/1 2/1 3/1\n' >"$tmp/scene/quad.obj"
cat >"$tmp/scene/quad.cfg" <<'CFG'
scene = "quad.obj";
film = { width = 8; height = 8; spp = 1; };
textures = { memory = 1; };
CFG
expect "a texture over textures.memory is named with its size" 0 "big.pgm" "512x512" "4.0 MiB" "textures.memory" -- \
    "$rtk" render "$tmp/scene/quad.cfg" -o "$tmp/out.png"
expect "textures.memory = 0 is out of range" fail "memory" -- \
    "$rtk" render "$tmp/scene/quad.cfg" -o "$tmp/out.png" -q --set textures.memory=0

# map_Kd naming a device: refused by the boundary, and by the file check when it is lifted.
printf 'newmtl m\nmap_Kd /dev/zero\n' >"$tmp/scene/quad.mtl"
expect "map_Kd /dev/zero is outside" 0 "lies outside" -- \
    "$rtk" render "$tmp/scene/quad.cfg" -o "$tmp/out.png"
expect "map_Kd /dev/zero with --allow-outside-files is a device" 0 "a device" -- \
    "$rtk" render "$tmp/scene/quad.cfg" -o "$tmp/out.png" --allow-outside-files

echo "$passed passed, $failed failed"
[ $failed -eq 0 ]

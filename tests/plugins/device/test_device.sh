#!/usr/bin/env bash
# The kernel's device accelerators end to end, with testdevice (a device
# that is the CPU): images through it equal the builder's bit for bit (ao,
# headlight and path, which trace in batches; an instanced scene; the
# device programs of ao, headlight and path, AOVs included, over normals,
# materials, vertex colours, instances, every kind of light and textures,
# and where they do not run), the
# report's device line, the BVH cache, `rtk bench`'s device table and
# counts, and every refusal with its message (a wrong builder at its
# config line, a device that cannot start or take the tree).
# usage: test_device.sh RTK SOURCE_ROOT TESTDEVICE_DIR
set -u
rtk=$1
src=$2
export RTK_PLUGIN_PATH=$3
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
export XDG_CACHE_HOME="$tmp/cache"
passed=0
failed=0
ok() { passed=$((passed + 1)); echo "ok    $1"; }
bad() { failed=$((failed + 1)); echo "FAIL  $1"; }
cornell=$src/scenes/cornell
small=(--set film.width=96 --set film.height=96 --set film.spp=4)

# Renders cfg with sah and with testdevice (builder sah); the pixels must
# be equal (rtk diff: overall RMSE exactly 0) and the device must have
# traced rays.
same_image() {
    local name=$1 cfg=$2
    shift 2
    if ! "$rtk" render "$cfg" "${small[@]}" "$@" --set accelerator.plugin=sah \
         --set film.output="$tmp/$name-sah.exr" >"$tmp/$name-sah.log" 2>&1; then
        bad "$name: render with sah"; sed 's/^/    /' "$tmp/$name-sah.log"; return
    fi
    if ! "$rtk" render "$cfg" "${small[@]}" "$@" --set accelerator.plugin=testdevice \
         --set film.output="$tmp/$name-dev.exr" >"$tmp/$name-dev.log" 2>&1; then
        bad "$name: render with testdevice"; sed 's/^/    /' "$tmp/$name-dev.log"; return
    fi
    local rmse rays
    rmse=$("$rtk" diff "$tmp/$name-dev.exr" "$tmp/$name-sah.exr" 2>&1 | awk '$1 == "rmse" { print $NF }')
    rays=$(sed -n 's/^device .*; \([0-9]*\) rays in \([0-9]*\) batches.*/\1/p' "$tmp/$name-dev.log")
    if [ "$rmse" = 0 ] && [ -n "$rays" ] && [ "$rays" -gt 0 ]; then
        ok "$name: testdevice's image equals sah's (RMSE $rmse); the device traced $rays rays"
    else
        bad "$name: RMSE '$rmse' (want 0), device rays '$rays' (want > 0)"
        sed 's/^/    /' "$tmp/$name-dev.log"
    fi
}
same_image ao "$cornell/cornell-ao.cfg"
same_image headlight "$cornell/cornell-headlight.cfg"
same_image path "$cornell/cornell.cfg" --set integrator.max_depth=4
# Two levels: the box's own triangles and two more boxes placed beside it, one turned and mirrored.
printf 'scene = "%s/cornell.obj";\ninstances = ( { file = "%s/cornell.obj"; translate = [0.3, 0.1, 0.4]; scale = [0.3, 0.3, 0.3]; },\n  { file = "%s/cornell.obj"; translate = [0.35, 0.0, 0.2]; rotate = [0.0, 1.0, 0.0, 30.0]; scale = [-0.25, 0.25, 0.25]; } );\ncamera = { position = [0.278, 0.273, -0.8]; look_at = [0.278, 0.273, 0.0]; fov = 39.3076; };\nintegrator = { plugin = "ao"; rays = 8; distance = 0.3; };\n' \
    "$cornell" "$cornell" "$cornell" >"$tmp/instanced.cfg"
same_image instanced "$tmp/instanced.cfg"

# Device programs (ABI 3.6): ao shades whole samples on the device. Its
# images, AOVs included, equal li's bit for bit: the EXR files are equal.
device_args=() # set for the testdevice render alone
program_image() {
    local name=$1 cfg=$2
    shift 2
    local dev=("$rtk" render "$cfg" "${small[@]}" "$@" --set 'film.aovs=["albedo","normal","depth"]')
    if ! "${dev[@]}" --set accelerator.plugin=sah --set film.output="$tmp/$name-sah.exr" >"$tmp/$name-sah.log" 2>&1 ||
       ! "${dev[@]}" --set accelerator.plugin=testdevice "${device_args[@]}" --set film.output="$tmp/$name-dev.exr" \
         >"$tmp/$name-dev.log" 2>&1; then
        bad "$name: a render failed"; sed 's/^/    /' "$tmp/$name-sah.log" "$tmp/$name-dev.log"; return
    fi
    local samples rays_sah rays_dev
    samples=$(sed -n 's/^device .*; \([0-9]*\) samples shaded by the integrator.s device program.*/\1/p' "$tmp/$name-dev.log")
    rays_sah=$(awk '$1 == "rays" { print $2 }' "$tmp/$name-sah.log")
    rays_dev=$(awk '$1 == "rays" { print $2 }' "$tmp/$name-dev.log")
    if cmp -s "$tmp/$name-dev.exr" "$tmp/$name-sah.exr" && [ -n "$samples" ] && [ "$samples" -gt 0 ] &&
       [ "$rays_sah" = "$rays_dev" ]; then
        ok "$name: the device program's image and AOVs equal li's; $samples samples, $rays_dev rays as on the CPU"
    else
        bad "$name: files differ, or no samples shaded ('$samples'), or rays $rays_dev != $rays_sah"
        sed 's/^/    /' "$tmp/$name-dev.log"
    fi
}
# A smooth sphere (corner normals, so shading and geometric normals part)
# on a floor.
awk 'BEGIN {
    pi = 3.14159265358979; nu = 24; nv = 12
    for (j = 0; j <= nv; j++) for (i = 0; i < nu; i++) {
        t = pi * j / nv; p = 2 * pi * i / nu
        x = sin(t) * cos(p); y = cos(t); z = sin(t) * sin(p)
        printf "v %.6f %.6f %.6f\nvn %.6f %.6f %.6f\n", 0.3 * x, 0.3 * y + 0.3, 0.3 * z, x, y, z
    }
    for (j = 0; j < nv; j++) for (i = 0; i < nu; i++) {
        a = j * nu + i + 1; b = j * nu + (i + 1) % nu + 1; c = a + nu; d = b + nu
        printf "f %d//%d %d//%d %d//%d\nf %d//%d %d//%d %d//%d\n", a, a, c, c, b, b, b, b, c, c, d, d
    }
    n = (nv + 1) * nu
    printf "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nvn 0 1 0\n"
    printf "f %d//%d %d//%d %d//%d\nf %d//%d %d//%d %d//%d\n", n+1, n+1, n+3, n+1, n+2, n+1, n+1, n+1, n+4, n+1, n+3, n+1
}' >"$tmp/sphere.obj"
printf 'scene = "%s/sphere.obj";\ncamera = { position = [0.0, 0.9, -1.4]; look_at = [0.0, 0.25, 0.0]; fov = 45.0; };\nintegrator = { plugin = "ao"; rays = 6; distance = 0.5; };\n' \
    "$tmp" >"$tmp/sphere.cfg"
program_image "program, independent" "$tmp/sphere.cfg"
program_image "program, stratified" "$tmp/sphere.cfg" --set sampler.type=\"stratified\" --set film.spp=6
program_image "program, sobol, importance" "$tmp/sphere.cfg" --set sampler.type=\"sobol\" \
    --set film.reconstruction=\"importance\" --set filter.plugin=\"mitchell\"
program_image "program, cornell, any distance" "$cornell/cornell-ao.cfg" --set integrator.distance=inf
program_image "program, ao albedo over materials" "$cornell/cornell-ao.cfg" --set integrator.albedo=true
program_image "program, headlight over materials" "$cornell/cornell-headlight.cfg" --set integrator.ambient=0.1
# Vertex colours (glTF COLOR_0) times the material's colour: a quad coloured per corner.
# (written by python3; skipped, saying so, where there is none)
if command -v python3 >/dev/null; then
    python3 - "$tmp/colours.gltf" <<'PY'
import base64, json, struct, sys
pos = [-1, 0, -1, 1, 0, -1, 1, 0, 1, -1, 0, 1]
col = [1, 0, 0, 1, 0, 1, 0, 1, 0, 0, 1, 1, 1, 1, 1, 1]
idx = [0, 2, 1, 0, 3, 2]
data = struct.pack('<12f', *pos) + struct.pack('<16f', *col) + struct.pack('<6H', *idx)
view = lambda off, n: {"buffer": 0, "byteOffset": off, "byteLength": n}
doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
       "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "COLOR_0": 1}, "indices": 2, "material": 0}]}],
       "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.6, 0.3, 1.0]}, "doubleSided": True}],
       "buffers": [{"byteLength": len(data),
                    "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
       "bufferViews": [view(0, 48), view(48, 64), view(112, 12)],
       "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                      "min": [-1, 0, -1], "max": [1, 0, 1]},
                     {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC4"},
                     {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}]}
open(sys.argv[1], "w").write(json.dumps(doc))
PY
    printf 'scene = "%s/colours.gltf";\ncamera = { position = [0.0, 2.0, -2.0]; look_at = [0.0, 0.0, 0.0]; fov = 60.0; };\nintegrator = { plugin = "headlight"; };\n' \
        "$tmp" >"$tmp/colours.cfg"
    program_image "program, headlight over vertex colours" "$tmp/colours.cfg"
else
    echo "skip  program, headlight over vertex colours: no python3 to write its glTF"
fi
# path's program (ABI 3.7): the box's emitter, then every other kind of
# light (point, spot, directional, a constant environment), an
# environment map over glossy, rough and smooth BSDFs, clamping and
# roulette from the first bounce.
program_image "program, path in the box" "$cornell/cornell.cfg" --set integrator.max_depth=6
printf 'scene = "%s/cornell.obj";\ncamera = { position = [0.278, 0.273, -0.8]; look_at = [0.278, 0.273, 0.0]; fov = 39.3076; };\nintegrator = { plugin = "path"; };\nlights = ( { type = "point"; position = [0.28, 0.45, 0.28]; intensity = [0.2, 0.15, 0.1]; },\n  { type = "spot"; position = [0.1, 0.5, 0.1]; direction = [0.3, -1.0, 0.3]; intensity = [0.3, 0.3, 0.4]; inner = 15.0; outer = 30.0; },\n  { type = "directional"; direction = [0.2, -1.0, 0.5]; intensity = [0.5, 0.5, 0.5]; } );\nenvironment = { color = [0.2, 0.3, 0.5]; };\n' \
    "$cornell" >"$tmp/all-lights.cfg"
program_image "program, path under every kind of light" "$tmp/all-lights.cfg" --set integrator.max_depth=5 \
    --set sampler.type=\"stratified\"
program_image "program, path under an environment map" "$src/scenes/materials/environment.cfg" \
    --set integrator.max_depth=5 --set integrator.rr_depth=1
program_image "program, path over GGX, clamped" "$src/scenes/materials/ggx-ramp.cfg" --set integrator.clamp=0.5 \
    --set sampler.type=\"independent\"
# Instances (ABI 3.7): the box placed twice beside its own triangles, once
# turned and mirrored; path samples the placed ceilings' emitters too.
program_image "program, ao over instances" "$tmp/instanced.cfg"
for i in headlight path; do
    sed "s/^integrator = .*/integrator = { plugin = \"$i\"; };/" "$tmp/instanced.cfg" >"$tmp/instanced-$i.cfg"
done
program_image "program, headlight over instances" "$tmp/instanced-headlight.cfg"
program_image "program, path over instances and their emitters" "$tmp/instanced-path.cfg" --set integrator.max_depth=4
# Textures (ABI 3.8): tests/scenes/textured (a floor whose colour, normal
# map, roughness and metalness are repeating images, a ball with a clamped
# colour map, a normal map over corner normals and a shininess map, a lamp
# whose emission is an image, which path samples); bilinear, nearest and
# trilinear filtering (ABI 3.9: MIP levels at each camera hit's
# footprint); the scene placed twice; the second uv set (an emission map)
# and KHR_texture_transform of Khronos's samples where ../shared/data has
# them.
tex=$tmp/textured
textured=$src/tests/scenes/textured/textured.obj
sed "s|^scene = .*|scene = \"$textured\";|" "$src/tests/scenes/textured/textured.cfg" >"$tex-headlight.cfg"
sed 's/^integrator = .*/integrator = { plugin = "ao"; rays = 4; distance = 0.5; albedo = true; };/' "$tex-headlight.cfg" \
    >"$tex-ao.cfg"
sed 's/^integrator = .*/integrator = { plugin = "path"; max_depth = 4; };/' "$tex-headlight.cfg" >"$tex-path.cfg"
printf 'scene = "%s";\ninstances = ( { file = "%s"; translate = [0.9, 0.0, 0.6]; scale = [0.5, 0.5, 0.5]; },\n  { file = "%s"; translate = [-0.8, 0.0, 0.5]; rotate = [0.0, 1.0, 0.0, 40.0]; scale = [-0.4, 0.4, 0.4]; } );\ncamera = { position = [0.0, 1.5, -2.2]; look_at = [0.0, 0.3, 0.0]; fov = 60.0; };\nintegrator = { plugin = "path"; max_depth = 3; };\n' \
    "$textured" "$textured" "$textured" >"$tex-instanced.cfg"
if [ -s "$textured" ]; then
    program_image "program, headlight over textures and normal maps" "$tex-headlight.cfg"
    program_image "program, headlight over nearest textures" "$tex-headlight.cfg" --set textures.filter=\"nearest\"
    program_image "program, ao albedo over textures" "$tex-ao.cfg" --set sampler.type=\"stratified\"
    program_image "program, path over texture maps and a textured lamp" "$tex-path.cfg" --set sampler.type=\"sobol\"
    program_image "program, path over placed textured meshes" "$tex-instanced.cfg"
    tri=(--set textures.filter=\"trilinear\")
    program_image "program, headlight over trilinear textures" "$tex-headlight.cfg" "${tri[@]}"
    program_image "program, ao albedo over trilinear textures" "$tex-ao.cfg" "${tri[@]}"
    program_image "program, path over trilinear textures" "$tex-path.cfg" "${tri[@]}" --set sampler.type=\"sobol\"
    program_image "program, path over placed trilinear meshes" "$tex-instanced.cfg" "${tri[@]}"
    # Texture transforms and the second uv set (mapped.gltf): footprints
    # measured in the set a slot reads and taken through its transform.
    mapped=$src/tests/scenes/textured/mapped.gltf
    sed "s|^scene = .*|scene = \"$mapped\";|" "$src/tests/scenes/textured/mapped.cfg" >"$tmp/mapped-headlight.cfg"
    sed 's/^integrator = .*/integrator = { plugin = "path"; max_depth = 3; };/' "$tmp/mapped-headlight.cfg" \
        >"$tmp/mapped-path.cfg"
    program_image "program, headlight over texture transforms and a second uv set" "$tmp/mapped-headlight.cfg"
    program_image "program, headlight over transforms and a second uv set, trilinear" "$tmp/mapped-headlight.cfg" \
        "${tri[@]}"
    program_image "program, path over an emission map on the second uv set, trilinear" "$tmp/mapped-path.cfg" \
        "${tri[@]}"
    # The footprints matter: trilinear's image is not bilinear's.
    if ! cmp -s "$tmp/program, headlight over trilinear textures-dev.exr" \
            "$tmp/program, headlight over textures and normal maps-dev.exr"; then
        ok "trilinear textures on the device read MIP levels: the image differs from bilinear's"
    else
        bad "trilinear and bilinear device images are the same: no footprint reached a MIP level"
    fi
    # path's program as a wavefront: each step over every live sample.
    device_args=(--set accelerator.wavefront=true)
    program_image "program, path as a wavefront, textures and a lamp" "$tex-path.cfg" --set sampler.type=\"stratified\"
    program_image "program, path as a wavefront, trilinear textures" "$tex-instanced.cfg" "${tri[@]}"
    device_args=()
else
    bad "no $textured"
fi
# Khronos's samples are single-sided, which device accelerators refuse: a
# double-sided copy of each (the glTF's folder copied to $tmp) is traced.
samples=$src/../shared/data/gltf-samples
for model in MultiUVTest TextureTransformTest; do
    if [ ! -f "$samples/$model/glTF/$model.gltf" ]; then
        echo "skip  program, path over $model: no $samples/$model (../shared/data absent)"
        continue
    fi
    cp -r "$samples/$model/glTF" "$tmp/$model"
    python3 - "$tmp/$model/$model.gltf" <<'PY'
import json, sys
doc = json.load(open(sys.argv[1]))
for m in doc["materials"]:
    m["doubleSided"] = True
json.dump(doc, open(sys.argv[1], "w"))
PY
    printf 'scene = "%s/%s/%s.gltf";\nintegrator = { plugin = "path"; max_depth = 2; };\n' "$tmp" "$model" "$model" \
        >"$tmp/$model.cfg"
    program_image "program, path over $model (a double-sided copy)" "$tmp/$model.cfg"
    program_image "program, path over $model, trilinear" "$tmp/$model.cfg" --set textures.filter=\"trilinear\"
done

device_args=(--set accelerator.wavefront=true)
program_image "program, path as a wavefront under every kind of light" "$tmp/all-lights.cfg" \
    --set integrator.max_depth=5 --set integrator.rr_depth=1
program_image "program, path as a wavefront over instances" "$tmp/instanced-path.cfg"
device_args=()

# Where the device runs no program, it traces the integrator's batches, saying why.
fallback() {
    local name=$1 fragment=$2
    shift 2
    local out
    out=$("$@" 2>&1)
    if grep -qF -- "$fragment" <<<"$out" && grep -q "^device .* rays in" <<<"$out" &&
       ! grep -q "samples shaded" <<<"$out"; then
        ok "$name"
    else
        bad "$name (want '$fragment', a device line, no samples shaded)"; echo "$out" | sed 's/^/    /'
    fi
}
dev_ao=("$rtk" render "$tmp/sphere.cfg" "${small[@]}" --set accelerator.plugin=testdevice --set film.output="$tmp/fb.exr")
fallback "programs = false: batches only" "stays on the CPU (the device does not run this program)" \
    "${dev_ao[@]}" --set accelerator.programs=false
fallback "whitted has no device program" "integrator 'whitted' (with these parameters) has no device program" \
    "$rtk" render "$cornell/cornell-whitted.cfg" "${small[@]}" --set accelerator.plugin=testdevice --set film.output="$tmp/fb.exr"
fallback "a device plugin built for ABI 3.8 keeps trilinear textures on the CPU" \
    'textures.filter = "trilinear" needs a device accelerator built for plugin ABI 3.9' \
    "$rtk" render "$tex-headlight.cfg" "${small[@]}" --set textures.filter=\"trilinear\" \
    --set accelerator.plugin=testdevice38 --set film.output="$tmp/fb.exr"

# expect NAME FRAGMENT CMD...: CMD fails, saying FRAGMENT.
refused() {
    local name=$1 fragment=$2
    shift 2
    local out status
    out=$("$@" 2>&1)
    status=$?
    if [ $status -ne 0 ] && grep -qF -- "$fragment" <<<"$out"; then
        ok "$name"
    else
        bad "$name (exit $status, want a failure saying '$fragment')"; echo "$out" | sed 's/^/    /'
    fi
}
ao=("$rtk" render "$cornell/cornell-ao.cfg" "${small[@]}" --set film.output="$tmp/refused.png")
printf 'scene = "%s/cornell.obj";\nfilm = { output = "%s/x.png"; };\naccelerator = { plugin = "testdevice";\n  builder = "nosuch"; };\n' \
    "$cornell" "$tmp" >"$tmp/nosuch.cfg"
refused "an unknown builder is named at its config line" "nosuch.cfg:4: accelerator: builder: no accelerator plugin named 'nosuch'" \
    "$rtk" render "$tmp/nosuch.cfg"
refused "a builder that builds no tree is refused" "names an accelerator that builds no tree" \
    "${ao[@]}" --set accelerator.plugin=testdevice --set accelerator.builder=testdevice
refused "a device that cannot start stops the render" "accelerator 'testdevice' failed to start: testdevice: no device" \
    env RTK_TESTDEVICE_FAIL=create "${ao[@]}" --set accelerator.plugin=testdevice
refused "a device that cannot take the tree stops the render" "could not take the tree of 38 triangles" \
    env RTK_TESTDEVICE_FAIL=attach "${ao[@]}" --set accelerator.plugin=testdevice
[ ! -e "$tmp/refused.png" ] && ok "no image after a refusal" || bad "an image was written after a refusal"

# The builder's tree through the cache (on by default, under
# XDG_CACHE_HOME): saved, then loaded, and traced on the device both times.
for run in saved loaded; do
    out=$("${ao[@]}" --set accelerator.plugin=testdevice --set accelerator.builder=lbvh 2>&1)
    want="saved to cache"
    [ $run = loaded ] && want="from cache"
    if grep -qF "$want" <<<"$out" && grep -q "^device .* rays in" <<<"$out"; then
        ok "cache: the builder's tree $run, traced on the device"
    else
        bad "cache: '$want' and a device line expected"; echo "$out" | sed 's/^/    /'
    fi
done

# rtk bench: the same counts as sah, one call per batch pass, the device table.
obj=$cornell/cornell.obj
if out=$("$rtk" bench "$obj" --accel testdevice,sah --threads 1,2 --runs 1 --width 64 --height 48 \
         --csv "$tmp/bench.csv" 2>&1); then
    counts=$(awk -F, 'NR > 1 { print $2, $3, $12, $13, $14 }' "$tmp/bench.csv" | sort -k2,2 -k1,1)
    dev=$(awk -F, 'NR > 1 && $2 == "testdevice" { print $12, $13, $14 }' "$tmp/bench.csv" | sort -u)
    sah=$(awk -F, 'NR > 1 && $2 == "sah" { print $12, $13, $14 }' "$tmp/bench.csv" | sort -u)
    if [ -n "$dev" ] && [ "$dev" = "$sah" ] && [ "$(wc -l <<<"$dev")" = 1 ]; then
        ok "bench: testdevice's primary hits, AO rays and unoccluded rays equal sah's ($dev)"
    else
        bad "bench: counts differ: $counts"
    fi
    if grep -q "^on a device" <<<"$out" && grep -q "^testdevice .*CPU (rtk's test device)$" <<<"$out" &&
       grep -q '"CPU (rtk.s test device)"' "$tmp/bench.csv"; then
        ok "bench: the device table and the CSV's device column"
    else
        bad "bench: no device table or CSV column"; echo "$out" | sed 's/^/    /'
    fi
else
    bad "bench with testdevice"; echo "$out" | sed 's/^/    /'
fi
echo "$passed passed, $failed failed"
[ $failed -eq 0 ]

#!/usr/bin/env bash
# Renders a fixed list of configs to EXR and prints one line per image:
# "NAME SHA256" of the EXR's bytes. Between two builds of rtk the lists must
# be equal (a move or split of the kernel changes no pixel); run with two
# thread counts they must be equal too (renders do not depend on threads).
#
#   tests/pixels/pixel_hashes.sh RTK_EXE SOURCE_ROOT OUT_DIR [THREADS]
#   tests/pixels/pixel_hashes.sh --compare A.txt B.txt
#
# Every shipped integrator, filter, sampler and accelerator is used at least
# once; the instanced and textured scenes from ../shared/data are added when
# that folder is there (and said to be skipped when not).
set -u

if [ "${1:-}" = "--compare" ]; then
    [ $# -eq 3 ] || { echo "usage: $0 --compare A.txt B.txt" >&2; exit 2; }
    for f in "$2" "$3"; do
        [ -s "$f" ] || { echo "$f: no hashes in it (did the renders fail?)" >&2; exit 2; }
    done
    if diff -u "$2" "$3"; then
        echo "pixel hashes equal: $(wc -l < "$2") images"
        exit 0
    fi
    echo "pixel hashes differ between $2 and $3 (lines above)" >&2
    exit 1
fi

[ $# -ge 3 ] || { echo "usage: $0 RTK_EXE SOURCE_ROOT OUT_DIR [THREADS]" >&2; exit 2; }
rtk=$1 src=$2 out=$3 threads=${4:-$(nproc)}
mkdir -p "$out" || exit 2
cornell=$src/scenes/cornell
shared=$src/../shared/data

# name | config | overrides (space-separated KEY=VALUE)
runs=(
  "headlight-median-box-independent|$cornell/cornell-headlight.cfg|"
  "ao-sah-gaussian-stratified|$cornell/cornell-ao.cfg|accelerator.plugin=sah filter.plugin=gaussian sampler.type=stratified"
  "ao-lbvh-mitchell-sobol|$cornell/cornell-ao.cfg|accelerator.plugin=lbvh filter.plugin=mitchell sampler.type=sobol"
  "arealight-sah-triangle-sobol|$cornell/cornell-arealight.cfg|accelerator.plugin=sah filter.plugin=triangle sampler.type=sobol"
  "arealight-nomis-lanczos-importance|$cornell/cornell-arealight.cfg|integrator.mis=false filter.plugin=lanczos film.reconstruction=importance"
  "whitted-embree-box-stratified|$cornell/cornell-whitted.cfg|accelerator.plugin=embree sampler.type=stratified"
  "whitted-median-mitchell-aovs|$cornell/cornell-whitted.cfg|filter.plugin=mitchell film.aovs=[albedo,normal,depth]"
  "heatmap-sah-box-independent|$cornell/cornell-headlight.cfg|integrator.plugin=heatmap accelerator.plugin=sah"
  "heatmap-lbvh-gaussian-independent|$cornell/cornell-headlight.cfg|integrator.plugin=heatmap accelerator.plugin=lbvh filter.plugin=gaussian"
  "path-sah-gaussian-sobol|$cornell/cornell.cfg|"
)
if [ -d "$shared" ]; then
  runs+=(
    "instances-bunnies-ao|$src/scenes/instances/bunnies.cfg|film.width=160 film.height=90"
    "gltf-balloon|$src/scenes/balloon.cfg|"
    "gltf-smallpine|$src/scenes/smallpine.cfg|"
  )
else
  echo "skipping the instanced and glTF scenes: $shared is absent" >&2
fi

# SHA-256 of the EXR's bytes (rtk writes no date or other varying field).
exr_hash() {
  sha256sum "$1" | cut -d' ' -f1
}

status=0
for run in "${runs[@]}"; do
  IFS='|' read -r name cfg sets <<< "$run"
  args=(render "$cfg" -q --no-cache --threads "$threads" --oversubscribe --set film.width=96 --set film.height=72
        --set film.spp=4 --set sampler.seed=7 -o "$out/$name.exr")
  for s in $sets; do args+=(--set "$s"); done
  if ! "$rtk" "${args[@]}" 2> "$out/$name.log"; then
    echo "$name: render failed:" >&2
    cat "$out/$name.log" >&2
    status=1
    continue
  fi
  echo "$name $(exr_hash "$out/$name.exr")" || status=1
done
exit $status

#!/usr/bin/env bash
# Runs on a lent GPU machine (the device tool, carrying .gpu; docs/testing.md,
# "The GPU check"): unpacks .gpu/bundle.tar.xz (pack.sh) and runs every GPU
# check and benchmark of the cuda plugin in one go, most telling first:
#   1. tests/cuda's programs, whose device code runs where a GPU is;
#   2. `rtk conform cuda`: every accelerator check through the GPU;
#   3. `rtk render` through the device programs on the GPU, with cuda and
#      with sah at 16 threads (seeds 0 and 1), 512x512 at 16 spp: ao (8
#      rays; distance 1 in the showroom, a closed room) on bunny, dragon
#      and the showroom, path (4 bounces) in the Cornell box; the renders
#      as PFM in $OUT/renders-NAME.tar.gz, for compare.sh. Then path's
#      frame rate in the box: 64 frames of 1 spp at 512x512, 4 bounces, as
#      one render of 64 spp, as one kernel and as a wavefront, whose
#      images must be equal (frames/s = 64 / its render time, and 64 / the
#      device's shade time);
#   4. `rtk bench` on bunny, the showroom, dragon, armadillo and elephant
#      with cuda, sah, lbvh and Embree (HIGH, MEDIUM, LOW; when packed) at
#      1, 2, 4, 8 and 16 threads (the showroom at 1, 4 and 16): the GPU
#      against the 16-core CPU, and the builders' scaling table of the
#      ray-batches issue.
# The whole run keeps within GPU_CHECK_SECONDS (default 500): each program
# is stopped at what is left, a step with too little left is skipped saying
# so. Logs and CSVs go to $OUT/gpu-check.tar.gz, rewritten after each step;
# each step's last lines and the bench tables are printed, the summary last.
# Nothing here needs a network.
#
#   bash tools/gpu-check/run.sh [STEPS]      (STEPS: any of tests conform render bench; default all)
set -u
steps=${1:-tests conform render bench}
budget=${GPU_CHECK_SECONDS:-500}
start=$(date +%s)
out=${OUT:-/tmp/gpu-check-out}
logs=/tmp/gpu-check-logs
rm -rf /tmp/rtk "$logs" && mkdir -p "$logs" "$out" || exit 2
tar xJf .gpu/bundle.tar.xz -C /tmp || { echo "run.sh: no .gpu/bundle.tar.xz (carry .gpu; pack.sh makes it)"; exit 2; }
b=/tmp/rtk
# The driver's libcuda, wherever this machine keeps it, after the carried libraries.
cuda_dir=$(ldconfig -p 2>/dev/null | awk '/libcuda\.so\.1 .*x86-64/ { print $NF; exit }')
cuda_dir=${cuda_dir:+$(dirname "$cuda_dir")}
for d in /usr/local/nvidia/lib64 /usr/lib/x86_64-linux-gnu /usr/lib64; do
    [ -z "$cuda_dir" ] && [ -e "$d/libcuda.so.1" ] && cuda_dir=$d
done
libpath=$b/lib:$b/sys${cuda_dir:+:$cuda_dir}
summary=()
note() { summary+=("$1"); echo "== $1"; }
save() { tar czf "$out/gpu-check.tar.gz" -C "$logs" . 2>/dev/null; }
# limit MAX: seconds a program may run, MAX or what the budget leaves (20 s kept to pack the logs).
limit() {
    local l=$((budget - ($(date +%s) - start) - 20))
    [ "$l" -gt "$1" ] && l=$1
    echo "$l"
}
# trun MAX LOG PROGRAM ARGS...: PROGRAM through the carried loader, output to LOG,
# stopped at limit MAX; returns its status (124: stopped; 125: no time left to start it).
trun() {
    local t
    t=$(limit "$1")
    [ "$t" -ge 10 ] || { echo "not run: the budget of $budget s is spent" >"$2"; return 125; }
    timeout "$t" "$b/sys/ld-linux-x86-64.so.2" --library-path "$libpath" "${@:3}" >"$2" 2>&1
}

echo "rtk $(cat "$b/commit"), libcuda from ${cuda_dir:-nowhere (no driver found)}, budget $budget s"
nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm --format=csv,noheader 2>&1 | tee "$logs/gpu.txt"
nproc | sed 's/^/cpu cores: /' | tee -a "$logs/gpu.txt"
grep -m1 'model name' /proc/cpuinfo | tee -a "$logs/gpu.txt"

if [[ " $steps " == *" tests "* ]]; then
    for t in isect sampler bsdf material texture lights program path_program textured_program; do
        trun 60 "$logs/test_$t.log" "$b/tests/test_${t}_cuda" "$b/src"
        note "tests/cuda $t: exit $? ($(tail -1 "$logs/test_$t.log"))"
    done
    for builder in sah lbvh; do
        trun 60 "$logs/test_traverse_$builder.log" "$b/tests/test_traverse_cuda" "$b/lib/rtk/plugins/$builder.so" "$b/src"
        note "tests/cuda traverse $builder: exit $? ($(tail -1 "$logs/test_traverse_$builder.log"))"
    done
    grep -h -E '^(FAIL|skip|# )' "$logs"/test_*.log | head -40
    save
fi

if [[ " $steps " == *" conform "* ]]; then
    t0=$(date +%s)
    trun 150 "$logs/conform_cuda.log" "$b/bin/rtk" conform cuda
    st=$?
    grep -E '^(FAIL|skip)' "$logs/conform_cuda.log" | head -20
    note "rtk conform cuda: exit $st in $(($(date +%s) - t0)) s ($(tail -1 "$logs/conform_cuda.log"))"
    save
fi

if [[ " $steps " == *" render "* ]]; then
    # render_case NAME CFG_TEXT: NAME rendered with cuda and with sah (seeds 0 and 1).
    render_case() {
        local name=$1 renders=/tmp/gpu-check-renders/$1
        mkdir -p "$renders"
        printf '%s\nfilm = { width = 512; height = 512; spp = 16; };\nsampler = { seed = 0; };\n' "$2" >"$renders/$name.cfg"
        for way in cuda:cuda:0 cpu0:sah:0 cpu1:sah:1; do
            IFS=: read -r tag accel seed <<<"$way"
            trun 60 "$logs/render_${name}_$tag.txt" "$b/bin/rtk" render "$renders/$name.cfg" --threads 16 \
                --set accelerator.plugin=$accel --set sampler.seed=$seed -o "$renders/$name-$tag.pfm"
            st=$?
            echo "---- render $name, $tag"
            grep -E '^(render|rays|device|mean) ' "$logs/render_${name}_$tag.txt"
            [ $st -ne 0 ] && tail -3 "$logs/render_${name}_$tag.txt"
            note "render $name $tag: exit $st"
        done
        tar czf "$out/renders-$name.tar.gz" -C "$renders" . 2>/dev/null
    }
    box=$b/src/scenes/cornell/cornell.obj
    box_cfg=$(printf 'scene = "%s";\ncamera = { position = [0.278, 0.273, -0.8]; look_at = [0.278, 0.273, 0.0]; fov = 39.3076; };\nintegrator = { plugin = "path"; max_depth = 4; };' "$box")
    if [ -f "$box" ]; then
        render_case cornell "$box_cfg"
        printf '%s\nfilm = { width = 512; height = 512; spp = 64; };\n' "$box_cfg" >/tmp/gpu-check-renders/frames.cfg
        # path as one kernel (a megakernel), then as a wavefront: the same image, bit for bit.
        for mode in megakernel wavefront; do
            trun 60 "$logs/frames_$mode.txt" "$b/bin/rtk" render /tmp/gpu-check-renders/frames.cfg --threads 16 \
                --set accelerator.plugin=cuda --set accelerator.wavefront=$([ $mode = wavefront ] && echo true || echo false) \
                -o /tmp/gpu-check-renders/frames-$mode.pfm
            st=$?
            echo "---- path frames ($mode), Cornell box 512x512, 4 bounces, 64 x 1 spp"
            grep -E '^(render|rays|device) ' "$logs/frames_$mode.txt"
            awk -v mode=$mode '$1 == "render" { r = $2 } $1 == "device" { for (i = 1; i <= NF; i++) if ($i == "shade") s = $(i + 1) + 0 }
                 END { printf "path frames/s (%s; 512x512, 1 spp, 4 bounces): %.1f by render time, %.1f by shade time summed over the device lanes (target >= 30)\n",
                       mode, (r > 0 ? 64 / r : 0), (s > 0 ? 64 / s : 0) }' "$logs/frames_$mode.txt" | tee -a "$logs/frames_$mode.txt"
            note "path frames, $mode: exit $st ($(tail -1 "$logs/frames_$mode.txt"))"
        done
        if cmp -s /tmp/gpu-check-renders/frames-megakernel.pfm /tmp/gpu-check-renders/frames-wavefront.pfm; then
            note "path frames: the wavefront's image equals the megakernel's, bit for bit"
        else
            note "path frames: the wavefront's image DIFFERS from the megakernel's"
        fi
    else
        note "render cornell: not packed"
    fi
    for m in bunny dragon showroom; do
        f=$b/shared/data/meshes/$m.obj cam="" distance='"inf"'
        [ $m = showroom ] && f=$b/shared/data/showroom/showroom.obj distance=1.0 &&
            cam='camera = { position = [-2.5, 2.2, -2.5]; look_at = [14.0, 0.5, 10.0]; fov = 60.0; };'
        [ -f "$f" ] || { note "render $m: not packed"; continue; }
        render_case "$m" "$(printf 'scene = "%s";\n%s\nintegrator = { plugin = "ao"; rays = 8; distance = %s; };' \
            "$f" "$cam" "$distance")"
    done
    note "renders in \$OUT/renders-*.tar.gz (tools/gpu-check/compare.sh compares them)"
    save
fi

if [[ " $steps " == *" bench "* ]]; then
    accels=cuda,sah,lbvh
    [ -e "$b/lib/rtk/plugins/embree.so" ] && accels=$accels,embree,embree:quality=medium,embree:quality=low
    for m in bunny showroom dragon armadillo elephant; do
        f=$b/shared/data/meshes/$m.obj cam=() threads=1,2,4,8,16 most=150
        # The showroom's 2.2 million triangles: three thread counts take about 140 s on an H100 machine.
        [ $m = showroom ] && f=$b/shared/data/showroom/showroom.obj cam=(--camera -2.5,2.2,-2.5,14,0.5,10,60) \
            threads=1,4,16 most=200
        [ -f "$f" ] || { note "bench $m: not packed"; continue; }
        t0=$(date +%s)
        trun $most "$logs/bench_$m.txt" "$b/bin/rtk" bench "$f" "${cam[@]}" --accel "$accels" \
            --threads $threads --runs 3 --verbose --csv "$logs/bench_$m.csv"
        st=$?
        if [ $st -ne 0 ] && grep -q "accelerator 'cuda' failed to start" "$logs/bench_$m.txt"; then
            mv "$logs/bench_$m.txt" "$logs/bench_${m}_cuda_failed.txt"   # the CPU's table still counts
            trun $most "$logs/bench_$m.txt" "$b/bin/rtk" bench "$f" "${cam[@]}" --accel "${accels#cuda,}" \
                --threads $threads --runs 3 --verbose --csv "$logs/bench_$m.csv"
            st=$?
            note "bench $m: cuda failed to start (bench_${m}_cuda_failed.txt); again without it"
        fi
        echo "---- bench $m"
        sed -n '/^accelerator  *threads  *build_ms/,/^$/p; /^against embree/,/^$/p; /^batches against/,/^$/p; /^on a device/,/^$/p' "$logs/bench_$m.txt"
        [ $st -ne 0 ] && tail -3 "$logs/bench_$m.txt"
        note "bench $m: exit $st in $(($(date +%s) - t0)) s"
        save
    done
fi

save
echo "==== summary ($(($(date +%s) - start)) s of $budget)"
printf '%s\n' "${summary[@]}"

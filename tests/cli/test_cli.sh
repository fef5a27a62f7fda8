#!/usr/bin/env bash
# End-to-end checks of the rtk command: plugin listing, rendering, config
# errors with file and line, refusing untrusted code, atomic output, help,
# suggestions, the version and the thread limit.
# usage: test_cli.sh RTK SOURCE_ROOT BUILD_ROOT VERSION
set -u
rtk=$1
src=$2
build=$3
version=$4
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
export XDG_CACHE_HOME="$tmp/cache"
passed=0
failed=0

ok() { passed=$((passed + 1)); echo "ok    $1"; }
bad() { failed=$((failed + 1)); echo "FAIL  $1"; }
# expect NAME STATUS(0|fail|N) PATTERN... -- CMD...: runs CMD, checks exit and that output has every pattern
expect() {
    local name=$1 want=$2
    shift 2
    local patterns=()
    while [ "$1" != "--" ]; do patterns+=("$1"); shift; done
    shift
    local out status
    out=$("$@" 2>&1)
    status=$?
    if [ "$want" = 0 ] && [ $status -ne 0 ]; then
        bad "$name (exit $status)"; echo "$out" | sed 's/^/    /'; return
    fi
    if [ "$want" = fail ] && [ $status -eq 0 ]; then
        bad "$name (succeeded, expected failure)"; echo "$out" | sed 's/^/    /'; return
    fi
    if [ "$want" != 0 ] && [ "$want" != fail ] && [ $status -ne "$want" ]; then
        bad "$name (exit $status, expected $want)"; echo "$out" | sed 's/^/    /'; return
    fi
    for p in "${patterns[@]}"; do
        if ! grep -qF -- "$p" <<<"$out"; then
            bad "$name (no '$p' in output)"; echo "$out" | sed 's/^/    /'; return
        fi
    done
    ok "$name"
}

expect "rtk plugins lists the shipped plugins" 0 "headlight" "median" "box" "integrator" "accelerator" "filter" -- "$rtk" plugins
expect "rtk plugins NAME prints parameters" 0 "ambient" "float" "[0, 1]" -- "$rtk" plugins headlight
expect "rtk plugins median prints choices" 0 "object|spatial" "max_leaf" -- "$rtk" plugins median
expect "unknown command is a usage error" fail "unknown command" -- "$rtk" frobnicate

cat >"$tmp/quad.obj" <<'OBJ'
v -1 -1 0
v 1 -1 0
v 1 1 0
v -1 1 0
f 1 2 3 4
OBJ
printf 'scene = "quad.obj";\nfilm = { width = 32; height = 24; spp = 2; output = "quad.png"; };\n' >"$tmp/min.cfg"
expect "minimal config renders" 0 "rays" "Mrays/s" "mean" -- "$rtk" render "$tmp/min.cfg"
[ -f "$tmp/quad.png" ] && ok "output written next to the config" || bad "output written next to the config"
ls "$tmp" | grep -q tmp && bad "no temporary file left behind" || ok "no temporary file left behind"
# A config from a pipe: the check of integer literals reads regular files
# only, so libconfig still gets the whole text.
expect "a config read from a pipe renders" 0 "32x24" -- "$rtk" render \
    <(printf 'scene = "%s/quad.obj";\nfilm = { width = 32; height = 24; spp = 1; output = "%s/pipe.png"; };\n' "$tmp" "$tmp")
printf 'scene = "quad.obj";\nfilm = {\n  width = 4294967297; height = 24; };\n' >"$tmp/wrap.cfg"
expect "an integer libconfig would wrap is refused with file and line" fail "wrap.cfg:3" "4294967297L" -- \
    "$rtk" render "$tmp/wrap.cfg"

printf 'scene = "quad.obj";\nfilm = {\n  widht = 32;\n};\n' >"$tmp/typo.cfg"
expect "typo'd key names file, line and suggestion" fail "typo.cfg:3" "did you mean 'width'" -- "$rtk" render "$tmp/typo.cfg"
printf 'scene = "quad.obj";\nfilm = { width = "wide"; };\n' >"$tmp/type.cfg"
expect "wrong type names file and line" fail "type.cfg:2" "width" -- "$rtk" render "$tmp/type.cfg"
printf 'scene = "quad.obj";\n\nintegrator = { plugin = "headlite"; };\n' >"$tmp/missing.cfg"
expect "missing plugin names file, line and what exists" fail "missing.cfg:3" "headlite" "headlight" -- "$rtk" render "$tmp/missing.cfg"
printf 'scene = "quad.obj";\nlights = ( { type = "point"; positon = [0, 1, 0]; intensity = [1, 1, 1]; } );\n' >"$tmp/light.cfg"
expect "typo in a light names file, line and suggestion" fail "light.cfg:2" "did you mean 'position'" -- "$rtk" render "$tmp/light.cfg"
printf 'scene = "quad.obj";\nfilm = { spp = 0; };\n' >"$tmp/range.cfg"
expect "out of range value names file and line" fail "range.cfg:2" "spp" -- "$rtk" render "$tmp/range.cfg"
expect "--set override with a typo is refused" fail "--set" "bogus" -- "$rtk" render "$tmp/min.cfg" --set integrator.bogus=1
expect "--set override applies" 0 "8x8" -- "$rtk" render "$tmp/min.cfg" --set film.width=8 --set film.height=8

# Every bad --set at once (only the last one read was reported).
expect "every bad --set is reported" fail "2 errors" "--set integrator.bogus=1" "--set film.widht=3" \
    "did you mean 'width'" -- "$rtk" render "$tmp/min.cfg" --set integrator.bogus=1 --set film.widht=3
# --set arrays, as rtk render --help shows them.
expect "--set film.aovs=[albedo,normal] renders the layers" 0 "aovs.exr" -- "$rtk" render "$tmp/min.cfg" \
    -o "$tmp/aovs.exr" --set film.aovs=[albedo,normal]
expect "--set film.aovs with quoted strings renders" 0 "aovs2.exr" -- "$rtk" render "$tmp/min.cfg" \
    -o "$tmp/aovs2.exr" --set 'film.aovs=["albedo","normal"]'
# inf in a config: the string "inf"; bare inf gets the way to write it.
printf 'scene = "quad.obj";\nfilm = { width = 8; height = 8; spp = 1; };\nintegrator = { plugin = "ao"; distance = "inf"; };\n' \
    >"$tmp/inf.cfg"
expect "distance = \"inf\" renders" 0 "8x8" -- "$rtk" render "$tmp/inf.cfg"
printf 'scene = "quad.obj";\nintegrator = { plugin = "ao";\n  distance = inf; };\n' >"$tmp/bareinf.cfg"
expect "bare inf says how to write it" fail "bareinf.cfg:3" 'distance = "inf";' -- "$rtk" render "$tmp/bareinf.cfg"

# Help: per command, short usage on errors, the overview, did-you-mean.
lines() { "$@" 2>&1 | wc -l; }
expect "rtk render --help shows render's options" 0 "usage: rtk render CONFIG" "--threads" "--oversubscribe" \
    "--allow-outside-files" "film.aovs=[albedo,normal]" "--plugin-path" -- "$rtk" render --help
out=$("$rtk" render --help)
if grep -q -- "--samplers\|--epsilon\|--accel " <<<"$out"; then bad "render --help leaves out other commands' options"
else ok "render --help leaves out other commands' options"; fi
[ "$("$rtk" help render)" = "$out" ] && ok "rtk help render = rtk render --help" || bad "rtk help render = rtk render --help"
expect "rtk bench -h shows bench's options" 0 "usage: rtk bench" "--accel" "--runs" "--allow-outside-files" -- "$rtk" bench -h
expect "rtk sweep --help shows sweep's options" 0 "usage: rtk sweep" "--samplers" "--allow-outside-files" \
    "--oversubscribe" -- "$rtk" sweep --help
expect "rtk --help is the overview" 0 "render" "plugins" "conform" "bench" "diff" "sweep" "rtk help COMMAND" -- "$rtk" --help
expect "rtk help lists the commands" 0 "render" "sweep" "version" -- "$rtk" help
if "$rtk" --help | grep -q -- "--reference-spp"; then bad "the overview leaves out command options"
else ok "the overview leaves out command options"; fi
expect "a typo'd command gets a suggestion" 2 "unknown command 'rendr'" "did you mean 'render'?" -- "$rtk" rendr x.cfg
expect "rtk help of a typo'd command" 2 "did you mean 'sweep'?" -- "$rtk" help swep
expect "a typo'd render option gets a suggestion" 2 "unknown option '--thread' for render" "did you mean '--threads'?" \
    "usage: rtk render CONFIG" -- "$rtk" render "$tmp/min.cfg" --thread 4
expect "a typo'd bench option gets a suggestion" 2 "did you mean '--runs'?" -- "$rtk" bench x.obj --runz 3
expect "an empty item in a list is a usage error" 2 "--accel: item 2 of its list is empty" -- "$rtk" bench x.obj \
    --accel sah,,lbvh
expect "an empty list is a usage error" 2 "--spp: item 1 of its list is empty" -- "$rtk" sweep x.cfg --spp ""
expect "a list longer than the cap is a usage error" 2 "--threads: more than 64 items" -- "$rtk" bench x.obj \
    --threads "$(printf '1,%.0s' {1..64})1"
expect "a typo'd sweep option gets a suggestion" 2 "did you mean '--samplers'?" -- "$rtk" sweep x.cfg --sampler sobol
expect "a typo'd diff option gets a suggestion" 2 "did you mean '--epsilon'?" -- "$rtk" diff a.png b.png --epsilom 1
expect "a typo'd option before the command" 2 "did you mean '--threads'?" -- "$rtk" --thread 4 render "$tmp/min.cfg"
n=$(lines "$rtk" render)
[ "$n" -le 4 ] && ok "a usage error prints the command's usage, not all help ($n lines)" ||
    bad "a usage error prints the command's usage, not all help ($n lines)"
expect "--threads without a value names it" 2 "--threads needs a value" -- "$rtk" render "$tmp/min.cfg" --threads
expect "options before the command still apply" 0 -- "$rtk" --set film.width=8 -q render "$tmp/min.cfg" \
    --set film.height=8 -o "$tmp/before.png"
[ -f "$tmp/before.png" ] && ok "options before the command: -q and -o" || bad "options before the command: -q and -o"
# -o: named as typed in errors, and the last of several wins.
expect "an error in -o names -o" fail "-o $tmp/outdir:" "no file extension" -- "$rtk" render "$tmp/min.cfg" \
    -o "$tmp/outdir"
expect "-o given twice renders the last" 0 -- "$rtk" -q render "$tmp/min.cfg" --set film.width=8 --set film.height=8 \
    -o "$tmp/first.png" -o "$tmp/second.png"
[ -f "$tmp/second.png" ] && [ ! -e "$tmp/first.png" ] && ok "-o given twice writes the last only" ||
    bad "-o given twice writes the last only"
expect "--version gives the release and the ABI" 0 "rtk $version (plugin ABI " -- "$rtk" --version
expect "rtk version gives the same" 0 "rtk $version (plugin ABI " -- "$rtk" version
expect "--allow-outside-files is an option of render" 0 "8x8" -- "$rtk" render "$tmp/min.cfg" --allow-outside-files \
    --set film.width=8 --set film.height=8

# Threads above the cores this process may use (online, in its affinity
# and its cgroup's CPU quota) are capped, with a warning, unless
# --oversubscribe. The count is rtk's own, read from its warning for 1024.
plural() { [ "$1" = 1 ] && echo "$1 core" || echo "$1 cores"; }
cores=$("$rtk" render "$tmp/min.cfg" --threads 1024 --set film.width=8 --set film.height=8 -o "$tmp/cores.png" 2>&1 |
    sed -n 's/.*1024 threads on the \([0-9]*\) cores\{0,1\} this process may use.*/\1/p')
if [ -z "$cores" ]; then
    bad "1024 threads are capped to the cores this process may use (no warning)"
elif [ "$cores" -gt "$(nproc --all)" ]; then
    bad "rtk counts $cores cores, more than the $(nproc --all) installed"
elif [ "$cores" -lt 1024 ]; then
    many=$((cores + 3))
    on="$many threads on the $(plural "$cores") this process may use"
    expect "--threads above the cores is capped" 0 "--threads $many: $on" \
        "using $cores" "spp, $cores thread" -- "$rtk" render "$tmp/min.cfg" --threads "$many"
    expect "--oversubscribe keeps them" 0 "$many threads" -- "$rtk" render "$tmp/min.cfg" --threads "$many" --oversubscribe
    if "$rtk" render "$tmp/min.cfg" --threads "$many" --oversubscribe 2>&1 | grep -q "this process may use"; then
        bad "--oversubscribe gives no warning"; else ok "--oversubscribe gives no warning"; fi
    printf 'scene = "quad.obj";\nfilm = { width = 8; height = 8; spp = 1; };\nthreads = %d;\n' "$many" >"$tmp/threads.cfg"
    expect "the config's threads are capped" 0 "threads.cfg:3: $on" \
        "spp, $cores thread" -- "$rtk" render "$tmp/threads.cfg"
    printf 'oversubscribe = true;\n' >>"$tmp/threads.cfg"
    expect "oversubscribe = true keeps them" 0 "$many threads" -- "$rtk" render "$tmp/threads.cfg"
    expect "bench caps its thread counts" 0 "--threads $many: $on" -- \
        "$rtk" bench "$tmp/quad.obj" --accel median --threads "1,$many" --runs 1 --width 8 --height 8 -q
    expect "sweep caps its threads" 0 "--threads $many: $on" -- \
        "$rtk" sweep "$tmp/min.cfg" --threads "$many" --spp 1 --seeds 1 --reference-spp 1 --no-plot --out "$tmp/sweep" -q
else
    echo "skip  thread limit ($cores cores)"
fi
# The affinity mask counts: pinned to one CPU, 2 threads are capped to 1.
cpu=$(taskset -pc $$ 2>/dev/null | sed 's/.*: *//; s/[-,].*//')
if [ -n "$cpu" ] && taskset -c "$cpu" true 2>/dev/null; then
    expect "a process pinned to one CPU runs one thread" 0 \
        "--threads 2: 2 threads on the 1 core this process may use" "spp, 1 thread" -- \
        taskset -c "$cpu" "$rtk" render "$tmp/min.cfg" --threads 2
else
    echo "skip  affinity (taskset cannot pin this process here)"
fi

printf 'scene = "quad.obj";\nplugin_path = "plugins";\n' >"$tmp/untrusted.cfg"
mkdir -p "$tmp/plugins"
expect "config plugin_path refused without the flag" fail "untrusted.cfg:2" "--allow-config-plugins" -- "$rtk" render "$tmp/untrusted.cfg"

if [ -f "$build/tests/plugins/broken/abi_major.so" ]; then
    cp "$build/tests/plugins/broken/abi_major.so" "$tmp/plugins/abi_major.so"
    printf 'scene = "quad.obj";\nplugin_path = "plugins";\nintegrator = { plugin = "abi_major"; };\n' >"$tmp/abi.cfg"
    expect "plugin built for another ABI fails before rendering" fail "abi_major.so" "ABI" -- "$rtk" render "$tmp/abi.cfg" --allow-config-plugins
fi

printf 'scene = "quad.obj";\nfilm = { output = "no/such/dir/x.png"; width = 8; height = 8; };\n' >"$tmp/nodir.cfg"
expect "unwritable output is an error naming the file" fail "x.png" -- "$rtk" render "$tmp/nodir.cfg"
echo "old" >"$tmp/keep.png"
printf 'scene = "quad.obj";\nfilm = { output = "keep.png"; width = 8; height = 8; };\nintegrator = { plugin = "headlight"; };\n' >"$tmp/keep.cfg"
printf 'v 0 0 0\nf 1 2 3\n' >"$tmp/broken.obj"
expect "broken scene fails" fail "broken.obj" -- "$rtk" render "$tmp/keep.cfg" --set scene=broken.obj
[ "$(cat "$tmp/keep.png")" = old ] && ok "failed render leaves the old image untouched" || bad "failed render leaves the old image untouched"

# The installed SDK builds a plugin outside the tree with pkg-config alone.
if command -v meson >/dev/null && command -v cc >/dev/null &&
    meson install -C "$build" --destdir "$tmp/stage" --no-rebuild --quiet >"$tmp/install.log" 2>&1; then
    pc=$(find "$tmp/stage" -name rtk.pc | head -n 1)
    cflags=$(PKG_CONFIG_PATH=$(dirname "$pc") pkg-config --cflags rtk)
    if cc -shared -fPIC $cflags "$src/tests/plugins/broken/outside_tree.c" -o "$tmp/plugins/outside_tree.so" 2>"$tmp/cc.log"; then
        ok "out-of-tree plugin compiles with pkg-config --cflags rtk"
        expect "out-of-tree plugin passes rtk conform" 0 "passed, 0 failed" -- "$rtk" conform "$tmp/plugins/outside_tree.so"
        expect "out-of-tree plugin found through RTK_PLUGIN_PATH" 0 "outside_tree" -- env RTK_PLUGIN_PATH="$tmp/plugins" "$rtk" plugins
    else
        bad "out-of-tree plugin compiles with pkg-config --cflags rtk"; cat "$tmp/cc.log"
    fi
    # The image module is installed, and an rtk that cannot load it says
    # which file is missing and writes nothing. A copy of the command and
    # librtk outside the build tree looks for the module beside that
    # librtk, in rtk/, where there is none. PNG and EXR need no module.
    staged=$(find "$tmp/stage" -name rtk_image.so | head -n 1)
    [ -n "$staged" ] && ok "meson install ships the image module" || bad "meson install ships the image module"
    installed=$tmp/moved/rtk/rtk_image.so
    if [ -n "$staged" ]; then
        mkdir -p "$tmp/moved"
        cp "$rtk" "$tmp/moved/rtk"
        cp -L "$build/kernel/librtk.so.0" "$tmp/moved/librtk.so.0"
        plugin_dirs="$build/plugins/integrators:$build/plugins/accelerators:$build/plugins/filters"
        printf 'scene = "quad.obj";\nfilm = { output = "moved.jpg"; width = 8; height = 8; };\n' >"$tmp/moved.cfg"
        moved=(env LD_LIBRARY_PATH="$tmp/moved" RTK_PLUGIN_PATH="$plugin_dirs" "$tmp/moved/rtk" render "$tmp/moved.cfg")
        expect "a missing image module is an error naming it" fail "image adapter $installed cannot be loaded" \
            "moved.jpg" -- "${moved[@]}"
        [ ! -e "$tmp/moved.jpg" ] && ok "no image written without the module" || bad "no image written without the module"
        for ext in png exr; do
            expect "a .$ext is written without the module" 0 "moved.$ext" -- "${moved[@]}" --set film.output=\"moved.$ext\"
            [ -s "$tmp/moved.$ext" ] && ok "moved.$ext written" || bad "moved.$ext written"
        done
    fi
else
    bad "meson install of the SDK"; cat "$tmp/install.log"
fi

echo "$passed passed, $failed failed"
[ $failed -eq 0 ]

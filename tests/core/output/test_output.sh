#!/usr/bin/env bash
# Outputs are safe: film.output is checked before the scene loads; SIGINT
# and SIGTERM in each phase leave no temporary file and the previous image,
# say what was interrupted in one line and exit 130/143; a file size limit
# (ulimit -f) fails the write in every format with the old file kept; the
# temporaries a killed run left are removed by the next run, and only those.
# usage: test_output.sh RTK SOURCE_ROOT
set -u
rtk=$1
src=$2
tmp=$(mktemp -d)
helpers=()
cleanup() {
    for p in "${helpers[@]}"; do kill "$p" 2>/dev/null; done
    chmod -R u+w "$tmp" 2>/dev/null
    rm -rf "$tmp"
}
trap cleanup EXIT
. "$(dirname "$0")/common.sh"
formats=(exr png jpg hdr tif tga bmp ppm)

# A config of the Cornell box whose scene path is $2 (absolute), w x h.
write_cfg() {
    cat >"$1" <<EOF
scene = "$2";
camera = { position = [0.278, 0.273, -0.8]; look_at = [0.278, 0.273, 0.0]; up = [0.0, 1.0, 0.0]; fov = 39.3; };
film = { width = $3; height = $4; spp = 1; };
integrator = { plugin = "headlight"; };
accelerator = { plugin = "median"; };
cache = "off";
EOF
}
cfg=$tmp/box.cfg
write_cfg "$cfg" "$src/scenes/cornell/cornell.obj" 96 64
missing_cfg=$tmp/missing.cfg
write_cfg "$missing_cfg" "$tmp/no-such-scene.obj" 96 64
out=$tmp/out
mkdir "$out"

# Reference images, one per format, that later runs must leave untouched.
for f in "${formats[@]}"; do
    if ! "$rtk" render "$cfg" -q -o "$out/old.$f" >"$tmp/log" 2>&1; then
        bad "render a .$f"; show "$tmp/log"
    fi
done
[ "$failed" -eq 0 ] && ok "every format renders (${formats[*]})"

# ---- the output is checked before the scene loads ----
# The scene does not exist: an error about the output proves it came first.
# precheck NAME TARGET PATTERN [WHERE]: WHERE (default: the config's name)
# must be in the message too.
precheck() {
    local name=$1 target=$2 pattern=$3 where=${4:-missing.cfg}
    "$rtk" render "$missing_cfg" -q -o "$target" >"$tmp/log" 2>&1
    local status=$?
    if [ $status -eq 0 ]; then
        bad "$name: exit 0"; show "$tmp/log"
    elif grep -q "no-such-scene" "$tmp/log"; then
        bad "$name: the scene was loaded before the output was checked"; show "$tmp/log"
    elif ! grep -qF -- "$pattern" "$tmp/log" || ! grep -qF -- "$where" "$tmp/log"; then
        bad "$name: message lacks '$pattern' or the config's name"; show "$tmp/log"
    else
        ok "$name: refused before loading"
    fi
}
precheck "nonexistent directory" "$tmp/no/such/dir/out.png" "does not exist; create it or write elsewhere"
precheck "unknown extension" "$out/x.xyz" "OpenImageIO has no writer for '.xyz'"
precheck "no extension" "$out/x" "has no file extension" "-o $out/x:"
precheck "format rtk does not write" "$out/x.sgi" "rtk does not write sgi files"
mkdir "$out/dir.png"
precheck "output is a directory" "$out/dir.png" "is a directory"
mkdir "$tmp/file-parent" && touch "$tmp/file-parent/f"
precheck "parent is a file" "$tmp/file-parent/f/out.png" "is not a directory"
if [ "$(id -u)" -ne 0 ]; then
    mkdir "$tmp/ro" && chmod 555 "$tmp/ro"
    precheck "unwritable directory" "$tmp/ro/out.png" "is not writable"
else
    echo "skip  unwritable directory by permissions: running as root (test_output_full.sh checks a read-only mount)"
fi
cat >"$tmp/aov.cfg" <<EOF
scene = "$tmp/no-such-scene.obj";
film = { width = 8; height = 8; spp = 1; aovs = ["albedo"]; };
integrator = { plugin = "headlight"; };
EOF
"$rtk" render "$tmp/aov.cfg" -q -o "$out/aov.png" >"$tmp/log" 2>&1
if [ $? -ne 0 ] && grep -q "need an EXR output" "$tmp/log" && ! grep -q no-such-scene "$tmp/log"; then
    ok "AOVs to a PNG: refused before loading"
else
    bad "AOVs to a PNG"; show "$tmp/log"
fi

# ---- interrupts ----
# Waits (bounded, no fixed sleep) until process $1 is stopped.
wait_stopped() {
    local i state
    for ((i = 0; i < 6000; i++)); do
        state=$(awk '{print $3}' "/proc/$1/stat" 2>/dev/null) || return 1
        [ "$state" = T ] && return 0
        sleep 0.01
    done
    return 1
}
# interrupt SIG PHASE EXT: stops rtk at PHASE (RTK_TEST_STOP_AT), sends SIG.
interrupt() {
    local sig=$1 phase=$2 ext=$3 want words
    case $sig in INT) want=130 ;; TERM) want=143 ;; esac
    case $phase in
        loading) words="loading the scene" ;;
        building) words="building the BVH" ;;
        rendering) words="rendering" ;;
        write) words="writing the image" ;;
    esac
    local target=$out/int.$ext name="SIG$sig at $phase (.$ext)"
    cp "$out/old.$ext" "$target"
    # Background jobs of a script ignore SIGINT; env gives rtk the default.
    RTK_TEST_STOP_AT=$phase env --default-signal=INT,TERM "$rtk" render "$cfg" -q -o "$target" 2>"$tmp/err" &
    local pid=$!
    if ! wait_stopped $pid; then
        kill -KILL $pid 2>/dev/null; wait $pid 2>/dev/null
        bad "$name: rtk did not reach the stop point"; show "$tmp/err"; return
    fi
    if [ "$phase" = write ] && [ -z "$(ls "$out" | grep "^int\.tmp$pid-")" ]; then
        bad "$name: no temporary file while stopped in the write"
    fi
    kill -"$sig" $pid
    kill -CONT $pid
    wait $pid
    local status=$?
    local leftovers
    leftovers=$(ls -A "$out" | grep '\.tmp' || true)
    local line="rtk: interrupted by SIG$sig while $words; '$target' was not written (the previous file is unchanged)"
    if [ $status -ne $want ]; then
        bad "$name: exit $status, expected $want"; show "$tmp/err"
    elif [ -n "$leftovers" ]; then
        bad "$name: temporary files left: $leftovers"
    elif ! cmp -s "$target" "$out/old.$ext"; then
        bad "$name: the previous output changed"
    elif [ "$(wc -l <"$tmp/err")" -ne 1 ] || [ "$(cat "$tmp/err")" != "$line" ]; then
        bad "$name: expected the one line \"$line\""; show "$tmp/err"
    else
        ok "$name: exit $status, previous file kept, nothing left, one line"
    fi
    rm -f "$target"
}
for sig in INT TERM; do
    for phase in loading building rendering; do
        interrupt $sig $phase png
    done
    for f in exr png jpg; do
        interrupt $sig write $f
    done
done

# SIGINT while a BVH cache file is saved: its temporary goes too.
cache=$tmp/cache
mkdir "$cache"
RTK_TEST_STOP_AT=cache-save env --default-signal=INT "$rtk" render "$cfg" -q --set "cache=$cache" \
    -o "$out/c.png" 2>"$tmp/err" &
pid=$!
if wait_stopped $pid; then
    had=$(ls -A "$cache" | grep -c '\.tmp')
    kill -INT $pid
    kill -CONT $pid
    wait $pid
    status=$?
    if [ "$had" -eq 1 ] && [ $status -eq 130 ] && [ -z "$(ls -A "$cache")" ] && [ ! -e "$out/c.png" ] &&
        grep -qx "rtk: interrupted by SIGINT while building the BVH; '$out/c.png' was not written" "$tmp/err"; then
        ok "SIGINT in a BVH cache save: its temporary removed, exit 130, one line"
    else
        bad "SIGINT in a BVH cache save (temporaries before: $had, exit $status, left: $(ls -A "$cache"))"
        show "$tmp/err"
    fi
else
    kill -KILL $pid 2>/dev/null
    bad "SIGINT in a BVH cache save: rtk did not reach the stop point"; show "$tmp/err"
fi

# ---- a file size limit in every format ----
for f in "${formats[@]}"; do
    target=$out/lim.$f
    cp "$out/old.$f" "$target"
    # 4 KiB: every 256x256 image is larger, so each write fails.
    (ulimit -f 4; exec "$rtk" render "$cfg" -q --set film.width=256 --set film.height=256 -o "$target") \
        >"$tmp/log" 2>&1
    check_refused "ulimit -f, .$f" $? "$tmp/log" "$out" "$target" "$out/old.$f" "File too large"
    rm -f "$target"
done

# ---- temporaries of processes that no longer run ----
stale=$tmp/stale
mkdir "$stale"
sleep 600 &
live=$!
helpers+=("$live")
dead=$(sh -c 'echo $$')
for ((i = 0; i < 100 && dead > 0; i++)); do
    kill -0 "$dead" 2>/dev/null || break
    dead=$(sh -c 'echo $$')
done
if kill -0 "$dead" 2>/dev/null; then
    bad "found no pid that is not running"
else
    mine=(out.tmp$dead-0.png out.tmp$dead-17.png)
    others=(out.tmp$live-0.png out.tmp$dead-0.png.bak out.tmp$dead-x.png out.tmp$dead-0.exr
            other.tmp$dead-0.png out.tmp$dead.png out.tmp-$dead-0.png xout.tmp$dead-0.png)
    for n in "${mine[@]}" "${others[@]}"; do echo partial >"$stale/$n"; done
    mkdir "$stale/out.tmp$dead-3.png"
    others+=(out.tmp$dead-3.png)
    if "$rtk" render "$cfg" -q -o "$stale/out.png" >"$tmp/log" 2>&1; then
        gone=1
        for n in "${mine[@]}"; do [ -e "$stale/$n" ] && gone=0; done
        kept=1
        for n in "${others[@]}"; do [ -e "$stale/$n" ] || kept=0; done
        if [ $gone -eq 1 ] && [ $kept -eq 1 ] && [ -s "$stale/out.png" ]; then
            ok "stale temporaries of a dead pid removed; a live pid's and other names kept"
        else
            bad "stale temporaries (removed all of mine: $gone, kept all others: $kept)"; ls -A "$stale"
        fi
    else
        bad "render next to stale temporaries"; show "$tmp/log"
    fi
fi
kill "$live" 2>/dev/null

# SIGKILL in the write leaves the temporary; the next run removes it.
target=$out/kill.exr
RTK_TEST_STOP_AT=write "$rtk" render "$cfg" -q -o "$target" 2>"$tmp/err" &
pid=$!
if wait_stopped $pid; then
    kill -KILL $pid
    wait $pid 2>/dev/null
    left=$(ls "$out" | grep "^kill\.tmp$pid-" || true)
    if [ -z "$left" ]; then
        bad "SIGKILL in the write: no temporary to clean (the stop point is not in the write)"
    elif "$rtk" render "$cfg" -q -o "$target" >"$tmp/log" 2>&1 && [ ! -e "$out/$left" ] && [ -s "$target" ]; then
        ok "SIGKILL in the write: the next run removed $left"
    else
        bad "SIGKILL in the write: $left still there or the render failed"; show "$tmp/log"
    fi
else
    kill -KILL $pid 2>/dev/null
    bad "SIGKILL in the write: rtk did not reach the stop point"; show "$tmp/err"
fi

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]

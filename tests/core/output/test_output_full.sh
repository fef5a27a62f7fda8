#!/usr/bin/env bash
# A full filesystem while rtk writes, in every output format: a small tmpfs
# filled to the last block holds the previous image; the render must fail
# with "No space left on device", keep the previous image byte for byte and
# leave no temporary file. Also a read-only mount as the output's directory
# (refused before the scene loads). Needs root and mount: exit 77 (skip)
# otherwise.
# usage: test_output_full.sh RTK SOURCE_ROOT
set -u
rtk=$1
src=$2
if [ "$(id -u)" -ne 0 ]; then
    echo "skip: mounting a small tmpfs needs root (this test fills one to check full-disk writes)"
    exit 77
fi
tmp=$(mktemp -d)
mnt=$tmp/mnt
ro=$tmp/ro
mkdir "$mnt" "$ro"
cleanup() {
    umount "$mnt" 2>/dev/null
    umount "$ro" 2>/dev/null
    rm -rf "$tmp"
}
trap cleanup EXIT
if ! mount -t tmpfs -o size=4m tmpfs "$mnt" 2>"$tmp/mount.log"; then
    echo "skip: mount -t tmpfs is not permitted here ($(cat "$tmp/mount.log"))"
    exit 77
fi
. "$(dirname "$0")/common.sh"

cfg=$tmp/box.cfg
cat >"$cfg" <<EOF
scene = "$src/scenes/cornell/cornell.obj";
camera = { position = [0.278, 0.273, -0.8]; look_at = [0.278, 0.273, 0.0]; up = [0.0, 1.0, 0.0]; fov = 39.3; };
film = { width = 64; height = 48; spp = 1; };
integrator = { plugin = "headlight"; };
accelerator = { plugin = "median"; };
cache = "off";
EOF

for f in exr png jpg hdr tif tga bmp ppm; do
    name="full disk, .$f"
    if ! "$rtk" render "$cfg" -q -o "$tmp/old.$f" >"$tmp/log" 2>&1; then
        bad "$name: the small render failed"; show "$tmp/log"; continue
    fi
    cp "$tmp/old.$f" "$mnt/out.$f"
    # Fill every block that is left (dd stops at ENOSPC).
    dd if=/dev/zero of="$mnt/fill" bs=4096 >/dev/null 2>&1
    "$rtk" render "$cfg" -q --set film.width=256 --set film.height=256 -o "$mnt/out.$f" >"$tmp/log" 2>&1
    check_refused "$name" $? "$tmp/log" "$mnt" "$mnt/out.$f" "$tmp/old.$f" "No space left on device"
    rm -f "$mnt"/*
done

if mount -t tmpfs -o ro,size=64k tmpfs "$ro" 2>/dev/null; then
    cat >"$tmp/missing.cfg" <<EOF
scene = "$tmp/no-such-scene.obj";
film = { width = 8; height = 8; spp = 1; };
integrator = { plugin = "headlight"; };
EOF
    "$rtk" render "$tmp/missing.cfg" -q -o "$ro/out.png" >"$tmp/log" 2>&1
    status=$?
    if [ $status -ne 0 ] && grep -q "is not writable (Read-only file system)" "$tmp/log" &&
        ! grep -q no-such-scene "$tmp/log"; then
        ok "read-only directory: refused before loading"
    else
        bad "read-only directory (exit $status)"; show "$tmp/log"
    fi
else
    echo "skip  read-only directory: a read-only tmpfs cannot be mounted"
fi

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]

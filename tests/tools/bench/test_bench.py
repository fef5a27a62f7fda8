#!/usr/bin/env python3
"""`rtk bench` against an independent implementation of the standard recipe
(docs/bench-vs-embree.md).

usage: test_bench.py RTK_EXE SOURCE_ROOT recipe|bunny

recipe: small generated OBJ scenes, every accelerator found, 1 and 2
threads: the counts and primary_ray_hash must equal recipe.py's exactly
(scenes are checked to have no ray too close to call), the hash must be
equal across accelerators, the CSV must hold one row per accelerator x
threads; bad OBJ files must be refused with file:line.
bunny: the shared bunny at 1024x768 (the recipe's reference counts); skipped (77)
without ../shared/data. Nothing here depends on wall-clock speed.
"""
import csv
import os
import re
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import recipe  # noqa: E402

failures = []


def check(ok, what):
    print(("ok    " if ok else "FAIL  ") + what, flush=True)
    if not ok:
        failures.append(what)


def bench(rtk, args, tmp, name):
    out_csv = os.path.join(tmp, name + ".csv")
    cmd = [rtk, "bench"] + args + ["--runs", "1", "--csv", out_csv]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        check(False, "%s: rtk bench exits 0 (%s)" % (name, proc.stderr.strip()))
        return None, proc
    with open(out_csv) as f:
        return list(csv.DictReader(f)), proc


def write(path, text):
    with open(path, "w") as f:
        f.write(text)
    return path


# Floor y = 0 and ceiling y = 1, both 16 x 16; written with every face form.
ROOM = """# floor: a quad, plain indices
v -8 0 -8
v 8 0 -8
v 8 0 8
v -8 0 8
f 1 2 3 4
# ceiling: two triangles, i/j, i//k and negative (relative) indices
v -8 1 -8
v 8 1 -8
v 8 1 8
v -8 1 8
vt 0 0
vn 0 -1 0
f 5/1 7/1 6/1
f -4//1 -2//1 -1//1
"""

# A wall z = 0 covering x in [0, 2]: exactly the right half of a centred view.
WALL = """v 0 -2 0
v 2 -2 0
v 2 2 0
v 0 2 0
f -4/1/1 -3/1/1 -2/1/1 -1/1/1
"""


def compare(rows, expect, name, accelerators):
    check(len(rows) == 2 * len(accelerators) and {r["accelerator"] for r in rows} == set(accelerators)
          and {r["threads"] for r in rows} == {"1", "2"},
          "%s: one CSV row per accelerator x threads (%d rows)" % (name, len(rows)))
    hashes = {r["primary_ray_hash"] for r in rows}
    check(hashes == {"0x%016x" % expect["primary_ray_hash"]},
          "%s: primary_ray_hash equal across accelerators and to recipe.py (%s, expected 0x%016x)"
          % (name, ",".join(sorted(hashes)), expect["primary_ray_hash"]))
    for r in rows:
        tag = "%s [%s, %s threads]" % (name, r["accelerator"], r["threads"])
        got = (int(r["primary_hits"]), int(r["ao_rays"]), int(r["ao_unoccluded"]))
        want = (expect["primary_hits"], expect["ao_rays"], expect["ao_unoccluded"])
        check(got == want, "%s: primary_hits, ao_rays, ao_unoccluded %s == %s" % (tag, got, want))
        mean = expect["ao_unoccluded"] / expect["ao_rays"] if expect["ao_rays"] else 0.0
        check(abs(float(r["mean_ao"]) - mean) <= 1e-6, "%s: mean_ao %s == %.6f" % (tag, r["mean_ao"], mean))
        # Batch passes: rtk bench itself fails when a batch's hits or
        # counts differ from the single rays'; here they were measured.
        check(float(r["primary_batch_mrays"]) > 0 and float(r["ao_batch_mrays"]) > 0
              and 0 <= int(r["primary_packet_rays"])
              and 0 <= int(r["ao_packet_rays"]) <= expect["ao_rays"],
              "%s: batch rows measured (%s, %s Mrays/s; %s and %s rays in packets)"
              % (tag, r["primary_batch_mrays"], r["ao_batch_mrays"], r["primary_packet_rays"], r["ao_packet_rays"]))


def accelerators(rtk):
    """Every accelerator `rtk plugins` lists, less the device accelerators
    that cannot start here, which `rtk bench` leaves out of its default set
    (saying so, checked here)."""
    proc = subprocess.run([rtk, "plugins"], capture_output=True, text=True)
    names = sorted({line.split()[1] for line in proc.stdout.splitlines() if line.startswith("accelerator ")})
    with tempfile.TemporaryDirectory() as tmp:
        wall = write(os.path.join(tmp, "wall.obj"), WALL)
        probe = subprocess.run([rtk, "bench", wall, "--runs", "1", "--threads", "1", "--width", "8", "--height", "8"],
                               capture_output=True, text=True)
    left = set(re.findall(r"bench: leaving out accelerator '([^']+)': ", probe.stderr))
    for name in sorted(left):
        check(name in names and ("'%s'" % name) not in probe.stdout,
              "%s is left out of the default set, saying why (%s)"
              % (name, [ln for ln in probe.stderr.splitlines() if "leaving out" in ln][0].strip()))
    return [n for n in names if n not in left]


def test_recipe(rtk):
    accels = accelerators(rtk)
    check(len(accels) > 0, "accelerators found: %s" % ",".join(accels))
    with tempfile.TemporaryDirectory() as tmp:
        room = write(os.path.join(tmp, "room.obj"), ROOM)
        wall = write(os.path.join(tmp, "wall.obj"), WALL)
        verts, tris = recipe.read_obj(room)
        w, h = 64, 48
        cases = [
            ("room inside", room, ["--camera", "0,0.5,0,0,0,1,40"], recipe.look_camera((0, 0.5, 0), (0, 0, 1), 40.0)),
            ("room, recipe camera", room, [], recipe.recipe_camera(*recipe.bounds(verts))),
        ]
        for name, path, extra, cam in cases:
            expect = recipe.run(verts, tris, cam, w, h)
            check(expect["ambiguous"] == 0, "%s: no ray too close to call (%d)" % (name, expect["ambiguous"]))
            rows, _ = bench(rtk, [path, "--threads", "1,2", "--width", str(w), "--height", str(h)] + extra, tmp,
                            name.replace(" ", "_").replace(",", ""))
            if rows is not None:
                compare(rows, expect, name, accels)
            if name == "room inside":
                check(expect["primary_hits"] == w * h and 0 < expect["ao_unoccluded"] < expect["ao_rays"],
                      "room inside: every pixel hits the floor, the ceiling occludes some AO rays")
        # The wall: counts known without any tracer.
        wv, wt = recipe.read_obj(wall)
        cam = recipe.look_camera((0, 0, 1), (0, 0, 0), 45.0)
        expect = {"primary_ray_hash": recipe.ray_hash(recipe.primary_rays(cam, w, h)), "primary_hits": w * h // 2,
                  "ao_rays": 8 * w * h // 2, "ao_unoccluded": 8 * w * h // 2}
        rows, proc = bench(rtk, [wall, "--threads", "1,2", "--width", str(w), "--height", str(h),
                                 "--camera", "0,0,1,0,0,0,45"], tmp, "wall")
        if rows is not None:
            compare(rows, expect, "wall", accels)
            check("primary_ray_hash 0x%016x" % expect["primary_ray_hash"] in proc.stdout
                  and "primary_hits" in proc.stdout and "mean_ao" in proc.stdout,
                  "wall: the table prints the recipe's keys")
            check("batches: each image row" in proc.stdout, "wall: the batch table is printed")
            usable = len(os.sched_getaffinity(0))
            cpu = re.search(r"^cpu .+, (\d+) cores? this process may use \((\d+) online\)$", proc.stdout, re.M)
            check(cpu is not None and 1 <= int(cpu.group(1)) <= min(usable, int(cpu.group(2))),
                  "wall: the report names the CPU and its usable cores (at most the %d of this affinity mask): %s"
                  % (usable, cpu.group(0) if cpu else "no cpu line"))
            if "embree" in accels and len(accels) > 1:
                check("against embree" in proc.stdout and "batches against embree" in proc.stdout,
                      "wall: ratios to embree printed, single rays and batches")
        # -v: the work counters, known here without a tracer: every ray
        # tests the root node's children; the quad's two triangles (one
        # leaf, or two leaves with the quad's box each) are tested by the
        # half of the primary rays that hit it; AO rays leave the wall.
        proc = subprocess.run([rtk, "bench", wall, "-v", "--runs", "1", "--threads", "1", "--width", str(w),
                               "--height", str(h), "--camera", "0,0,1,0,0,0,45"], capture_output=True, text=True)
        for a in accels:
            want = ("primary 0.000 nodes, 0.000 triangles; AO 0.000 nodes, 0.000 triangles" if a == "embree" else
                    "primary 1.000 nodes, 1.000 triangles; AO 1.000 nodes, 0.000 triangles")
            line = "bench: %s, 1 threads: work per ray: %s" % (a, want)
            check(proc.returncode == 0 and line in proc.stderr, "wall: -v logs %s's work per ray: %s" % (a, want))
        # -v on 1 and 2 threads: each 2-thread row's phases end with its
        # speed-up and CPU time against the 1-thread row, the CSV's figures.
        rows, proc = bench(rtk, [room, "-v", "--threads", "1,2", "--width", "16", "--height", "12"], tmp, "phases")
        if rows is not None:
            for a in accels:
                one = [r for r in rows if r["accelerator"] == a and r["threads"] == "1"][0]
                two = [r for r in rows if r["accelerator"] == a and r["threads"] == "2"][0]
                b1, b2 = float(one["build_ms"]), float(two["build_ms"])
                c1, c2 = float(one["build_cpu_ms"]), float(two["build_cpu_ms"])
                speed, cpu = b1 / b2, c2 / c1
                # a's 2-thread block: its header and the indented lines under it.
                after = proc.stdout.split("\n%s, 2 threads: build" % a, 1)[-1].split("\n")[1:]
                block = "\n".join(ln for ln in after[:next((i for i, ln in enumerate(after)
                                                            if not ln.startswith("  ")), len(after))])
                m = re.search(r"speed-up ([0-9.]+)x over one thread; CPU time ([0-9.]+)x the 1-thread build's "
                              r"\(([0-9.]+) / ([0-9.]+) ms\)", block)
                # Printed to 2 decimals (0.005) from the medians the CSV rounds
                # to 4 (5e-5 each, so a ratio x / y within x / y (5e-5 / x + 5e-5 / y)).
                def near(printed, value, x=None, y=None):
                    slack = value * (5e-5 / x + 5e-5 / y) if x else 5e-5
                    return abs(float(printed) - value) <= 0.005 + slack + 1e-9
                ok = (m is not None and b2 > 0 and c1 > 0 and near(m.group(1), speed, b1, b2)
                      and near(m.group(2), cpu, c2, c1) and near(m.group(3), c2) and near(m.group(4), c1))
                check(ok, "phases: %s on 2 threads reports speed-up %.3f and CPU time %.3f against 1 thread (%s)"
                      % (a, speed, cpu, m.group(0) if m else "no such line"))
        # Bad files are refused with file:line.
        bad = [("f 1 2 9", "bad.obj:4:"), ("v 1 2", "bad.obj:1:"), ("f 1 2", "no triangles"), ("f 1 0 2", "bad.obj:4:"),
               ("f 1 x 2", "bad.obj:4:")]
        for line, where in bad:
            text = ("v 1 2\n" if line == "v 1 2" else "v 0 0 0\nv 1 0 0\nv 0 1 0\n") + line + "\n"
            path = write(os.path.join(tmp, "bad.obj"), text)
            proc = subprocess.run([rtk, "bench", path, "--runs", "1", "--width", "8", "--height", "8"],
                                  capture_output=True, text=True)
            check(proc.returncode == 1 and where in proc.stderr,
                  "'%s' refused at %s (exit %d: %s)" % (line, where, proc.returncode, proc.stderr.strip()))
        proc = subprocess.run([rtk, "bench", wall, "--width", "8"], capture_output=True, text=True)
        check(proc.returncode == 2, "--width without --height is a usage error")
        proc = subprocess.run([rtk, "bench", wall, "--accel", "nosuch"], capture_output=True, text=True)
        check(proc.returncode == 1 and "nosuch" in proc.stderr, "an unknown accelerator is refused")


# The recipe's reference counts, and the hash of the bunny's primary rays at 1024x768
# computed once by recipe.py (pure Python doubles; about ten seconds).
BUNNY_HASH = "0xbc3a6e195057cb77"


def test_bunny(rtk, root):
    bunny = os.path.join(root, "..", "shared", "data", "meshes", "bunny.obj")
    if not os.path.exists(bunny):
        print("skipped: no %s" % bunny)
        sys.exit(77)
    with tempfile.TemporaryDirectory() as tmp:
        rows, _ = bench(rtk, [bunny, "--accel", "median", "--threads", "1"], tmp, "bunny")
        if rows is None:
            return
        r = rows[0]
        check(r["triangles"] == "75408", "bunny: 75,408 triangles (%s)" % r["triangles"])
        check(r["primary_ray_hash"] == BUNNY_HASH, "bunny: primary_ray_hash %s == %s" % (r["primary_ray_hash"],
                                                                                           BUNNY_HASH))
        check(r["primary_hits"] == "83110", "bunny: primary_hits %s == 83110" % r["primary_hits"])
        check(abs(float(r["mean_ao"]) - 0.956132) < 2e-4, "bunny: mean_ao %s ~ 0.956132" % r["mean_ao"])


def main():
    rtk, root, which = sys.argv[1], sys.argv[2], sys.argv[3]
    if which == "recipe":
        test_recipe(rtk)
    else:
        test_bunny(rtk, root)
    print("all checks passed" if not failures else "%d checks failed" % len(failures))
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()

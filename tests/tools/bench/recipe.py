"""An independent implementation of rtk bench's standard recipe in Python
(docs/bench-vs-embree.md).

Python floats are IEEE doubles and are never fused, so the primary rays
below are bit-identical to any correct implementation; `rtk bench` must
print the same primary_ray_hash. Hits are found in double precision
(Moeller-Trumbore); a ray whose answer is too close to call (near a
triangle edge or near tmax) is counted as ambiguous, so that exact
comparisons are made only where every correct tracer must agree.
"""
import math
import struct

AO_RAYS = 8
SEED = 1
MASK64 = (1 << 64) - 1


def read_obj(path):
    """Vertices and fan-triangulated faces, as the recipe reads them."""
    verts, tris = [], []
    with open(path) as f:
        for line in f:
            tok = line.split()
            if not tok:
                continue
            if tok[0] == "v":
                verts.append(tuple(struct.unpack("<f", struct.pack("<f", float(t)))[0] for t in tok[1:4]))
            elif tok[0] == "f":
                idx = []
                for t in tok[1:]:
                    i = int(t.split("/")[0])
                    idx.append(i - 1 if i > 0 else len(verts) + i)
                for k in range(1, len(idx) - 1):
                    tris.append((idx[0], idx[k], idx[k + 1]))
    return verts, tris


def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def normalize(v):
    n = math.sqrt(dot(v, v))
    return (v[0] / n, v[1] / n, v[2] / n)


def bounds(verts):
    lo = tuple(min(v[k] for v in verts) for k in range(3))
    hi = tuple(max(v[k] for v in verts) for k in range(3))
    return lo, hi


def diagonal(lo, hi):
    d = (hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2])
    return math.sqrt(dot(d, d))


def camera_basis(eye, fwd, fov_deg, world_up=(0.0, 1.0, 0.0)):
    right = normalize(cross(fwd, world_up))
    up = cross(right, fwd)
    th = math.tan(0.5 * fov_deg * math.pi / 180.0)
    return eye, fwd, right, up, th


def recipe_camera(lo, hi):
    diag = diagonal(lo, hi)
    d = normalize((1.0, 0.6, 1.4))
    eye = tuple((lo[k] + hi[k]) * 0.5 + 1.6 * diag * d[k] for k in range(3))
    return camera_basis(eye, (-d[0], -d[1], -d[2]), 45.0)


def look_camera(eye, look_at, fov_deg):
    fwd = normalize(tuple(look_at[k] - eye[k] for k in range(3)))
    return camera_basis(tuple(eye), fwd, fov_deg)


def primary_rays(cam, width, height):
    """(origin, direction) as float32 triples, row-major from the top."""
    eye, fwd, right, up, th = cam
    aspect = width / height
    org = tuple(f32(c) for c in eye)
    rays = []
    for y in range(height):
        sy = (1.0 - 2.0 * (y + 0.5) / height) * th
        for x in range(width):
            sx = (2.0 * (x + 0.5) / width - 1.0) * th * aspect
            d = tuple(fwd[k] + sx * right[k] + sy * up[k] for k in range(3))
            d = normalize(d)
            rays.append((org, (f32(d[0]), f32(d[1]), f32(d[2]))))
    return rays


def ray_hash(rays):
    """FNV-1a-64 over the float bits of (ox, oy, oz, dx, dy, dz) of each ray."""
    h = 0xCBF29CE484222325
    for org, d in rays:
        for b in struct.pack("<6f", *org, *d):
            h = ((h ^ b) * 0x100000001B3) & MASK64
    return h


class Pcg32:
    """The reference pcg32_srandom_r / pcg32_random_r."""

    def __init__(self, initstate, initseq):
        self.state = 0
        self.inc = ((initseq << 1) | 1) & MASK64
        self.next()
        self.state = (self.state + initstate) & MASK64
        self.next()

    def next(self):
        old = self.state
        self.state = (old * 6364136223846793005 + self.inc) & MASK64
        xorshifted = (((old >> 18) ^ old) >> 27) & 0xFFFFFFFF
        rot = old >> 59
        return ((xorshifted >> rot) | (xorshifted << ((-rot) & 31))) & 0xFFFFFFFF


def intersect(org, d, a, b, c, tmax, rel=1e-7):
    """(t, ambiguous) of a double-precision ray/triangle test, t None on a miss."""
    e1 = tuple(b[k] - a[k] for k in range(3))
    e2 = tuple(c[k] - a[k] for k in range(3))
    p = cross(d, e2)
    det = dot(e1, p)
    if det == 0.0:
        return None, False
    s = tuple(org[k] - a[k] for k in range(3))
    u = dot(s, p) / det
    q = cross(s, e1)
    v = dot(d, q) / det
    t = dot(e2, q) / det
    w = 1.0 - u - v
    near_edge = min(abs(u), abs(v), abs(w)) < rel
    near_end = t > 0 and abs(t - tmax) < rel * max(1.0, abs(tmax)) * 100
    inside = u >= 0.0 and v >= 0.0 and w >= 0.0 and 0.0 <= t <= tmax
    return (t if inside else None), (near_edge or near_end) and t > 0


def closest(org, d, verts, tris, tmax=math.inf):
    """(t, triangle, ambiguous) of the closest hit; ties count as ambiguous."""
    best, best_i, amb = tmax, None, False
    hits = []
    for i, (ia, ib, ic) in enumerate(tris):
        t, a = intersect(org, d, verts[ia], verts[ib], verts[ic], tmax)
        amb = amb or a
        if t is not None:
            hits.append(t)
            if t < best or best_i is None:
                best, best_i = t, i
    if best_i is not None and sum(1 for t in hits if abs(t - best) <= 1e-6 * abs(best)) > 1:
        amb = True
    return (best if best_i is not None else None), best_i, amb


def ao_rays(org, d, t, tri, verts, diag, pixel):
    """The recipe's AO rays of one hit pixel, as (origin, direction, tfar)."""
    v0, v1, v2 = (verts[i] for i in tri)
    p = tuple(org[k] + t * d[k] for k in range(3))
    n = cross(tuple(v1[k] - v0[k] for k in range(3)), tuple(v2[k] - v0[k] for k in range(3)))
    if math.sqrt(dot(n, n)) == 0.0:
        n = (-d[0], -d[1], -d[2])
    else:
        n = normalize(n)
    if dot(n, d) > 0.0:
        n = (-n[0], -n[1], -n[2])
    sign = math.copysign(1.0, n[2])
    a = -1.0 / (sign + n[2])
    b = n[0] * n[1] * a
    b1 = (1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0])
    b2 = (b, sign + n[1] * n[1] * a, -n[1])
    off = 1e-4 * diag
    o = tuple(f32(p[k] + off * n[k]) for k in range(3))
    tfar = f32(0.1 * diag)
    rng = Pcg32(SEED, pixel)
    out = []
    for _ in range(AO_RAYS):
        u1 = (rng.next() >> 8) * 2.0 ** -24
        u2 = (rng.next() >> 8) * 2.0 ** -24
        r = math.sqrt(u1)
        phi = 2.0 * math.pi * u2
        h = math.sqrt(1.0 - u1)
        dd = tuple(r * math.cos(phi) * b1[k] + r * math.sin(phi) * b2[k] + h * n[k] for k in range(3))
        out.append((o, tuple(f32(c) for c in dd), tfar))
    return out


def run(verts, tris, cam, width, height):
    """Every key of the recipe that does not depend on speed, plus the
    number of ambiguous primary and AO rays."""
    lo, hi = bounds(verts)
    diag = diagonal(lo, hi)
    rays = primary_rays(cam, width, height)
    res = {"primary_ray_hash": ray_hash(rays), "primary_hits": 0, "ao_rays": 0, "ao_unoccluded": 0,
           "ambiguous": 0}
    for i, (org, d) in enumerate(rays):
        t, tri, amb = closest(org, d, verts, tris)
        res["ambiguous"] += amb
        if t is None:
            continue
        res["primary_hits"] += 1
        for o, dd, tfar in ao_rays(org, d, t, tris[tri], verts, diag, i):
            res["ao_rays"] += 1
            t2, _, amb2 = closest(o, dd, verts, tris, tfar)
            res["ambiguous"] += amb2
            res["ao_unoccluded"] += t2 is None
    return res

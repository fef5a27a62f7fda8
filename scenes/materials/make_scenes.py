#!/usr/bin/env python3
"""Writes the assets of scenes/materials/ (python3 standard library only):

  ggx-ramp.gltf     gold spheres at GGX roughness 0.05 .. 0.8 behind glass
                    spheres at 0 .. 0.5 (smooth at +x, the camera's left), on
                    a checkered floor, under an emissive rectangle
  oren-nayar.gltf   two clay spheres, roughness 0 (Lambert) and 1 (Oren-Nayar
                    sigma 1 under whitted), on a grey floor
  environment.gltf  a gold, a glass and a clay sphere on a grey floor
  sky.hdr           128 x 64 equirectangular Radiance HDR: a blue sky gradient
                    over a brown ground and a small bright sun disk

Every file is computed here (this script and its output are rtk's own work,
free to ship with it). The glTF files embed their geometry as base64 data
URIs: one UV sphere (32 x 16 segments) shared by all the spheres of a file.
The written files are committed, so rendering needs no run of this script;
run it (from anywhere) after changing it: python3 scenes/materials/make_scenes.py
"""
import base64
import json
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))

GOLD = [1.0, 0.766, 0.336, 1.0]
GLASS = [1.0, 1.0, 1.0, 1.0]
CLAY = [0.75, 0.42, 0.28, 1.0]


class Gltf:
    """A glTF 2.0 document with one embedded buffer, built up piece by piece."""

    def __init__(self):
        self.data = bytearray()
        self.doc = {"asset": {"version": "2.0", "generator": "rtk scenes/materials/make_scenes.py"},
                    "scene": 0, "scenes": [{"nodes": []}], "nodes": [], "meshes": [],
                    "materials": [], "accessors": [], "bufferViews": []}
        self.extensions = set()

    def _view(self, blob, target):
        while len(self.data) % 4:
            self.data.append(0)
        self.doc["bufferViews"].append({"buffer": 0, "byteOffset": len(self.data), "byteLength": len(blob),
                                        "target": target})
        self.data += blob
        return len(self.doc["bufferViews"]) - 1

    def _accessor(self, view, ctype, count, atype, lo=None, hi=None):
        a = {"bufferView": view, "componentType": ctype, "count": count, "type": atype}
        if lo is not None:
            a["min"], a["max"] = lo, hi
        self.doc["accessors"].append(a)
        return len(self.doc["accessors"]) - 1

    def geometry(self, positions, normals, indices):
        """Accessors for a triangle list; returns the primitive's attributes and indices."""
        pb = b"".join(struct.pack("<3f", *p) for p in positions)
        nb = b"".join(struct.pack("<3f", *n) for n in normals)
        ib = struct.pack("<%dH" % len(indices), *indices)
        lo = [min(p[i] for p in positions) for i in range(3)]
        hi = [max(p[i] for p in positions) for i in range(3)]
        pa = self._accessor(self._view(pb, 34962), 5126, len(positions), "VEC3", lo, hi)
        na = self._accessor(self._view(nb, 34962), 5126, len(normals), "VEC3")
        ia = self._accessor(self._view(ib, 34963), 5123, len(indices), "SCALAR")
        return {"attributes": {"POSITION": pa, "NORMAL": na}, "indices": ia}

    def material(self, name, base, metallic, roughness, transmission=0.0, ior=None, specular=None,
                 emission=None):
        m = {"name": name, "doubleSided": True,
             "pbrMetallicRoughness": {"baseColorFactor": base, "metallicFactor": metallic,
                                      "roughnessFactor": roughness}}
        ext = {}
        if transmission > 0.0:
            ext["KHR_materials_transmission"] = {"transmissionFactor": transmission}
        if ior is not None:
            ext["KHR_materials_ior"] = {"ior": ior}
        if specular is not None:
            ext["KHR_materials_specular"] = {"specularFactor": specular}
        if emission is not None:
            m["emissiveFactor"] = [1.0, 1.0, 1.0]
            ext["KHR_materials_emissive_strength"] = {"emissiveStrength": emission}
        if ext:
            m["extensions"] = ext
            self.extensions.update(ext)
        self.doc["materials"].append(m)
        return len(self.doc["materials"]) - 1

    def mesh(self, name, primitives):
        self.doc["meshes"].append({"name": name, "primitives": primitives})
        return len(self.doc["meshes"]) - 1

    def node(self, name, mesh, translation=(0, 0, 0), scale=1.0):
        self.doc["nodes"].append({"name": name, "mesh": mesh, "translation": list(translation),
                                  "scale": [scale] * 3})
        self.doc["scenes"][0]["nodes"].append(len(self.doc["nodes"]) - 1)

    def write(self, name):
        self.doc["buffers"] = [{"byteLength": len(self.data),
                                "uri": "data:application/octet-stream;base64,"
                                       + base64.b64encode(bytes(self.data)).decode("ascii")}]
        if self.extensions:
            self.doc["extensionsUsed"] = sorted(self.extensions)
        with open(os.path.join(HERE, name), "w") as f:
            json.dump(self.doc, f, separators=(",", ":"))
            f.write("\n")


def uv_sphere(segments=32, rings=16):
    """Unit sphere around the origin; normals = positions; counter-clockwise from outside."""
    pos, idx = [], []
    for j in range(rings + 1):
        theta = math.pi * j / rings
        for i in range(segments + 1):
            phi = 2.0 * math.pi * i / segments
            pos.append((round(math.sin(theta) * math.cos(phi), 6), round(math.cos(theta), 6),
                        round(-math.sin(theta) * math.sin(phi), 6)))
    row = segments + 1
    for j in range(rings):
        for i in range(segments):
            a, b = j * row + i, (j + 1) * row + i
            if j != 0:
                idx += [a, b, a + 1]
            if j != rings - 1:
                idx += [a + 1, b, b + 1]
    return pos, pos, idx


def quads(rects, y, normal_up=True):
    """Axis-aligned rectangles (x0, z0, x1, z1) in the plane y, facing +y (or -y)."""
    pos, nrm, idx = [], [], []
    n = (0.0, 1.0, 0.0) if normal_up else (0.0, -1.0, 0.0)
    for x0, z0, x1, z1 in rects:
        k = len(pos)
        pos += [(x0, y, z0), (x0, y, z1), (x1, y, z1), (x1, y, z0)]
        nrm += [n] * 4
        idx += [k, k + 1, k + 2, k, k + 2, k + 3] if normal_up else [k, k + 2, k + 1, k, k + 3, k + 2]
    return pos, nrm, idx


def checker(half, tiles, parity):
    size = 2.0 * half / tiles
    return [(-half + i * size, -half + j * size, -half + (i + 1) * size, -half + (j + 1) * size)
            for i in range(tiles) for j in range(tiles) if (i + j) % 2 == parity]


def ggx_ramp():
    g = Gltf()
    sphere = g.geometry(*uv_sphere())
    radius = 0.4
    for k, r in enumerate([0.05, 0.15, 0.3, 0.5, 0.8]):
        m = g.material("gold r%.2f" % r, GOLD, 1.0, r)
        g.node("gold r%.2f" % r, g.mesh("gold", [dict(sphere, material=m)]),
               (2.0 - k, radius, 0.6), radius)
    for k, r in enumerate([0.0, 0.1, 0.2, 0.35, 0.5]):
        m = g.material("glass r%.2f" % r, GLASS, 0.0, r, transmission=1.0, ior=1.5)
        g.node("glass r%.2f" % r, g.mesh("glass", [dict(sphere, material=m)]),
               (2.0 - k, radius, -0.6), radius)
    light_tiles = g.material("floor light", [0.7, 0.7, 0.7, 1.0], 0.0, 1.0)
    dark_tiles = g.material("floor dark", [0.15, 0.15, 0.15, 1.0], 0.0, 1.0)
    floor = g.mesh("floor", [dict(g.geometry(*quads(checker(4.0, 16, 0), 0.0)), material=light_tiles),
                             dict(g.geometry(*quads(checker(4.0, 16, 1), 0.0)), material=dark_tiles)])
    g.node("floor", floor)
    # A 2.4 x 1.2 rectangle 3.5 above the floor, over the camera's side of the
    # rows, emitting downwards: each sphere mirrors it above its centre.
    lamp = g.material("lamp", [0.0, 0.0, 0.0, 1.0], 0.0, 1.0, emission=10.0)
    g.node("lamp", g.mesh("lamp", [dict(g.geometry(*quads([(-1.2, -2.6, 1.2, -1.4)], 3.5, False)),
                                        material=lamp)]))
    g.write("ggx-ramp.gltf")


def oren_nayar():
    g = Gltf()
    sphere = g.geometry(*uv_sphere())
    # specular 0: no coat at normal incidence, so the spheres differ only in
    # their diffuse model (whitted takes Oren-Nayar's sigma from roughness).
    smooth = g.material("clay roughness 0", CLAY, 0.0, 0.0, specular=0.0)
    rough = g.material("clay roughness 1", CLAY, 0.0, 1.0, specular=0.0)
    g.node("lambert", g.mesh("lambert", [dict(sphere, material=smooth)]), (1.0, 0.8, 0.0), 0.8)
    g.node("oren-nayar", g.mesh("oren-nayar", [dict(sphere, material=rough)]), (-1.0, 0.8, 0.0), 0.8)
    floor = g.material("floor", [0.5, 0.5, 0.5, 1.0], 0.0, 1.0, specular=0.0)
    g.node("floor", g.mesh("floor", [dict(g.geometry(*quads([(-6.0, -6.0, 6.0, 6.0)], 0.0)), material=floor)]))
    g.write("oren-nayar.gltf")


def environment():
    g = Gltf()
    sphere = g.geometry(*uv_sphere())
    gold = g.material("gold", GOLD, 1.0, 0.2)
    glass = g.material("glass", GLASS, 0.0, 0.0, transmission=1.0, ior=1.5)
    clay = g.material("white clay", [0.8, 0.8, 0.8, 1.0], 0.0, 0.6)
    g.node("gold", g.mesh("gold", [dict(sphere, material=gold)]), (-1.3, 0.6, 0.3), 0.6)
    g.node("glass", g.mesh("glass", [dict(sphere, material=glass)]), (0.0, 0.6, -0.3), 0.6)
    g.node("clay", g.mesh("clay", [dict(sphere, material=clay)]), (1.3, 0.6, 0.3), 0.6)
    floor = g.material("floor", [0.5, 0.5, 0.5, 1.0], 0.0, 1.0)
    g.node("floor", g.mesh("floor", [dict(g.geometry(*quads([(-200.0, -200.0, 200.0, 200.0)], 0.0)), material=floor)]))
    g.write("environment.gltf")


def rgbe(r, g, b):
    m = max(r, g, b)
    if m < 1e-32:
        return b"\0\0\0\0"
    mant, e = math.frexp(m)
    s = mant * 256.0 / m
    return bytes((int(r * s), int(g * s), int(b * s), e + 128))


# The sun: direction towards it (y up; rtk's map puts -z at the image centre,
# +x to its right), angular radius, and the irradiance it gives a surface
# facing it: 8, or 4 on the floor, where the sky gives 1.2.
SUN_DIR = (-0.8, 0.5, -0.35)
SUN_RADIUS = math.radians(3.5)
SUN_IRRADIANCE = 8.0


def sky_hdr(width=128, height=64):
    """Equirectangular sky in rtk's convention: u = 1/2 + atan2(x, -z) / 2 pi, v = acos(y) / pi."""
    n = math.sqrt(sum(c * c for c in SUN_DIR))
    sun = tuple(c / n for c in SUN_DIR)
    sub = 8
    pixels, sun_cover = [], []
    for j in range(height):
        for i in range(width):
            col, cover = [0.0, 0.0, 0.0], 0.0
            for sj in range(sub):
                for si in range(sub):
                    u = (i + (si + 0.5) / sub) / width
                    v = (j + (sj + 0.5) / sub) / height
                    theta, phi = v * math.pi, (u - 0.5) * 2.0 * math.pi
                    d = (math.sin(theta) * math.sin(phi), math.cos(theta), -math.sin(theta) * math.cos(phi))
                    if d[1] >= 0.0:
                        t = d[1] ** 0.5
                        c = (0.275 + 0.025 * t, 0.325 + 0.075 * t, 0.4 + 0.175 * t)
                        cover += math.acos(max(-1.0, min(1.0, sum(a * b for a, b in zip(d, sun))))) < SUN_RADIUS
                    else:
                        c = (0.15, 0.135, 0.12)
                    col = [a + b for a, b in zip(col, c)]
            pixels.append([c / (sub * sub) for c in col])
            sun_cover.append(cover / (sub * sub))
    # Sun radiance so that its pixels' solid angle gives SUN_IRRADIANCE.
    solid = sum(cov * (2.0 * math.pi / width) * (math.pi / height) * math.sin(math.pi * ((k // width) + 0.5) / height)
                for k, cov in enumerate(sun_cover))
    radiance = SUN_IRRADIANCE / solid
    warm = (1.0, 0.92, 0.8)
    for k, cov in enumerate(sun_cover):
        if cov > 0.0:
            pixels[k] = [p * (1.0 - cov) + cov * radiance * w for p, w in zip(pixels[k], warm)]
    with open(os.path.join(HERE, "sky.hdr"), "wb") as f:
        f.write(b"#?RADIANCE\n# rtk scenes/materials/make_scenes.py: sky gradient and sun disk\n"
                b"FORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (height, width))
        for p in pixels:
            f.write(rgbe(*p))


if __name__ == "__main__":
    ggx_ramp()
    oren_nayar()
    environment()
    sky_hdr()

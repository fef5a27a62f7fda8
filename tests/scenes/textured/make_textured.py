#!/usr/bin/env python3
"""Writes tests/scenes/textured/ (python3 standard library only): a scene
whose every surface reads textures, for device programs' tests.

  textured.obj, textured.mtl
      a 2 x 2 floor (y = 0, texture coordinates 0..3: repeating) whose
      colour, tangent-space normal map, roughness and metalness are images
      (metallic-roughness mapping); a smooth ball (corner normals) with a
      clamped colour map, a normal map and an MTL shininess map (Phong);
      a lamp above (y = 1.2, facing down) whose emission is an image
  checker.ppm, bumps.ppm, rough.ppm, metal.ppm, shiny.ppm, stripes.ppm
      the images, binary PPM
  mapped.gltf, mapped.bin, grid.png, bands.png
      what OBJ cannot say: a double-sided floor (4 x 4 quads) whose base
      colour reads TEXCOORD_0 through a KHR_texture_transform (offset,
      rotation, scale) and whose emission reads TEXCOORD_1 through another,
      and a wall whose base colour reads TEXCOORD_1 untransformed, with
      repeat and mirrored-repeat wrapping

Every file is computed here (this script and its output are rtk's own
work, free to ship with it). Run it in this folder to write them again.
"""
import base64
import json
import math
import struct
import zlib


def ppm(name, n, texel):
    """An n x n image whose texel at (u, v) in [0, 1) is texel(u, v)."""
    px = bytearray()
    for y in range(n):
        for x in range(n):
            px += bytes(max(0, min(255, int(255 * c + 0.5))) for c in texel(x / n, y / n))
    with open(name, "wb") as f:
        f.write(b"P6 %d %d 255\n" % (n, n) + px)


def png(name, n, texel):
    """An n x n RGB PNG whose texel at (u, v) in [0, 1) is texel(u, v)."""
    rows = b""
    for y in range(n):
        rows += b"\0" + bytes(max(0, min(255, int(255 * c + 0.5))) for x in range(n) for c in texel(x / n, y / n))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    with open(name, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", n, n, 8, 2, 0, 0, 0)) +
                chunk(b"IDAT", zlib.compress(rows, 9)) + chunk(b"IEND", b""))


def mapped():
    """mapped.gltf and its buffer and images (see the module's summary)."""
    png("grid.png", 32, lambda u, v: (0.9, 0.8, 0.2) if (int(8 * u) + int(8 * v)) % 2 else (0.1, 0.3, 0.7))
    png("bands.png", 16, lambda u, v: (1.0, 0.5, 0.3) if int(4 * (u + v)) % 2 else (0.2, 0.2, 0.2))
    pos, uv0, uv1, idx = [], [], [], []
    n = 4
    for j in range(n + 1):  # the floor, y = 0, x and z in [-1.5, 1.5]
        for i in range(n + 1):
            pos.append((-1.5 + 3.0 * i / n, 0.0, -1.5 + 3.0 * j / n))
            uv0.append((2.0 * i / n, 2.0 * j / n))
            uv1.append((1.0 * j / n, 1.0 - 1.0 * i / n))
    for j in range(n):
        for i in range(n):
            a, b = j * (n + 1) + i, j * (n + 1) + i + 1
            c, d = a + n + 1, b + n + 1
            idx += [a, c, b, b, c, d]
    floor = len(idx)
    w = len(pos)  # the wall, z = 1.2, x in [-1.2, 1.2], y in [0, 1.4]
    for x, y in ((-1.2, 0.0), (1.2, 0.0), (1.2, 1.4), (-1.2, 1.4)):
        pos.append((x, y, 1.2))
        uv0.append((0.0, 0.0))
        uv1.append(((x + 1.2) / 0.8, 1.4 - y))
    idx += [w, w + 2, w + 1, w, w + 3, w + 2]
    blob = b"".join(struct.pack("<3f", *p) for p in pos)
    views = [(0, len(blob))]
    for data, fmt in ((uv0, "<2f"), (uv1, "<2f")):
        start = len(blob)
        blob += b"".join(struct.pack(fmt, *t) for t in data)
        views.append((start, len(blob) - start))
    start = len(blob)
    blob += struct.pack("<%dH" % len(idx), *idx)
    views.append((start, len(blob) - start))
    with open("mapped.bin", "wb") as f:
        f.write(blob)
    lo = [min(p[k] for p in pos) for k in range(3)]
    hi = [max(p[k] for p in pos) for k in range(3)]
    accessors = [{"bufferView": 0, "componentType": 5126, "count": len(pos), "type": "VEC3", "min": lo, "max": hi},
                 {"bufferView": 1, "componentType": 5126, "count": len(pos), "type": "VEC2"},
                 {"bufferView": 2, "componentType": 5126, "count": len(pos), "type": "VEC2"},
                 {"bufferView": 3, "byteOffset": 0, "componentType": 5123, "count": floor, "type": "SCALAR"},
                 {"bufferView": 3, "byteOffset": 2 * floor, "componentType": 5123, "count": 6, "type": "SCALAR"}]
    attributes = {"POSITION": 0, "TEXCOORD_0": 1, "TEXCOORD_1": 2}
    doc = {
        "asset": {"version": "2.0", "generator": "rtk tests/scenes/textured/make_textured.py"},
        "extensionsUsed": ["KHR_texture_transform"],
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": attributes, "indices": 3, "material": 0},
                                   {"attributes": attributes, "indices": 4, "material": 1}]}],
        "materials": [
            {"name": "floor", "doubleSided": True,
             "pbrMetallicRoughness": {
                 "baseColorTexture": {"index": 0, "extensions": {"KHR_texture_transform": {
                     "offset": [0.1, 0.2], "rotation": 0.4, "scale": [2.5, 1.5]}}},
                 "metallicFactor": 0.0, "roughnessFactor": 0.8},
             "emissiveFactor": [0.6, 0.6, 0.6],
             "emissiveTexture": {"index": 1, "texCoord": 1, "extensions": {"KHR_texture_transform": {
                 "offset": [0.3, 0.0], "scale": [3.0, 2.0]}}}},
            {"name": "wall", "doubleSided": True,
             "pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "texCoord": 1},
                                      "metallicFactor": 0.0, "roughnessFactor": 0.5}}],
        "textures": [{"source": 0, "sampler": 0}, {"source": 1, "sampler": 1}],
        "images": [{"uri": "grid.png"}, {"uri": "bands.png"}],
        "samplers": [{"wrapS": 10497, "wrapT": 33648}, {"wrapS": 10497, "wrapT": 10497}],
        "accessors": accessors,
        "bufferViews": [{"buffer": 0, "byteOffset": o, "byteLength": l} for o, l in views],
        "buffers": [{"uri": "mapped.bin", "byteLength": len(blob)}],
    }
    with open("mapped.gltf", "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")


def main():
    ppm("checker.ppm", 16, lambda u, v: (0.9, 0.3, 0.2) if (int(4 * u) + int(4 * v)) % 2 else (0.2, 0.5, 0.9))
    ppm("bumps.ppm", 16, lambda u, v: (0.5 + 0.35 * math.sin(6.28 * u), 0.5 + 0.35 * math.cos(6.28 * v), 0.85))
    ppm("rough.ppm", 8, lambda u, v: (u, 0.1 + 0.8 * v, 0.5))
    ppm("metal.ppm", 8, lambda u, v: (1.0,) * 3 if u > 0.5 else (0.0,) * 3)
    ppm("shiny.ppm", 8, lambda u, v: (v,) * 3)
    ppm("stripes.ppm", 8, lambda u, v: (1.0, 0.8, 0.5) if int(4 * u) % 2 else (0.3, 0.4, 1.0))
    o = ["# tests/scenes/textured: written by make_textured.py", "mtllib textured.mtl",
         "v -1 0 -1", "v 1 0 -1", "v 1 0 1", "v -1 0 1",
         "vt 0 0", "vt 3 0", "vt 3 3", "vt 0 3", "vn 0 1 0", "usemtl floor",
         "f 1/1/1 3/3/1 2/2/1", "f 1/1/1 4/4/1 3/3/1",
         "v -0.4 1.2 -0.4", "v 0.4 1.2 -0.4", "v 0.4 1.2 0.4", "v -0.4 1.2 0.4",
         "vt 0 0", "vt 1 0", "vt 1 1", "vt 0 1", "vn 0 -1 0", "usemtl lamp",
         "f 5/5/2 6/6/2 7/7/2", "f 5/5/2 7/7/2 8/8/2"]
    # The ball: vertex k (from 9) has texture coordinate k - 4 and normal k - 6.
    nu, nv, first = 16, 8, 9
    for j in range(nv + 1):
        for i in range(nu + 1):
            t, p = math.pi * j / nv, 2 * math.pi * i / nu
            x, y, z = math.sin(t) * math.cos(p), math.cos(t), math.sin(t) * math.sin(p)
            o += [f"v {0.35 * x:.6f} {0.35 * y + 0.4:.6f} {0.35 * z:.6f}",
                  f"vt {1.4 * i / nu - 0.2:.6f} {j / nv:.6f}", f"vn {x:.6f} {y:.6f} {z:.6f}"]
    o.append("usemtl ball")
    k = lambda i, j: first + j * (nu + 1) + i
    corner = lambda q: f"{q}/{q - 4}/{q - 6}"
    for j in range(nv):
        for i in range(nu):
            a, b, c, e = k(i, j), k(i + 1, j), k(i, j + 1), k(i + 1, j + 1)
            if j > 0:  # not at the top pole, where a and b meet
                o.append(f"f {corner(a)} {corner(c)} {corner(b)}")
            if j < nv - 1:  # nor at the bottom one
                o.append(f"f {corner(b)} {corner(c)} {corner(e)}")
    with open("textured.obj", "w") as f:
        f.write("\n".join(o) + "\n")
    with open("textured.mtl", "w") as f:
        f.write("# tests/scenes/textured: written by make_textured.py\n"
                "newmtl floor\nKd 1 1 1\nPr 1\nPm 1\nmap_Kd checker.ppm\nnorm bumps.ppm\n"
                "map_Pr rough.ppm\nmap_Pm metal.ppm\n"
                "newmtl ball\nKd 0.9 0.9 0.9\nKs 0.3 0.3 0.3\nNs 60\nillum 2\nmap_Kd -clamp on checker.ppm\n"
                "map_Ns shiny.ppm\nnorm bumps.ppm\n"
                "newmtl lamp\nKd 0 0 0\nKe 3 3 3\nmap_Ke stripes.ppm\n")
    mapped()


if __name__ == "__main__":
    main()

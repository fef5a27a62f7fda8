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

Every file is computed here (this script and its output are rtk's own
work, free to ship with it). Run it in this folder to write them again.
"""
import math


def ppm(name, n, texel):
    """An n x n image whose texel at (u, v) in [0, 1) is texel(u, v)."""
    px = bytearray()
    for y in range(n):
        for x in range(n):
            px += bytes(max(0, min(255, int(255 * c + 0.5))) for c in texel(x / n, y / n))
    with open(name, "wb") as f:
        f.write(b"P6 %d %d 255\n" % (n, n) + px)


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


if __name__ == "__main__":
    main()

/* Tangent-space normal maps (kernel/scene/normalmap.c) through rtk_surface_at:
 * a quad whose normal map holds one direction n_ts gets the shading
 * normal T x + B y + N z, exactly, with T along +u and B towards the top
 * of the image (OpenGL convention); rotated and mirrored uv mappings turn
 * the frame with them; the back side sees the mirror of the front; a grey
 * image given as map_bump is a height map, warned about and ignored. */
#include "config/config.h"
#include "render/render.h"
#include "image/image.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"

static char tmpdir[256];

static void write_map(const char *name, float r, float g, float b)
{
    float px[4 * 4 * 4];
    for (int i = 0; i < 16; i++)
        px[4 * i] = r, px[4 * i + 1] = g, px[4 * i + 2] = b, px[4 * i + 3] = 1.0f;
    char path[512];
    snprintf(path, sizeof path, "%s/%s", tmpdir, name);
    const char *names[4] = {"R", "G", "B", "A"};
    check(rtk_image_write(path, 4, 4, 4, names, px, 0) == RTK_OK, "wrote %s", name);
}

/* A unit quad at z = 0 (front +z) whose uv corners are given; material
 * with `keyword map`. */
static rtk_scene *quad(const char *keyword, const char *map, const float uv[4][2])
{
    char path[512];
    snprintf(path, sizeof path, "%s/q.mtl", tmpdir);
    FILE *f = fopen(path, "w");
    fprintf(f, "newmtl m\nKd 1 1 1\n%s %s\n", keyword, map);
    fclose(f);
    snprintf(path, sizeof path, "%s/q.obj", tmpdir);
    f = fopen(path, "w");
    fprintf(f, "mtllib q.mtl\nusemtl m\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n");
    for (int k = 0; k < 4; k++)
        fprintf(f, "vt %g %g\n", uv[k][0], uv[k][1]);
    fprintf(f, "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n");
    fclose(f);
    rtk_scene *s = NULL;
    if (rtk_scene_load(path, RTK_NEED_NORMALS | RTK_NEED_TEXTURES, &s) != RTK_OK) {
        check(0, "load: %s", rtk_error_message());
        return NULL;
    }
    return s;
}

/* Shading normal seen by a ray at (0.3, 0.6) from above (or below). */
static rtk_vec3 shade(const rtk_scene *s, int below, int *front)
{
    rtk_ray r = {{0.3f, 0.6f, below ? -1.0f : 1.0f}, 0.0f, {0.0f, 0.0f, below ? 1.0f : -1.0f}, INFINITY};
    rtk_hit h = {0.0f, 0.0f, 0.0f, RTK_INVALID_ID, RTK_INVALID_ID};
    /* Brute force over the two triangles: no BVH needed. */
    for (uint32_t i = 0; i < s->triangle_count; i++) {
        rtk_vec3 a, b, c;
        rtk_scene_triangle(s, i, &a, &b, &c);
        float t, u, v;
        if (rtk_intersect_triangle(&r, a, b, c, &t, &u, &v))
            h.t = t, h.u = u, h.v = v, h.prim = i;
    }
    rtk_surface sf;
    rtk_surface_at(s, &r, &h, &sf);
    *front = sf.front_face;
    return sf.ns;
}

static int near3(rtk_vec3 a, double x, double y, double z)
{
    /* Texel values are exact floats; the frame and normalisation add a
     * few float roundings. */
    return fabs(a.x - x) < 1e-6 && fabs(a.y - y) < 1e-6 && fabs(a.z - z) < 1e-6;
}

int main(void)
{
    setvbuf(stdout, NULL, _IOLBF, 0);
    snprintf(tmpdir, sizeof tmpdir, "/tmp/rtk-normalmap-XXXXXX");
    if (!mkdtemp(tmpdir)) {
        printf("FAIL  cannot make a temporary directory\n");
        return 1;
    }
    /* n_ts = (sin 30, 0, cos 30) and (0, sin 30, cos 30), stored (n + 1) / 2. */
    const double sn = 0.5, cs = sqrt(3.0) / 2.0;
    write_map("tilt_x.exr", (float)((sn + 1) / 2), 0.5f, (float)((cs + 1) / 2));
    write_map("tilt_y.exr", 0.5f, (float)((sn + 1) / 2), (float)((cs + 1) / 2));
    write_map("grey.exr", 0.5f, 0.5f, 0.5f);
    /* The map's texels are floats of (n + 1) / 2: the expected normal is
     * what they decode to. */
    const double ex = 2.0 * (double)(float)((sn + 1) / 2) - 1.0, ez = 2.0 * (double)(float)((cs + 1) / 2) - 1.0;
    const double el = sqrt(ex * ex + ez * ez);

    const float plain[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};      /* u along +x, v along +y */
    const float turned[4][2] = {{0, 1}, {0, 0}, {1, 0}, {1, 1}};     /* u along +y, v along -x */
    const float mirrored[4][2] = {{1, 0}, {0, 0}, {0, 1}, {1, 1}};   /* u along -x, v along +y */
    int front;

    rtk_scene *s = quad("norm", "tilt_x.exr", plain);
    if (s) {
        rtk_vec3 n = shade(s, 0, &front);
        check(near3(n, ex / el, 0, ez / el), "x tilt, plain uvs: ns (%.7f, %.7f, %.7f) leans to +x (+u)", n.x, n.y, n.z);
        n = shade(s, 1, &front);
        check(!front && near3(n, -ex / el, 0, -ez / el),
              "x tilt seen from below: ns (%.7f, %.7f, %.7f) is the mirror of the front", n.x, n.y, n.z);
        rtk_scene_free(s);
    }
    s = quad("norm", "tilt_y.exr", plain);
    if (s) {
        rtk_vec3 n = shade(s, 0, &front);
        check(near3(n, 0, ex / el, ez / el), "y tilt (green): ns (%.7f, %.7f, %.7f) leans to +y, the image's top",
              n.x, n.y, n.z);
        rtk_scene_free(s);
    }
    s = quad("norm", "tilt_x.exr", turned);
    if (s) {
        rtk_vec3 n = shade(s, 0, &front);
        check(near3(n, 0, ex / el, ez / el), "x tilt, uvs turned (u along +y): ns (%.7f, %.7f, %.7f) leans to +y", n.x,
              n.y, n.z);
        rtk_scene_free(s);
    }
    s = quad("norm", "tilt_y.exr", mirrored);
    if (s) {
        rtk_vec3 n = shade(s, 0, &front);
        check(near3(n, 0, ex / el, ez / el), "y tilt, uvs mirrored in u: ns (%.7f, %.7f, %.7f) still leans to +y", n.x,
              n.y, n.z);
        rtk_scene_free(s);
    }
    s = quad("norm", "tilt_x.exr", mirrored);
    if (s) {
        rtk_vec3 n = shade(s, 0, &front);
        check(near3(n, -ex / el, 0, ez / el), "x tilt, uvs mirrored in u: ns (%.7f, %.7f, %.7f) leans to -x (+u)", n.x,
              n.y, n.z);
        rtk_scene_free(s);
    }
    s = quad("map_bump", "grey.exr", plain);
    if (s) {
        rtk_vec3 n = shade(s, 0, &front);
        check(near3(n, 0, 0, 1) && s->textures[s->materials[0].normal_tex].normal_map_checked == -1,
              "a grey map_bump is a height map: ignored (ns (%.7f, %.7f, %.7f))", n.x, n.y, n.z);
        rtk_scene_free(s);
    }
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmpdir);
    if (system(cmd) != 0)
        printf("note  could not remove %s\n", tmpdir);
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}

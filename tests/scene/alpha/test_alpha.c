/* Alpha cutouts in traversal (kernel/scene/alpha.c, kernel/accel/):
 * - a quad with a checkerboard coverage texture (map_d; RGBA alpha or a
 *   grey mask) lets rays through exactly in the cut-out cells, for closest
 *   and any hit, on every traversal path this CPU runs;
 * - closest hits equal a brute-force oracle that walks every triangle the
 *   ray meets, nearest first, to the first one opaque at its hit point:
 *   on the quad, on a stack of cut quads, and on smallpine (glTF BLEND
 *   foliage atlas) when ../shared/data is there;
 * - scenes without cutout materials keep no materials or uvs for it. */
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

#define TEX 64
#define CELL 8

/* Checker cell of texel (x, row): opaque when even. */
static int cell_opaque(double x, double row)
{
    return (((int)floor(x / CELL) + (int)floor(row / CELL)) & 1) == 0;
}

static void write_texture(const char *name, int grey)
{
    float *px = malloc(sizeof(float) * 4 * TEX * TEX);
    for (int y = 0; y < TEX; y++)
        for (int x = 0; x < TEX; x++) {
            float a = cell_opaque(x + 0.5, y + 0.5) ? 1.0f : 0.0f;
            float *p = px + 4 * (y * TEX + x);
            /* RGBA: green texels with the coverage in alpha; grey: the
             * coverage in every colour channel and alpha 1. */
            p[0] = grey ? a : 0.1f, p[1] = grey ? a : 0.8f, p[2] = grey ? a : 0.1f, p[3] = grey ? 1.0f : a;
        }
    char path[512];
    snprintf(path, sizeof path, "%s/%s", tmpdir, name);
    const char *names[4] = {"R", "G", "B", "A"};
    rtk_status st = rtk_image_write(path, TEX, TEX, 4, names, px, 0);
    check(st == RTK_OK, "wrote %s", name);
    free(px);
}

/* quads.obj: `layers` unit quads at z = 0, -1, -2, ... each with the
 * checker of tex, the later ones shifted by half a cell in u so that
 * a ray through a cut cell meets an opaque cell further on. */
static void write_obj(const char *name, const char *tex, int layers)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s.mtl", tmpdir, name);
    FILE *f = fopen(path, "w");
    fprintf(f, "newmtl cut\nKd 1 1 1\nmap_Kd %s\nmap_d %s\n", tex, tex);
    fclose(f);
    snprintf(path, sizeof path, "%s/%s.obj", tmpdir, name);
    f = fopen(path, "w");
    fprintf(f, "mtllib %s.mtl\nusemtl cut\n", name);
    for (int l = 0; l < layers; l++) {
        double du = l * 0.5 * CELL / TEX;
        fprintf(f, "v 0 0 %d\nv 1 0 %d\nv 1 1 %d\nv 0 1 %d\n", -l, -l, -l, -l);
        fprintf(f, "vt %g 0\nvt %g 0\nvt %g 1\nvt %g 1\n", du, 1 + du, 1 + du, du);
        fprintf(f, "f %d/%d %d/%d %d/%d\nf %d/%d %d/%d %d/%d\n", 4 * l + 1, 4 * l + 1, 4 * l + 2, 4 * l + 2, 4 * l + 3,
                4 * l + 3, 4 * l + 1, 4 * l + 1, 4 * l + 3, 4 * l + 3, 4 * l + 4, 4 * l + 4);
    }
    fclose(f);
}

/* The oracle: of the triangles the ray meets (rtk_intersect_triangle, as
 * traversal), the nearest opaque at its hit; equal t to the lowest id. */
static int oracle(const rtk_scene *s, const rtk_ray *ray, rtk_hit *out)
{
    out->prim = RTK_INVALID_ID;
    out->t = ray->tmax;
    for (uint32_t i = 0; i < s->triangle_count; i++) {
        rtk_vec3 a, b, c;
        rtk_scene_triangle(s, i, &a, &b, &c);
        float t, u, v;
        if (!rtk_intersect_triangle(ray, a, b, c, &t, &u, &v) || !rtk_alpha_opaque(s, ray, i, u, v))
            continue;
        if (t < out->t || (t == out->t && i < out->prim))
            out->t = t, out->u = u, out->v = v, out->prim = i;
    }
    return out->prim != RTK_INVALID_ID;
}

static const rtk_simd_path paths[] = {RTK_SIMD_BINARY, RTK_SIMD_SCALAR, RTK_SIMD_SSE, RTK_SIMD_AVX2, RTK_SIMD_AVX512};

/* Every path against the oracle on rays from gen; returns mismatches. */
typedef rtk_ray (*ray_gen)(int i, void *data);

static void against_oracle(rtk_scene *s, const char *what, int count, ray_gen gen, void *data)
{
    rtk_simd_path saved = s->wide ? s->wide->path : RTK_SIMD_BINARY;
    for (size_t p = 0; p < RTK_COUNTOF(paths); p++) {
        if (paths[p] != RTK_SIMD_BINARY && (!s->wide || !rtk_simd_supported(paths[p])))
            continue;
        if (s->wide)
            s->wide->path = paths[p];
        int bad = 0, hits = 0;
        for (int i = 0; i < count; i++) {
            rtk_ray r = gen(i, data);
            rtk_hit h, o;
            int th = rtk_bvh_closest(s, &r, &h), oh = oracle(s, &r, &o), any = rtk_bvh_any(s, &r);
            hits += oh;
            if (th != oh || any != oh || (oh && (h.prim != o.prim || h.t != o.t))) {
                if (bad++ < 3)
                    printf("      ray %d: traversal %s %u t %g, any %d; oracle %s %u t %g\n", i, th ? "hit" : "miss",
                           th ? h.prim : 0, th ? h.t : 0.0, any, oh ? "hit" : "miss", oh ? o.prim : 0, oh ? o.t : 0.0);
            }
        }
        check(bad == 0, "%s, %s traversal: %d rays (%d hits) as the oracle, closest and any", what,
              rtk_simd_name(paths[p]), count, hits);
    }
    if (s->wide)
        s->wide->path = saved;
}

typedef struct grid_data {
    int n;
} grid_data;

/* Rays straight down -z through a grid of points on the unit square. */
static rtk_ray grid_ray(int i, void *data)
{
    int n = ((grid_data *)data)->n;
    rtk_ray r = {{(float)((i % n) + 0.5) / n, (float)((i / n) + 0.5) / n, 2.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, INFINITY};
    return r;
}

/* Oblique rays from random points above into random points of the quad. */
static rtk_ray oblique_ray(int i, void *data)
{
    (void)data;
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 42, (uint64_t)i);
    float tx = rtk_pcg32_float(&rng), ty = rtk_pcg32_float(&rng);
    rtk_ray r = {{rtk_pcg32_float(&rng) * 3 - 1, rtk_pcg32_float(&rng) * 3 - 1, 1.5f}, 0.0f, {0, 0, 0}, INFINITY};
    r.dir = rtk_vec3_make(tx - r.org.x, ty - r.org.y, -1.5f);
    return r;
}

static const rtk_plugin *builder;
static rtk_params *builder_params;

static rtk_scene *load_built(const char *path, uint32_t needs)
{
    rtk_scene *s = NULL;
    if (rtk_scene_load(path, needs, &s) != RTK_OK) {
        check(0, "load %s: %s", path, rtk_error_message());
        return NULL;
    }
    if (rtk_bvh_build(s, builder, builder_params, 2) != RTK_OK) {
        check(0, "build %s: %s", path, rtk_error_message());
        rtk_scene_free(s);
        return NULL;
    }
    return s;
}

static void test_checker(const char *tex, const char *label)
{
    char path[512];
    write_obj("quad", tex, 1);
    snprintf(path, sizeof path, "%s/quad.obj", tmpdir);
    /* Headlight-like needs (normals only): the cutout alone keeps uvs,
     * materials and the one alpha texture. */
    rtk_scene *s = load_built(path, RTK_NEED_NORMALS);
    if (!s)
        return;
    check(s->has_cutouts && s->uvs && s->tri_material, "%s: the scene knows its cutouts (uvs and materials kept)",
          label);
    /* Exactly the cut cells let rays through: points more than a texel
     * away from any cell edge (bilinear filtering blends within one). */
    int n = 256, wrong = 0, checked = 0, through = 0;
    for (int i = 0; i < n * n; i++) {
        double px = ((i % n) + 0.5) / n, py = ((i / n) + 0.5) / n;
        double x = px * TEX, row = (1.0 - py) * TEX; /* OBJ v is up; the texture's row 0 is the top */
        double ex = fmod(x, CELL), ey = fmod(row, CELL);
        if (ex < 1.0 || ex > CELL - 1.0 || ey < 1.0 || ey > CELL - 1.0)
            continue;
        rtk_ray r = {{(float)px, (float)py, 1.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, INFINITY};
        rtk_hit h;
        int hit = rtk_bvh_closest(s, &r, &h), occluded = rtk_bvh_any(s, &r);
        checked++;
        through += !hit;
        wrong += hit != cell_opaque(x, row) || occluded != hit;
    }
    check(wrong == 0 && through > checked / 3 && through < 2 * checked / 3,
          "%s: %d of %d rays pass exactly where the checker is cut (%d through)", label, checked - wrong, checked,
          through);
    grid_data g = {300};
    against_oracle(s, label, g.n * g.n, grid_ray, &g);
    rtk_scene_free(s);
}

static void test_stack(void)
{
    char path[512];
    write_obj("stack", "rgba.exr", 3);
    snprintf(path, sizeof path, "%s/stack.obj", tmpdir);
    rtk_scene *s = load_built(path, 0);
    if (!s)
        return;
    against_oracle(s, "three cut quads, shifted", 40000, oblique_ray, NULL);
    rtk_scene_free(s);
}

static void test_opaque_keeps_nothing(void)
{
    char path[512];
    snprintf(path, sizeof path, "%s/plain.obj", tmpdir);
    FILE *f = fopen(path, "w");
    fputs("mtllib plain.mtl\nusemtl a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n", f);
    fclose(f);
    snprintf(path, sizeof path, "%s/plain.mtl", tmpdir);
    f = fopen(path, "w");
    fputs("newmtl a\nKd 1 0 0\nmap_Kd rgba.exr\n", f);
    fclose(f);
    snprintf(path, sizeof path, "%s/plain.obj", tmpdir);
    rtk_scene *s = NULL;
    rtk_status st = rtk_scene_load(path, RTK_NEED_NORMALS, &s);
    check(st == RTK_OK && !s->has_cutouts && !s->uvs && !s->tri_material && !s->textures[0].decoded,
          "no cutout material: no uvs, materials or decoded textures kept for a normals-only integrator");
    rtk_scene_free(s);
}

typedef struct pine_data {
    rtk_bounds b;
} pine_data;

/* Rays across smallpine's bounds from the front, in a grid. */
static rtk_ray pine_ray(int i, void *data)
{
    const rtk_bounds *b = &((pine_data *)data)->b;
    int n = 200;
    float x = b->lower.x + (b->upper.x - b->lower.x) * ((i % n) + 0.5f) / n;
    float y = b->lower.y + (b->upper.y - b->lower.y) * ((i / n) + 0.5f) / n;
    float z = b->upper.z + (b->upper.z - b->lower.z);
    rtk_ray r = {{x, y, z}, 0.0f, {0.05f, -0.02f, -1.0f}, INFINITY};
    return r;
}

static void test_smallpine(void)
{
    const char *path = RTK_SOURCE_ROOT "/../shared/data/gltf/smallpine/scene.gltf";
    if (access(path, R_OK) != 0) {
        printf("skip  smallpine: %s not found (../shared/data is absent)\n", path);
        return;
    }
    rtk_scene *s = load_built(path, RTK_NEED_NORMALS);
    if (!s)
        return;
    uint32_t decoded = 0;
    for (uint32_t i = 0; i < s->texture_count; i++)
        decoded += s->textures[i].decoded && !s->textures[i].missing;
    check(s->has_cutouts && decoded == 1, "smallpine: the foliage (BLEND with a texture) cuts out; %u of %u textures "
          "decoded for a normals-only integrator (the atlas's alpha)", decoded, s->texture_count);
    pine_data d = {s->bounds};
    against_oracle(s, "smallpine", 200 * 200, pine_ray, &d);
    /* The cutouts matter: fewer rays stop than with solid foliage. */
    int stop_cut = 0, stop_solid = 0;
    for (int i = 0; i < 200 * 200; i++) {
        rtk_ray r = pine_ray(i, &d);
        stop_cut += rtk_bvh_any(s, &r);
    }
    s->has_cutouts = 0;
    for (int i = 0; i < 200 * 200; i++) {
        rtk_ray r = pine_ray(i, &d);
        stop_solid += rtk_bvh_any(s, &r);
    }
    check(stop_cut < stop_solid, "smallpine: %d rays stop with cutouts, %d with solid foliage", stop_cut, stop_solid);
    /* ... and they are tested at real texture coordinates (a loader that
     * dropped them would test every hit at (0, 0)). */
    float umin = INFINITY, umax = -INFINITY;
    for (uint32_t t = 0; t < s->triangle_count; t++)
        for (int k = 0; k < 3; k++) {
            umin = fminf(umin, s->uvs[6 * (size_t)t + 2 * k]);
            umax = fmaxf(umax, s->uvs[6 * (size_t)t + 2 * k]);
        }
    check(umax - umin > 0.5f, "smallpine: texture coordinates kept for the cutouts (u in [%g, %g])", umin, umax);
    rtk_scene_free(s);
}

int main(void)
{
    setvbuf(stdout, NULL, _IOLBF, 0);
    snprintf(tmpdir, sizeof tmpdir, "/tmp/rtk-alpha-XXXXXX");
    if (!mkdtemp(tmpdir)) {
        printf("FAIL  cannot make a temporary directory\n");
        return 1;
    }
    rtk_registry *reg = NULL;
    if (rtk_registry_create(&reg) != RTK_OK ||
        rtk_registry_find(reg, RTK_KIND_ACCELERATOR, "sah", &builder) != RTK_OK) {
        printf("FAIL  sah plugin: %s\n", rtk_error_message());
        return 1;
    }
    builder_params = rtk_params_defaults(builder);
    write_texture("rgba.exr", 0);
    write_texture("grey.exr", 1);
    test_checker("rgba.exr", "map_d with alpha");
    test_checker("grey.exr", "map_d grey mask");
    test_stack();
    test_opaque_keeps_nothing();
    test_smallpine();
    rtk_params_destroy(builder_params);
    rtk_registry_destroy(reg);
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmpdir);
    if (!getenv("KEEP") && system(cmd) != 0)
        printf("note  could not remove %s\n", tmpdir);
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}

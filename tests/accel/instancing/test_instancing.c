/* Tests for two-level instancing (kernel/accel/instance.c), for every shipped
 * builder with the kernel's traversal:
 * - a mesh placed by six transforms (rotation, non-uniform and tiny scale,
 *   a mirror, an offset of 1e4) beside world-space triangles answers as
 *   the same triangles flattened into one scene: the same triangle, t and
 *   surface (point, normals, uvs, front side), the same any-hit answer;
 *   where the two differ, a double-precision oracle must show a tie or a
 *   ray grazing an edge;
 * - equal distances go to the scene's own triangles, then to the lowest
 *   instance, then to the lowest triangle id;
 * - memory: 10,000 instances add instance records only;
 * - lights: an instanced emitter is sampled per instance, and the pdf of
 *   the hit on it is the pdf of the sample;
 * - glTF: a mesh used by three nodes is loaded once and instanced, and
 *   traces as the same file with three copies of the mesh;
 * - config: instances entries are checked with file and line;
 * - several accelerators' trees held at once (rtk_accel_set, as `rtk
 *   bench` holds them): swapped out and back in, each traces as built. */
#include "config/config.h"
#include "render/render.h"

#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"

static double frand(rtk_pcg32 *rng, double lo, double hi)
{
    return lo + (hi - lo) * rtk_pcg32_float(rng);
}

/* ---- transforms ---- */

static void compose(const double t[3], const double axis[3], double degrees, const double s[3], double m[12])
{
    double len = sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    double x = axis[0] / len, y = axis[1] / len, z = axis[2] / len;
    double a = degrees * M_PI / 180.0, c = cos(a), sn = sin(a), k = 1.0 - c;
    double r[9] = {c + x * x * k,      x * y * k - z * sn, x * z * k + y * sn,
                   y * x * k + z * sn, c + y * y * k,      y * z * k - x * sn,
                   z * x * k - y * sn, z * y * k + x * sn, c + z * z * k};
    for (int row = 0; row < 3; row++) {
        for (int col = 0; col < 3; col++)
            m[4 * row + col] = r[3 * row + col] * s[col];
        m[4 * row + 3] = t[row];
    }
}

static void apply(const double m[12], const float p[3], int w, double out[3])
{
    for (int r = 0; r < 3; r++)
        out[r] = m[4 * r] * p[0] + m[4 * r + 1] * p[1] + m[4 * r + 2] * p[2] + (w ? m[4 * r + 3] : 0.0);
}

/* Normal through m: cofactor rows (the inverse transpose up to a scale
 * with the determinant's sign, so that the authored side stays). */
static void apply_normal(const double m[12], const float n[3], double out[3])
{
    double a = m[0], b = m[1], c = m[2], d = m[4], e = m[5], f = m[6], g = m[8], h = m[9], i = m[10];
    double cof[9] = {e * i - f * h, f * g - d * i, d * h - e * g, c * h - b * i, a * i - c * g,
                     b * g - a * h, b * f - c * e, c * d - a * f, a * e - b * d};
    double det = a * cof[0] + b * cof[1] + c * cof[2];
    double sgn = det < 0 ? -1.0 : 1.0;
    for (int r = 0; r < 3; r++)
        out[r] = sgn * (cof[3 * r] * n[0] + cof[3 * r + 1] * n[1] + cof[3 * r + 2] * n[2]);
}

static double determinant(const double m[12])
{
    return m[0] * (m[5] * m[10] - m[6] * m[9]) - m[1] * (m[4] * m[10] - m[6] * m[8]) +
           m[2] * (m[4] * m[9] - m[5] * m[8]);
}

/* ---- scenes ---- */

static void add_triangle(rtk_scene *s, const float v[9], const float *n, const float *uv, uint32_t material)
{
    uint32_t i[3];
    for (int k = 0; k < 3; k++)
        rtk_scene_add_vertex(s, v[3 * k], v[3 * k + 1], v[3 * k + 2], &i[k]);
    rtk_scene_add_triangle(s, i[0], i[1], i[2], n, uv, material);
}

/* A mesh in object space: a closed box and a soup of small triangles, with
 * random corner normals and uvs. */
static void fill_mesh(rtk_scene *mesh, rtk_pcg32 *rng)
{
    static const int quads[6][4] = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
    float p[8][3];
    for (int i = 0; i < 8; i++) {
        p[i][0] = i & 1 ? 0.4f : -0.4f;
        p[i][1] = i & 2 ? 0.3f : -0.3f;
        p[i][2] = i & 4 ? 0.2f : -0.2f;
    }
    for (int q = 0; q < 6; q++) {
        for (int half = 0; half < 2; half++) {
            const int c[3] = {quads[q][0], quads[q][1 + half], quads[q][2 + half]};
            float v[9], n[9], uv[6];
            for (int k = 0; k < 3; k++) {
                memcpy(v + 3 * k, p[c[k]], sizeof p[0]);
                double dx = frand(rng, -1, 1), dy = frand(rng, -1, 1), dz = frand(rng, -1, 1);
                double len = sqrt(dx * dx + dy * dy + dz * dz) + 1e-3;
                n[3 * k] = (float)(dx / len), n[3 * k + 1] = (float)(dy / len), n[3 * k + 2] = (float)(dz / len);
                uv[2 * k] = (float)frand(rng, 0, 1), uv[2 * k + 1] = (float)frand(rng, 0, 1);
            }
            add_triangle(mesh, v, n, uv, RTK_INVALID_ID);
        }
    }
    for (int t = 0; t < 300; t++) {
        double c[3] = {frand(rng, -1, 1), frand(rng, -1, 1), frand(rng, -1, 1)};
        float v[9], n[9], uv[6];
        for (int k = 0; k < 3; k++) {
            for (int a = 0; a < 3; a++)
                v[3 * k + a] = (float)(c[a] + frand(rng, -0.15, 0.15));
            n[3 * k] = 0.0f, n[3 * k + 1] = 1.0f, n[3 * k + 2] = 0.0f;
            uv[2 * k] = (float)frand(rng, 0, 1), uv[2 * k + 1] = (float)frand(rng, 0, 1);
        }
        add_triangle(mesh, v, n, uv, RTK_INVALID_ID);
    }
}

#define PLACEMENTS 6

/* Object -> world transforms of the placements. */
static void placements(double m[PLACEMENTS][12])
{
    const double zero[3] = {0, 0, 0}, one[3] = {1, 1, 1}, y[3] = {0, 1, 0};
    compose(zero, y, 0.0, one, m[0]);
    compose((double[3]){3, 0.5, -1}, (double[3]){1, 2, 3}, 37.0, (double[3]){2, 2, 2}, m[1]);
    compose((double[3]){-3, 1, 2}, (double[3]){0, 0, 1}, 71.0, (double[3]){1, 0.5, 3}, m[2]);
    compose((double[3]){0, -2.5, 3}, y, 15.0, (double[3]){-1, 1, 1}, m[3]); /* a mirror */
    compose((double[3]){1e4, 2e3, -5e3}, (double[3]){1, 1, 0}, 120.0, (double[3]){40, 40, 40}, m[4]);
    compose((double[3]){0.5, 2.5, 0.5}, y, -30.0, (double[3]){1e-2, 1e-2, 1e-2}, m[5]);
}

/* Mapping of the flat scene's triangles: instance (RTK_INVALID_ID for the
 * scene's own) and triangle id in its mesh. */
typedef struct origin {
    uint32_t inst, prim;
} origin;

typedef struct pair {
    rtk_scene *inst;  /* the two-level scene */
    rtk_scene *flat;  /* the same triangles flattened */
    origin *from;     /* flat triangle -> where it came from */
    int uniform[PLACEMENTS]; /* placement i scales the same along every axis */
} pair;

static const float ground[2][9] = {{-20, -4, -20, -20, -4, 20, 20, -4, 20}, {-20, -4, -20, 20, -4, 20, 20, -4, -20}};

static void make_pair(pair *out, uint32_t needs)
{
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 2026, 11);
    rtk_scene *inst = rtk_scene_new("instanced", needs), *flat = rtk_scene_new("flat", needs);
    const float up[9] = {0, 1, 0, 0, 1, 0, 0, 1, 0}, uv0[6] = {0, 0, 0, 1, 1, 1};
    for (int g = 0; g < 2; g++) {
        add_triangle(inst, ground[g], up, uv0, RTK_INVALID_ID);
        add_triangle(flat, ground[g], up, uv0, RTK_INVALID_ID);
    }
    uint32_t mi;
    rtk_scene_add_mesh(inst, "mesh", &mi);
    rtk_scene *mesh = inst->meshes[mi];
    fill_mesh(mesh, &rng);
    double m[PLACEMENTS][12];
    placements(m);
    uint32_t nt = mesh->triangle_count;
    out->from = calloc(2 + (size_t)PLACEMENTS * nt, sizeof *out->from);
    out->from[0] = (origin){RTK_INVALID_ID, 0};
    out->from[1] = (origin){RTK_INVALID_ID, 1};
    for (uint32_t i = 0; i < PLACEMENTS; i++) {
        rtk_scene_add_instance(inst, mi, m[i], "test");
        out->uniform[i] = i != 2;
        int mirrored = determinant(m[i]) < 0.0;
        for (uint32_t t = 0; t < nt; t++) {
            float v[9], n[9], uv[6];
            const uint32_t *idx = mesh->indices + 3 * (size_t)t;
            for (int k = 0; k < 3; k++) {
                /* The flattening loaders swap two corners of a mirrored
                 * triangle to keep its authored side in front. */
                int src = mirrored && k ? 3 - k : k;
                double w[3], wn[3];
                apply(m[i], mesh->positions + 3 * (size_t)idx[src], 1, w);
                apply_normal(m[i], mesh->normals + 9 * (size_t)t + 3 * src, wn);
                double len = sqrt(wn[0] * wn[0] + wn[1] * wn[1] + wn[2] * wn[2]);
                for (int a = 0; a < 3; a++)
                    v[3 * k + a] = (float)w[a], n[3 * k + a] = (float)(wn[a] / len);
                uv[2 * k] = mesh->uvs[6 * (size_t)t + 2 * src];
                uv[2 * k + 1] = mesh->uvs[6 * (size_t)t + 2 * src + 1];
            }
            add_triangle(flat, v, n, uv, RTK_INVALID_ID);
            out->from[flat->triangle_count - 1] = (origin){i, t};
        }
    }
    check(rtk_scene_finish(inst) == RTK_OK && rtk_scene_finish(flat) == RTK_OK, "finish: %u own + %u x %u triangles",
          inst->triangle_count, inst->instance_count, mesh->triangle_count);
    check(flat->triangle_count == 2 + PLACEMENTS * nt, "flat copy: %u triangles (none dropped)", flat->triangle_count);
    out->inst = inst;
    out->flat = flat;
}

static double allowance(const rtk_ray *r, double t);

/* Double-precision ray/triangle: 1 and t, the smallest barycentric
 * coordinate (the margin to the nearest edge), and how far inside a float
 * test can be wrong about it (graze): the distance allowance over the
 * triangle's smallest altitude, over the cosine between ray and normal,
 * as a ray seen edge-on stretches barycentric errors by 1 / cos. */
static int oracle(const rtk_ray *r, const rtk_scene *flat, uint32_t prim, double *t, double *margin, double *graze)
{
    rtk_vec3 a, b, c;
    rtk_scene_triangle(flat, prim, &a, &b, &c);
    double o[3] = {r->org.x, r->org.y, r->org.z}, d[3] = {r->dir.x, r->dir.y, r->dir.z};
    double e1[3] = {(double)b.x - a.x, (double)b.y - a.y, (double)b.z - a.z};
    double e2[3] = {(double)c.x - a.x, (double)c.y - a.y, (double)c.z - a.z};
    double p[3] = {d[1] * e2[2] - d[2] * e2[1], d[2] * e2[0] - d[0] * e2[2], d[0] * e2[1] - d[1] * e2[0]};
    double det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2];
    if (det == 0.0)
        return 0;
    double s[3] = {o[0] - a.x, o[1] - a.y, o[2] - a.z};
    double u = (s[0] * p[0] + s[1] * p[1] + s[2] * p[2]) / det;
    double q[3] = {s[1] * e1[2] - s[2] * e1[1], s[2] * e1[0] - s[0] * e1[2], s[0] * e1[1] - s[1] * e1[0]};
    double v = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) / det;
    *t = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) / det;
    *margin = fmin(fmin(u, v), 1.0 - u - v);
    double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    double nl = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]), dl = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    double l1 = sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]), l2 = sqrt(e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2]);
    double l3 = sqrt((e2[0] - e1[0]) * (e2[0] - e1[0]) + (e2[1] - e1[1]) * (e2[1] - e1[1]) + (e2[2] - e1[2]) * (e2[2] - e1[2]));
    double h = nl / fmax(l1, fmax(l2, l3));
    double cosine = fabs(n[0] * d[0] + n[1] * d[1] + n[2] * d[2]) / (nl * dl);
    *graze = 8.0 * allowance(r, *t) * dl / (h * cosine);
    return 1;
}

/* The flat triangle an instanced hit stands for. */
static uint32_t flat_id(const pair *pr, const rtk_hit *h)
{
    uint32_t n = pr->flat->triangle_count;
    for (uint32_t f = 0; f < n; f++) {
        if (pr->from[f].inst == h->inst && pr->from[f].prim == h->prim)
            return f;
    }
    return RTK_INVALID_ID;
}

/* Distance error allowed between the two scenes for a ray: the flat
 * vertices and the instanced ray are each rounded to float once from the
 * same double transform, a few ulps of the larger of the ray origin and
 * the hit point, over the direction's length. */
static double allowance(const rtk_ray *r, double t)
{
    double dl = sqrt((double)r->dir.x * r->dir.x + (double)r->dir.y * r->dir.y + (double)r->dir.z * r->dir.z);
    double ol = fmax(fabs(r->org.x), fmax(fabs(r->org.y), fabs(r->org.z)));
    double hl = ol + t * dl;
    return 64.0 * FLT_EPSILON * fmax(ol, hl) / dl;
}

typedef struct tally {
    uint64_t rays, same, explained, unexplained;
} tally;

/* Compares closest and any hits of the two scenes on ray r. */
static void compare_ray(const pair *pr, const rtk_ray *r, tally *tl, int surfaces, double *worst_p)
{
    rtk_hit hf, hi;
    int f = rtk_bvh_closest(pr->flat, r, &hf), i = rtk_bvh_closest(pr->inst, r, &hi);
    int af = rtk_bvh_any(pr->flat, r), ai = rtk_bvh_any(pr->inst, r);
    tl->rays++;
    if (ai != i || af != f) {
        tl->unexplained++;
        printf("      any-hit disagrees with closest hit: flat %d/%d, instanced %d/%d\n", af, f, ai, i);
        return;
    }
    uint32_t fi = i ? flat_id(pr, &hi) : RTK_INVALID_ID;
    int uniform = !i || hi.inst == RTK_INVALID_ID || pr->uniform[hi.inst];
    if (f == i && (!f || (fi == hf.prim && fabs((double)hf.t - hi.t) <= allowance(r, hf.t)))) {
        tl->same++;
        if (f && surfaces) {
            rtk_surface sf, si;
            rtk_surface_at(pr->flat, r, &hf, &sf);
            rtk_surface_at(pr->inst, r, &hi, &si);
            /* Barycentrics carry the distance allowance divided by the
             * triangle's smallest altitude h; the point moves by that
             * times the longest edge L, uvs by that times their range. */
            rtk_vec3 a, b, c;
            rtk_scene_triangle(pr->flat, hf.prim, &a, &b, &c);
            double la = rtk_vec3_length(rtk_vec3_sub(b, a)), lb = rtk_vec3_length(rtk_vec3_sub(c, b)),
                   lc = rtk_vec3_length(rtk_vec3_sub(a, c));
            double longest = fmax(la, fmax(lb, lc));
            double h = rtk_vec3_length(rtk_vec3_cross(rtk_vec3_sub(b, a), rtk_vec3_sub(c, a))) / longest;
            double dist = allowance(r, hf.t) * rtk_vec3_length(r->dir);
            double tol_p = dist * fmax(1.0, longest / h), tol_uv = 2.0 * tol_p / h;
            double dp = rtk_vec3_length(rtk_vec3_sub(sf.p, si.p));
            if (dp / tol_p > *worst_p)
                *worst_p = dp / tol_p;
            /* Shading normals agree where the placement scales evenly: the
             * flat copy interpolates normals transformed per corner, the
             * instance transforms the interpolated one, the same only for
             * a rotation times a uniform scale. A normal nearly in the
             * surface may land on either side of it (ns follows ng). */
            float nsd = rtk_vec3_dot(sf.ns, si.ns);
            int ns_ok = !uniform || fabsf(nsd) >= 1.0f - 1e-3f;
            if (ns_ok && uniform && nsd < 0.0f)
                ns_ok = fabsf(rtk_vec3_dot(sf.ns, sf.ng)) < 1e-2f;
            if (dp > tol_p || rtk_vec3_dot(sf.ng, si.ng) < 1.0f - 1e-4f || !ns_ok ||
                fabsf(sf.uv.x - si.uv.x) > tol_uv || fabsf(sf.uv.y - si.uv.y) > tol_uv ||
                sf.front_face != si.front_face) {
                tl->unexplained++;
                printf("      instance %u triangle %u: point off by %g (allowed %g), ng.ng %g, ns.ns %g, uv off by "
                       "%g %g (allowed %g), front %d %d\n", hi.inst, hi.prim, dp, tol_p, rtk_vec3_dot(sf.ng, si.ng),
                       nsd, sf.uv.x - si.uv.x, sf.uv.y - si.uv.y, tol_uv, sf.front_face, si.front_face);
            }
        }
        return;
    }
    /* They differ: a tie in double, or a ray grazing an edge (within the
     * rounding of the two vertex sets) explains it. */
    double tf = 0, mf = -1, gf = 0, ti = 0, mi = -1, gi = 0;
    if (f)
        oracle(r, pr->flat, hf.prim, &tf, &mf, &gf);
    if (i && fi != RTK_INVALID_ID)
        oracle(r, pr->flat, fi, &ti, &mi, &gi);
    int ok;
    if (f && i)
        ok = fabs(tf - ti) <= 2.0 * allowance(r, tf) || mf < gf || mi < gi;
    else
        ok = f ? mf < gf || tf > r->tmax * (1 - 1e-5) : mi < gi || ti > r->tmax * (1 - 1e-5);
    if (ok) {
        tl->explained++;
    } else {
        tl->unexplained++;
        printf("      differ: flat %s triangle %u t %.9g (oracle %.9g, margin %.3g of %.3g), instanced %s (%u, %u) = flat %u "
               "t %.9g (oracle %.9g, margin %.3g of %.3g)\n", f ? "hit" : "miss", f ? hf.prim : 0, f ? hf.t : 0.0, tf, mf, gf,
               i ? "hit" : "miss", i ? hi.inst : 0, i ? hi.prim : 0, fi, i ? hi.t : 0.0, ti, mi, gi);
    }
}

static void test_equivalence(const rtk_plugin *builder)
{
    pair pr;
    make_pair(&pr, RTK_NEED_NORMALS | RTK_NEED_UVS);
    rtk_params *params = rtk_params_defaults(builder);
    rtk_bvh_cache_use use;
    rtk_status s1 = rtk_bvh_build_cached(pr.inst, builder, params, 2, NULL, &use);
    rtk_status s2 = rtk_bvh_build_cached(pr.flat, builder, params, 2, NULL, &use);
    check(s1 == RTK_OK && s2 == RTK_OK && pr.inst->tlas_node_count > 0,
          "%s: built the two-level scene (top level %u nodes, depth %u) and the flat one", builder->name,
          pr.inst->tlas_node_count, pr.inst->tlas_depth);
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 99, 1);
    tally aimed = {0}, random = {0}, shortened = {0};
    double worst_p = 0.0;
    /* Rays aimed at points inside the flat triangles, from all around. */
    for (uint32_t f = 0; f < pr.flat->triangle_count; f++) {
        rtk_vec3 a, b, c;
        rtk_scene_triangle(pr.flat, f, &a, &b, &c);
        for (int k = 0; k < 8; k++) {
            double u = frand(&rng, 0.05, 0.9), v = frand(&rng, 0.05, 0.9);
            if (u + v > 0.95)
                u = 0.95 - u * 0.5, v = 0.95 - v * 0.5;
            double target[3] = {a.x + u * (b.x - a.x) + v * (c.x - a.x), a.y + u * (b.y - a.y) + v * (c.y - a.y),
                                a.z + u * (b.z - a.z) + v * (c.z - a.z)};
            double scale = fmax(1.0, fmax(fabs(target[0]), fmax(fabs(target[1]), fabs(target[2]))));
            double dir[3] = {frand(&rng, -1, 1), frand(&rng, -1, 1), frand(&rng, -1, 1)};
            rtk_ray r;
            r.org = rtk_vec3_make((float)(target[0] - 3 * scale * dir[0]), (float)(target[1] - 3 * scale * dir[1]),
                                  (float)(target[2] - 3 * scale * dir[2]));
            r.dir = rtk_vec3_make((float)(target[0] - r.org.x), (float)(target[1] - r.org.y),
                                  (float)(target[2] - r.org.z));
            r.tmin = 0.0f;
            r.tmax = INFINITY;
            compare_ray(&pr, &r, &aimed, 1, &worst_p);
            r.tmax = 0.999f; /* stops short of the target: occluders only */
            compare_ray(&pr, &r, &shortened, 0, &worst_p);
        }
    }
    for (int k = 0; k < 200000; k++) {
        rtk_ray r;
        r.org = rtk_vec3_make((float)frand(&rng, -8, 8), (float)frand(&rng, -6, 6), (float)frand(&rng, -8, 8));
        r.dir = rtk_vec3_make((float)frand(&rng, -1, 1), (float)frand(&rng, -1, 1), (float)frand(&rng, -1, 1));
        r.tmin = 0.0f;
        r.tmax = INFINITY;
        compare_ray(&pr, &r, &random, 1, &worst_p);
    }
    check(aimed.unexplained == 0, "%s: %llu aimed rays: %llu identical (triangle, t, surface), %llu ties or grazes, "
          "%llu unexplained", builder->name, (unsigned long long)aimed.rays, (unsigned long long)aimed.same,
          (unsigned long long)aimed.explained, (unsigned long long)aimed.unexplained);
    check(aimed.same >= aimed.rays * 99 / 100, "%s: at least 99%% of aimed rays identical", builder->name);
    check(shortened.unexplained == 0, "%s: %llu shortened rays (occluders only): %llu identical, %llu explained, "
          "%llu unexplained", builder->name, (unsigned long long)shortened.rays, (unsigned long long)shortened.same,
          (unsigned long long)shortened.explained, (unsigned long long)shortened.unexplained);
    check(random.unexplained == 0, "%s: %llu random rays: %llu identical, %llu explained, %llu unexplained",
          builder->name, (unsigned long long)random.rays, (unsigned long long)random.same,
          (unsigned long long)random.explained, (unsigned long long)random.unexplained);
    printf("      worst hit point distance: %.3f of the allowance\n", worst_p);

    /* Invalid rays in an instanced scene are refused like any other. */
    rtk_ray bad = {{0, 0, 0}, 0.0f, {NAN, 0, 1}, INFINITY};
    rtk_ctx ctx;
    memset(&ctx, 0, sizeof ctx);
    ctx.scene = pr.inst;
    rtk_hit h;
    check(!rtk_trace(&ctx, &bad, &h) && !rtk_occluded(&ctx, &bad) && ctx.invalid_rays == 2 &&
          h.inst == RTK_INVALID_ID, "%s: NaN rays are rejected and counted", builder->name);
    rtk_params_destroy(params);
    rtk_scene_free(pr.inst);
    rtk_scene_free(pr.flat);
    free(pr.from);
}

/* A unit quad (two triangles) and its duplicate: triangles 0..3. */
static void fill_quads(rtk_scene *s, float y)
{
    const float q[2][9] = {{0, y, 0, 0, y, 1, 1, y, 1}, {0, y, 0, 1, y, 1, 1, y, 0}};
    for (int copy = 0; copy < 2; copy++)
        for (int k = 0; k < 2; k++)
            add_triangle(s, q[k], NULL, NULL, RTK_INVALID_ID);
}

static void test_ties(const rtk_plugin *builder)
{
    rtk_params *params = rtk_params_defaults(builder);
    rtk_bvh_cache_use use;
    for (int own = 0; own < 2; own++) {
        rtk_scene *s = rtk_scene_new("ties", 0);
        if (own)
            fill_quads(s, 0.0f);
        uint32_t mi;
        rtk_scene_add_mesh(s, "quads", &mi);
        fill_quads(s->meshes[mi], 0.0f);
        const double id[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
        /* Five coincident instances and one nearer the camera, whose
         * boxes overlap: the builder and the ray decide the order. */
        for (int i = 0; i < 5; i++)
            rtk_scene_add_instance(s, mi, id, "ties");
        rtk_scene_finish(s);
        rtk_status st = rtk_bvh_build_cached(s, builder, params, 1, NULL, &use);
        rtk_pcg32 rng;
        rtk_pcg32_seed(&rng, 5, 5);
        uint32_t wrong = 0, rays = 4000;
        for (uint32_t k = 0; k < rays && st == RTK_OK; k++) {
            float x = (float)frand(&rng, 0.01, 0.99), z = (float)frand(&rng, 0.01, 0.99);
            float sign = k & 1 ? 1.0f : -1.0f;
            rtk_ray r = {{x + (float)frand(&rng, -0.5, 0.5), sign * 2.0f, z + (float)frand(&rng, -0.5, 0.5)}, 0.0f,
                         {0, 0, 0}, INFINITY};
            r.dir = rtk_vec3_make(x - r.org.x, -r.org.y, z - r.org.z);
            rtk_hit h;
            int hit = rtk_bvh_closest(s, &r, &h);
            uint32_t want_inst = own ? RTK_INVALID_ID : 0;
            if (!hit || h.inst != want_inst || h.prim > 1)
                wrong++;
        }
        check(st == RTK_OK && wrong == 0, "%s: coplanar duplicates %s: %u of %u rays hit %s, triangle 0 or 1",
              builder->name, own ? "in the scene and in 5 instances" : "in 5 coincident instances", rays - wrong,
              rays, own ? "the scene's own triangle" : "instance 0");
        rtk_scene_free(s);
    }
    rtk_params_destroy(params);
}

static void test_memory(const rtk_plugin *builder)
{
    size_t g1, b1, i1, g2, b2, i2;
    rtk_params *params = rtk_params_defaults(builder);
    rtk_bvh_cache_use use;
    rtk_scene *s[2];
    const uint32_t counts[2] = {1, 10000};
    for (int k = 0; k < 2; k++) {
        rtk_pcg32 rng;
        rtk_pcg32_seed(&rng, 1, 1);
        s[k] = rtk_scene_new("memory", 0);
        uint32_t mi;
        rtk_scene_add_mesh(s[k], "mesh", &mi);
        fill_mesh(s[k]->meshes[mi], &rng);
        for (uint32_t i = 0; i < counts[k]; i++) {
            double m[12];
            compose((double[3]){(i % 100) * 2.5, 0, (i / 100) * 2.5}, (double[3]){0, 1, 0}, i * 7.0,
                    (double[3]){1, 1, 1}, m);
            rtk_scene_add_instance(s[k], mi, m, "memory");
        }
        rtk_scene_finish(s[k]);
        rtk_bvh_build_cached(s[k], builder, params, 2, NULL, &use);
    }
    rtk_scene_memory(s[0], &g1, &b1, &i1);
    rtk_scene_memory(s[1], &g2, &b2, &i2);
    /* Per instance: its record, the placement traversal reads, its top-level slot; the top level's nodes. */
    size_t records = 10000 * (sizeof(rtk_instance) + sizeof(rtk_device_instance) + sizeof(uint32_t)) +
                     (2 * 10000 - 1) * sizeof(rtk_bvh_node);
    check(g1 == g2 && b1 == b2 && i2 <= records,
          "%s: 10,000 instances: geometry %zu = %zu bytes and BVH %zu = %zu bytes as for one; instance records "
          "%zu bytes (<= %zu)", builder->name, g2, g1, b2, b1, i2, records);
    rtk_scene_free(s[0]);
    rtk_scene_free(s[1]);
    rtk_params_destroy(params);
}

static void test_lights(const rtk_plugin *builder)
{
    rtk_scene *s = rtk_scene_new("lights", RTK_NEED_LIGHTS | RTK_NEED_MATERIALS);
    rtk_material m = rtk_material_default();
    m.emission = rtk_rgb_make(2, 2, 2);
    uint32_t emissive;
    rtk_scene_add_material(s, &m, &emissive);
    uint32_t mi;
    rtk_scene_add_mesh(s, "lamp", &mi);
    /* A quad facing down (-y) at y = 0 in object space. */
    const float q[2][9] = {{0, 0, 0, 1, 0, 0, 1, 0, 1}, {0, 0, 0, 1, 0, 1, 0, 0, 1}};
    for (int k = 0; k < 2; k++)
        add_triangle(s->meshes[mi], q[k], NULL, NULL, emissive);
    double xf[3][12];
    compose((double[3]){0, 3, 0}, (double[3]){0, 1, 0}, 0, (double[3]){1, 1, 1}, xf[0]);
    compose((double[3]){2, 4, 0}, (double[3]){0, 1, 0}, 30, (double[3]){2, 1, 3}, xf[1]);
    compose((double[3]){-3, 5, 1}, (double[3]){0, 1, 0}, 0, (double[3]){-1, 1, 1}, xf[2]);
    for (int i = 0; i < 3; i++)
        rtk_scene_add_instance(s, mi, xf[i], "lights");
    rtk_status st = rtk_scene_finish(s);
    rtk_bvh_cache_use use;
    rtk_params *params = rtk_params_defaults(builder);
    if (st == RTK_OK)
        st = rtk_bvh_build_cached(s, builder, params, 1, NULL, &use);
    check(st == RTK_OK && rtk_scene_light_count(s) == 6, "%s: 3 instances of a 2-triangle emitter: %u lights",
          builder->name, rtk_scene_light_count(s));
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 3, 3);
    uint32_t agree = 0, n = 2000, per_inst[3] = {0, 0, 0};
    for (uint32_t k = 0; k < n && st == RTK_OK; k++) {
        rtk_light_sample ls;
        if (!rtk_scene_sample_light(s, rtk_pcg32_float(&rng),
                                    (rtk_vec2){rtk_pcg32_float(&rng), rtk_pcg32_float(&rng)}, &ls))
            break;
        /* From below (the emitting side) towards the sampled point. */
        rtk_ray r = {{ls.p.x + 0.1f, -1.0f, ls.p.z - 0.1f}, 0.0f, {0, 0, 0}, INFINITY};
        r.dir = rtk_vec3_sub(ls.p, r.org);
        r.dir = rtk_vec3_scale(r.dir, 1.001f);
        rtk_hit h;
        if (ls.inst < 3)
            per_inst[ls.inst]++;
        if (rtk_bvh_closest(s, &r, &h) && h.inst == ls.inst && h.prim == ls.prim &&
            rtk_scene_light_pdf(s, &h) == ls.pdf_area && ls.n.y < -0.999f)
            agree++;
    }
    /* Power is area x luminance: instance areas 1, 6 and 1 of 8. */
    double expect[3] = {n / 8.0, n * 6.0 / 8.0, n / 8.0};
    int fair = 1;
    for (int i = 0; i < 3; i++)
        fair &= fabs(per_inst[i] - expect[i]) <= 5.0 * sqrt(expect[i] * (1.0 - expect[i] / n));
    check(agree == n, "%s: %u of %u light samples are hit back on their (instance, triangle), facing down, with "
          "rtk_scene_light_pdf of the hit = the sample's pdf", builder->name, agree, n);
    check(fair, "%s: samples per instance %u %u %u for power shares 1/8 6/8 1/8 (5 sigma)", builder->name,
          per_inst[0], per_inst[1], per_inst[2]);
    rtk_params_destroy(params);
    rtk_scene_free(s);
}

/* ---- glTF ---- */

/* ---- several accelerators' trees held at once (rtk_accel_set) ---- */

enum { SET_RAYS = 3000 };

/* Closest hits and any-hit answers of rays through the middle of s, and
 * the work of each (nodes and triangles visited: how the builders' trees
 * differ, where the answers agree by design). */
static void trace_set(const rtk_scene *s, rtk_hit *hits, int *any, uint64_t *work)
{
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 77, 1);
    for (int i = 0; i < SET_RAYS; i++) {
        rtk_ray r = {{(float)frand(&rng, -30, 30), (float)frand(&rng, -30, 30), (float)frand(&rng, -30, 30)}, 0.0f,
                     {0, 0, 0}, INFINITY};
        r.dir = rtk_vec3_make((float)frand(&rng, -3, 3) - r.org.x, (float)frand(&rng, -3, 3) - r.org.y,
                              (float)frand(&rng, -3, 3) - r.org.z);
        if (i % 3 == 0)
            r.tmax = (float)frand(&rng, 0.1, 1.0); /* short: some occluded, some not */
        rtk_trace_work wc = {0, 0}, wa = {0, 0};
        rtk_bvh_closest_measure(s, &r, &hits[i], &wc);
        any[i] = rtk_bvh_any_measure(s, &r, &wa);
        work[i] = (uint64_t)wc.nodes << 48 | (uint64_t)wc.triangles << 32 | (uint64_t)wa.nodes << 16 | wa.triangles;
    }
}

typedef struct set_trace {
    rtk_hit hits[SET_RAYS];
    int any[SET_RAYS];
    uint64_t work[SET_RAYS];
} set_trace;

static int same_trace(const set_trace *a, const set_trace *b)
{
    for (int i = 0; i < SET_RAYS; i++)
        if (a->hits[i].prim != b->hits[i].prim || a->hits[i].inst != b->hits[i].inst ||
            memcmp(&a->hits[i].t, &b->hits[i].t, sizeof a->hits[i].t) != 0 || a->any[i] != b->any[i] ||
            a->work[i] != b->work[i])
            return 0;
    return 1;
}

static int same_work(const set_trace *a, const set_trace *b)
{
    return memcmp(a->work, b->work, sizeof a->work) == 0;
}

/* Whether s holds no tree at all (its meshes' and top level included). */
static int treeless(const rtk_scene *s)
{
    int none = !s->nodes && !s->prim_ids && !s->wide && !s->own_state && !s->tlas_nodes && !s->tlas_order;
    for (uint32_t i = 0; i < s->mesh_count; i++)
        none &= !s->meshes[i]->nodes && !s->meshes[i]->wide;
    return none;
}

/* A builds, its trees go aside into a set; b builds in the scene; the set
 * and the scene trade places twice: each time the scene traces exactly as
 * the accelerator whose trees it holds did right after its build. Freed
 * in the end with one accelerator in the set, the other in the scene
 * (ASan and valgrind: nothing leaked, nothing freed twice). */
static void test_accel_set(rtk_scene *s, const char *what, const rtk_plugin *a, const rtk_plugin *b)
{
    set_trace *tr = calloc(3, sizeof *tr);
    rtk_params *pa = rtk_params_defaults(a), *pb = rtk_params_defaults(b);
    rtk_bvh_cache_use use;
    rtk_accel_set set;
    rtk_status st = rtk_accel_set_init(&set, s);
    if (st == RTK_OK)
        st = rtk_bvh_build_cached(s, a, pa, 1, NULL, &use);
    if (st == RTK_OK) {
        trace_set(s, tr[0].hits, tr[0].any, tr[0].work);
        rtk_accel_swap(s, &set);
        check(treeless(s), "%s: %s's trees moved aside leave the scene without a tree", what, a->name);
        st = rtk_bvh_build_cached(s, b, pb, 2, NULL, &use);
    }
    if (st == RTK_OK) {
        trace_set(s, tr[1].hits, tr[1].any, tr[1].work);
        check(!same_work(&tr[0], &tr[1]), "%s: %s and %s visit different nodes (the check below can tell them apart)",
              what, a->name, b->name);
        rtk_accel_swap(s, &set);
        trace_set(s, tr[2].hits, tr[2].any, tr[2].work);
        check(same_trace(&tr[0], &tr[2]), "%s: %s swapped back in traces as it did when built: the same hits and work",
              what, a->name);
        rtk_accel_swap(s, &set);
        trace_set(s, tr[2].hits, tr[2].any, tr[2].work);
        check(same_trace(&tr[1], &tr[2]), "%s: %s swapped back in traces as it did when built: the same hits and work",
              what, b->name);
    }
    check(st == RTK_OK, "%s: %s and %s built: %s", what, a->name, b->name, st == RTK_OK ? "yes" : rtk_error_message());
    rtk_accel_set_free(&set);
    check(set.trees == NULL && set.tree_count == 0 && set.tlas_nodes == NULL, "%s: a freed set is empty", what);
    rtk_params_destroy(pa);
    rtk_params_destroy(pb);
    free(tr);
}

static void test_accel_sets(rtk_registry *reg)
{
    const rtk_plugin *sah = NULL, *median = NULL, *embree = NULL;
    if (rtk_registry_find(reg, RTK_KIND_ACCELERATOR, "sah", &sah) != RTK_OK ||
        rtk_registry_find(reg, RTK_KIND_ACCELERATOR, "median", &median) != RTK_OK) {
        check(0, "accelerator sets: sah and median found: %s", rtk_error_message());
        return;
    }
    pair pr;
    make_pair(&pr, RTK_NEED_NORMALS | RTK_NEED_UVS);
    test_accel_set(pr.inst, "two-level scene", sah, median);
    test_accel_set(pr.flat, "flat scene", median, sah);
    if (rtk_registry_find(reg, RTK_KIND_ACCELERATOR, "embree", &embree) == RTK_OK) {
        /* An own traversal's state moves with its trees. */
        test_accel_set(pr.flat, "flat scene", embree, sah);
        test_accel_set(pr.flat, "flat scene", sah, embree);
    } else {
        printf("skip  accelerator sets with embree: plugin not built\n");
    }
    rtk_scene_free(pr.inst);
    rtk_scene_free(pr.flat);
    free(pr.from);
}

/* Two device accelerators' trees (testdevice, ABI 3.9, and testdevice38,
 * 3.8) swapped in and out of a scene: what the kernel remembers of the
 * device holding the scene's tree (its ABI minor, the lights it was given)
 * moves with that tree. */
static void test_device_sets(rtk_registry *reg)
{
    const rtk_plugin *d9 = NULL, *d8 = NULL;
    if (rtk_registry_find(reg, RTK_KIND_ACCELERATOR, "testdevice", &d9) != RTK_OK ||
        rtk_registry_find(reg, RTK_KIND_ACCELERATOR, "testdevice38", &d8) != RTK_OK) {
        check(0, "device sets: testdevice and testdevice38 found: %s", rtk_error_message());
        return;
    }
    pair pr;
    make_pair(&pr, RTK_NEED_NORMALS | RTK_NEED_UVS);
    rtk_params *p9 = rtk_params_defaults(d9), *p8 = rtk_params_defaults(d8);
    rtk_bvh_cache_use use;
    rtk_accel_set set;
    rtk_status st = rtk_accel_set_init(&set, pr.flat);
    if (st == RTK_OK)
        st = rtk_bvh_build_cached(pr.flat, d9, p9, 1, NULL, &use);
    if (st == RTK_OK) {
        check(pr.flat->device_minor == 9, "device sets: testdevice holds the tree, ABI minor %u (want 9)",
              pr.flat->device_minor);
        rtk_accel_swap(pr.flat, &set);
        check(!pr.flat->device && pr.flat->device_minor == 0,
              "device sets: its tree moved aside leaves no device (ABI minor %u, want 0)", pr.flat->device_minor);
        st = rtk_bvh_build_cached(pr.flat, d8, p8, 1, NULL, &use);
    }
    if (st == RTK_OK) {
        check(pr.flat->device_minor == 8, "device sets: testdevice38 holds the tree, ABI minor %u (want 8)",
              pr.flat->device_minor);
        rtk_accel_swap(pr.flat, &set);
        check(pr.flat->device_minor == 9, "device sets: testdevice swapped back in, ABI minor %u (want 9)",
              pr.flat->device_minor);
        rtk_accel_swap(pr.flat, &set);
        check(pr.flat->device_minor == 8, "device sets: testdevice38 swapped back in, ABI minor %u (want 8)",
              pr.flat->device_minor);
    }
    check(st == RTK_OK, "device sets: testdevice and testdevice38 built: %s",
          st == RTK_OK ? "yes" : rtk_error_message());
    rtk_accel_set_free(&set);
    rtk_params_destroy(p9);
    rtk_params_destroy(p8);
    rtk_scene_free(pr.inst);
    rtk_scene_free(pr.flat);
    free(pr.from);
}

static char tmpdir[256];

/* A glTF with a box mesh (12 triangles) on three nodes, one mirrored;
 * shared = 1: the nodes share mesh 0; 0: each has its own copy. */
static void write_gltf(const char *path, int shared)
{
    static const float pos[8][3] = {{-1, -1, -1}, {1, -1, -1}, {-1, 1, -1}, {1, 1, -1},
                                    {-1, -1, 1},  {1, -1, 1},  {-1, 1, 1},  {1, 1, 1}};
    static const unsigned short idx[36] = {0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6, 0, 1, 5, 0, 5, 4,
                                           2, 6, 7, 2, 7, 3, 0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5};
    unsigned char bytes[96 + 72];
    memcpy(bytes, pos, 96);
    memcpy(bytes + 96, idx, 72);
    static const char b64[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    char enc[256];
    size_t e = 0;
    for (size_t i = 0; i < sizeof bytes; i += 3) {
        unsigned v = (unsigned)bytes[i] << 16 | (unsigned)bytes[i + 1] << 8 | bytes[i + 2];
        enc[e++] = b64[v >> 18 & 63], enc[e++] = b64[v >> 12 & 63], enc[e++] = b64[v >> 6 & 63], enc[e++] = b64[v & 63];
    }
    enc[e] = 0;
    const char *mesh = "{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1}]}";
    FILE *f = fopen(path, "w");
    fprintf(f,
            "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0,1,2]}],"
            "\"nodes\":[{\"mesh\":0,\"translation\":[0,0,0]},"
            "{\"mesh\":%d,\"translation\":[4,0,0],\"rotation\":[0,0.3826834,0,0.9238795],\"scale\":[1,2,0.5]},"
            "{\"mesh\":%d,\"translation\":[-4,1,0],\"scale\":[-1,1,1]}],"
            "\"meshes\":[%s,%s,%s],"
            "\"buffers\":[{\"byteLength\":168,\"uri\":\"data:application/octet-stream;base64,%s\"}],"
            "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":96},"
            "{\"buffer\":0,\"byteOffset\":96,\"byteLength\":72}],"
            "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":8,\"type\":\"VEC3\","
            "\"min\":[-1,-1,-1],\"max\":[1,1,1]},"
            "{\"bufferView\":1,\"componentType\":5123,\"count\":36,\"type\":\"SCALAR\"}]}\n",
            shared ? 0 : 1, shared ? 0 : 2, mesh, mesh, mesh, enc);
    fclose(f);
}

static void test_gltf(const rtk_plugin *builder)
{
    char shared_path[512], copies_path[512];
    snprintf(shared_path, sizeof shared_path, "%s/shared.gltf", tmpdir);
    snprintf(copies_path, sizeof copies_path, "%s/copies.gltf", tmpdir);
    write_gltf(shared_path, 1);
    write_gltf(copies_path, 0);
    rtk_scene *a = NULL, *b = NULL;
    rtk_status sa = rtk_scene_load(shared_path, RTK_NEED_NORMALS, &a);
    rtk_status sb = rtk_scene_load(copies_path, RTK_NEED_NORMALS, &b);
    check(sa == RTK_OK && sb == RTK_OK, "glTF: both files load (%s)", sa == RTK_OK && sb == RTK_OK ? "ok" :
          rtk_error_message());
    if (sa != RTK_OK || sb != RTK_OK) {
        rtk_scene_free(a);
        rtk_scene_free(b);
        return;
    }
    check(a->mesh_count == 1 && a->instance_count == 3 && a->triangle_count == 0 && a->meshes[0]->triangle_count == 12,
          "glTF: a mesh on three nodes is loaded once (%u mesh, %u instances, %u + %u triangles)", a->mesh_count,
          a->instance_count, a->triangle_count, a->mesh_count ? a->meshes[0]->triangle_count : 0);
    check(b->instance_count == 0 && b->triangle_count == 36, "glTF: three meshes on one node each are flattened "
          "(%u instances, %u triangles)", b->instance_count, b->triangle_count);
    check(fabsf(a->bounds.lower.x - b->bounds.lower.x) < 1e-4f && fabsf(a->bounds.upper.y - b->bounds.upper.y) < 1e-4f,
          "glTF: the same bounds ([%g, %g] vs [%g, %g] in x)", a->bounds.lower.x, a->bounds.upper.x,
          b->bounds.lower.x, b->bounds.upper.x);
    rtk_params *params = rtk_params_defaults(builder);
    rtk_bvh_cache_use use;
    rtk_bvh_build_cached(a, builder, params, 1, NULL, &use);
    rtk_bvh_build_cached(b, builder, params, 1, NULL, &use);
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 8, 8);
    uint32_t same = 0, n = 20000, hits = 0;
    for (uint32_t k = 0; k < n; k++) {
        rtk_ray r = {{(float)frand(&rng, -8, 8), (float)frand(&rng, -4, 4), 10.0f}, 0.0f, {0, 0, 0}, INFINITY};
        r.dir = rtk_vec3_make((float)frand(&rng, -0.3, 0.3), (float)frand(&rng, -0.3, 0.3), -1.0f);
        rtk_hit ha, hb;
        int ia = rtk_bvh_closest(a, &r, &ha), ib = rtk_bvh_closest(b, &r, &hb);
        int ok = ia == ib;
        if (ok && ia) {
            hits++;
            rtk_surface fa, fb;
            rtk_surface_at(a, &r, &ha, &fa);
            rtk_surface_at(b, &r, &hb, &fb);
            ok = ha.inst * 12 + ha.prim == hb.prim && fabsf(ha.t - hb.t) <= 1e-5f * 10.0f &&
                 rtk_vec3_dot(fa.ng, fb.ng) > 0.9999f && fa.front_face == fb.front_face;
        }
        same += ok;
    }
    check(same == n && hits > n / 10, "glTF: %u of %u rays (%u hits) give the same triangle, t, normal and side "
          "on both files, the mirrored node included", same, n, hits);
    rtk_params_destroy(params);
    rtk_scene_free(a);
    rtk_scene_free(b);
}

/* ---- config ---- */

static void expect_config_error(rtk_registry *reg, const char *name, const char *body, const char *want)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", tmpdir, name);
    FILE *f = fopen(path, "w");
    fputs(body, f);
    fclose(f);
    rtk_config *cfg = NULL;
    rtk_status st = rtk_config_load(path, reg, NULL, &cfg);
    const char *msg = st == RTK_OK ? "" : rtk_error_message();
    check(st != RTK_OK && strstr(msg, want) != NULL, "config %s refused: %s", name, msg);
    rtk_config_destroy(cfg);
}

static void test_config(rtk_registry *reg)
{
    const char *obj = "model.obj";
    char path[512];
    snprintf(path, sizeof path, "%s/%s", tmpdir, obj);
    FILE *f = fopen(path, "w");
    fputs("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", f);
    fclose(f);
    expect_config_error(reg, "grid.cfg",
                        "scene = \"model.obj\";\ninstances = (\n  { file = \"model.obj\"; grid = [2, 0, 1]; }\n);\n",
                        "grid.cfg:3: instances[0]: grid: element 2 (0) must be a whole number of copies");
    expect_config_error(reg, "scale.cfg",
                        "scene = \"model.obj\";\ninstances = ( { file = \"model.obj\";\n  scale = [1, 0, 1]; } );\n",
                        "scale.cfg:3: instances[0]: scale must be finite and not zero");
    expect_config_error(reg, "axis.cfg",
                        "scene = \"model.obj\";\ninstances = ( { file = \"model.obj\"; rotate = [0, 0, 0, 45]; } );\n",
                        "axis.cfg:2: instances[0]: rotate: the axis [0, 0, 0] has no direction");
    expect_config_error(reg, "nofile.cfg", "scene = \"model.obj\";\ninstances = ( { grid = [2, 1, 1]; } );\n",
                        "nofile.cfg:2: instances[0]");
    expect_config_error(reg, "typo.cfg",
                        "scene = \"model.obj\";\ninstances = ( { file = \"model.obj\"; trnaslate = [1, 2, 3]; } );\n",
                        "did you mean 'translate'");
    expect_config_error(reg, "many.cfg",
                        "scene = \"model.obj\";\ninstances = ( { file = \"model.obj\"; grid = [1000, 1000, 1000]; } );\n",
                        "many.cfg:2: instances[0]: grid asks for 1000000000 copies");

    /* A missing model is reported where the entry is, at load time. */
    snprintf(path, sizeof path, "%s/missing.cfg", tmpdir);
    f = fopen(path, "w");
    fputs("scene = \"model.obj\";\nfilm = { width = 8; height = 8; spp = 1; };\ncache = \"off\";\n"
          "instances = (\n  { file = \"nowhere.obj\"; }\n);\n", f);
    fclose(f);
    rtk_config *cfg = NULL;
    rtk_status st = rtk_config_load(path, reg, NULL, &cfg);
    if (st == RTK_OK) {
        rtk_render_options opt = {.size = sizeof opt, .quiet = 1};
        rtk_render_report rep;
        memset(&rep, 0, sizeof rep);
        rep.size = sizeof rep;
        st = rtk_render(cfg, &opt, &rep);
    }
    const char *msg = st == RTK_OK ? "" : rtk_error_message();
    check(st != RTK_OK && strstr(msg, "missing.cfg:5: instances[0]") && strstr(msg, "nowhere.obj"),
          "config: a missing instanced model is named with the entry's line: %s", msg);
    rtk_config_destroy(cfg);
    snprintf(path, sizeof path, "%s/missing.png", tmpdir);
    check(access(path, F_OK) != 0, "config: no image is written when an instance fails");
}

/*   test_instancing [TESTDEVICE_DIR]: with the folder of the test device
 *   accelerators, their trees are swapped too. */
int main(int argc, char **argv)
{
    setvbuf(stdout, NULL, _IOLBF, 0);
    snprintf(tmpdir, sizeof tmpdir, "/tmp/rtk-instancing-XXXXXX");
    if (!mkdtemp(tmpdir)) {
        printf("FAIL  cannot make a temporary directory\n");
        return 1;
    }
    rtk_registry *reg = NULL;
    if (rtk_registry_create(&reg) != RTK_OK) {
        printf("FAIL  registry: %s\n", rtk_error_message());
        return 1;
    }
    const char *names[] = {"median", "sah", "lbvh"};
    for (size_t i = 0; i < RTK_COUNTOF(names); i++) {
        const rtk_plugin *p = NULL;
        if (rtk_registry_find(reg, RTK_KIND_ACCELERATOR, names[i], &p) != RTK_OK) {
            check(0, "builder %s found: %s", names[i], rtk_error_message());
            continue;
        }
        test_equivalence(p);
        test_ties(p);
        test_memory(p);
        test_lights(p);
        test_gltf(p);
    }
    const rtk_plugin *embree = NULL;
    if (rtk_registry_find(reg, RTK_KIND_ACCELERATOR, "embree", &embree) == RTK_OK) {
        pair pr;
        make_pair(&pr, RTK_NEED_NORMALS | RTK_NEED_UVS);
        rtk_params *params = rtk_params_defaults(embree);
        rtk_bvh_cache_use use;
        rtk_status st = rtk_bvh_build_cached(pr.inst, embree, params, 1, NULL, &use);
        check(st != RTK_OK && strstr(rtk_error_message(), "pick median, sah or lbvh"),
              "embree (own traversal) is refused for an instanced scene: %s", rtk_error_message());
        rtk_params_destroy(params);
        rtk_scene_free(pr.inst);
        rtk_scene_free(pr.flat);
        free(pr.from);
    } else {
        printf("skip  embree plugin not built\n");
    }
    test_config(reg);
    test_accel_sets(reg);
    if (argc > 1) {
        rtk_registry_add_dir(reg, argv[1], "the test's argument");
        test_device_sets(reg);
    }
    rtk_registry_destroy(reg);
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmpdir);
    if (system(cmd) != 0)
        printf("note  could not remove %s\n", tmpdir);
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}

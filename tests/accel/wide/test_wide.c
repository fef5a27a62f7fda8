/* Tests for the wide BVH (kernel/accel/bvh_wide_build.c, bvh_wide_trace.c):
 * on every traversal path this CPU runs (plain C, SSE, AVX2, AVX-512), the
 * wide BVH answers exactly as the binary traversal and as brute force:
 * same triangle, bit-identical t, u, v, same any-hit answer; on several
 * meshes and builders, for random rays, rays with every combination of
 * +-0 direction components, origins on and next to box faces, and rays
 * with tmin > 0 or < 0. Work counts are the same on every wide path. */
#include "config/config.h"
#include "render/render.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"

static float frand(rtk_pcg32 *rng, float lo, float hi)
{
    return lo + (hi - lo) * rtk_pcg32_float(rng);
}

static void add_tri(rtk_scene *s, rtk_vec3 a, rtk_vec3 b, rtk_vec3 c)
{
    uint32_t i0, i1, i2;
    rtk_scene_add_vertex(s, a.x, a.y, a.z, &i0);
    rtk_scene_add_vertex(s, b.x, b.y, b.z, &i1);
    rtk_scene_add_vertex(s, c.x, c.y, c.z, &i2);
    rtk_scene_add_triangle(s, i0, i1, i2, NULL, NULL, RTK_INVALID_ID);
}

/* count random triangles centred in [lo, hi]^3, corners within size of
 * the centre. */
static void add_soup_in(rtk_scene *s, rtk_pcg32 *rng, int count, float lo, float hi, float size)
{
    for (int i = 0; i < count; i++) {
        rtk_vec3 c = rtk_vec3_make(frand(rng, lo, hi), frand(rng, lo, hi), frand(rng, lo, hi));
        rtk_vec3 v[3];
        for (int k = 0; k < 3; k++)
            v[k] = rtk_vec3_add(c, rtk_vec3_make(frand(rng, -size, size), frand(rng, -size, size),
                                                 frand(rng, -size, size)));
        add_tri(s, v[0], v[1], v[2]);
    }
}

/* count random triangles in [-1, 1]^3, corners within size of a centre. */
static void add_soup(rtk_scene *s, rtk_pcg32 *rng, int count, float size)
{
    add_soup_in(s, rng, count, -1, 1, size);
}

/* Axis-aligned box [lo, hi] as 12 triangles. */
static void add_box(rtk_scene *s, rtk_vec3 lo, rtk_vec3 hi)
{
    rtk_vec3 p[8];
    for (int i = 0; i < 8; i++)
        p[i] = rtk_vec3_make(i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z);
    static const int quads[6][4] = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
    for (int q = 0; q < 6; q++) {
        add_tri(s, p[quads[q][0]], p[quads[q][1]], p[quads[q][2]]);
        add_tri(s, p[quads[q][0]], p[quads[q][2]], p[quads[q][3]]);
    }
}

enum { MESH_SOUP, MESH_DEGENERATE, MESH_SPHERE, MESH_SPHERE_FAR, MESH_BOXES, MESH_BUNNY, MESH_COUNT };

/* Test meshes, raw (no rtk_scene_finish) so that degenerate and duplicate
 * triangles reach the builder; NULL when the mesh is not available. */
static rtk_scene *make_mesh(int which, const char **name)
{
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 77u + (uint64_t)which, 3u);
    if (which == MESH_BUNNY) {
        *name = "bunny";
        rtk_scene *s = NULL;
        if (rtk_scene_load(RTK_SOURCE_ROOT "/../shared/data/meshes/bunny.obj", 0, &s) != RTK_OK)
            return NULL;
        return s;
    }
    rtk_scene *s = rtk_scene_new("wide", 0);
    switch (which) {
    case MESH_SOUP:
        *name = "3000 random triangles";
        add_soup(s, &rng, 3000, .1f);
        break;
    case MESH_DEGENERATE:
        *name = "degenerate, duplicate and coplanar triangles";
        for (int i = 0; i < 600; i++) {
            rtk_vec3 a = rtk_vec3_make(frand(&rng, -1, 1), frand(&rng, -1, 1), frand(&rng, -1, 1));
            rtk_vec3 b = rtk_vec3_add(a, rtk_vec3_make(frand(&rng, -.2f, .2f), frand(&rng, -.2f, .2f), 0.1f));
            if (i % 4 == 0)
                add_tri(s, a, a, a);
            else if (i % 4 == 1)
                add_tri(s, a, b, rtk_vec3_scale(rtk_vec3_add(a, b), 0.5f));
            else
                add_tri(s, a, b, rtk_vec3_add(a, rtk_vec3_make(0.1f, -0.05f, 0.2f)));
        }
        for (int i = 0; i < 300; i++)
            add_tri(s, rtk_vec3_make(-1, -1, 0), rtk_vec3_make(1, -1, 0), rtk_vec3_make(0, 1, 0));
        for (int i = 0; i < 100; i++)
            add_tri(s, rtk_vec3_make(frand(&rng, -1, 0), -1, 0), rtk_vec3_make(1, frand(&rng, -1, 0), 0),
                    rtk_vec3_make(0, 1, 0));
        break;
    case MESH_SPHERE:
    case MESH_SPHERE_FAR: {
        *name = which == MESH_SPHERE ? "closed sphere" : "closed sphere at (1e5, 1e5, 1e5)";
        double off = which == MESH_SPHERE ? 0.0 : 1e5;
        const int nu = 64, nv = 32;
        for (int j = 0; j < nv; j++) {
            for (int i = 0; i < nu; i++) {
                rtk_vec3 p[4];
                for (int k = 0; k < 4; k++) {
                    int ii = i + (k == 1 || k == 2), jj = j + (k >= 2);
                    double th = M_PI * jj / nv, ph = 2.0 * M_PI * (ii % nu) / nu;
                    p[k] = rtk_vec3_make((float)(off + sin(th) * cos(ph)), (float)(off + cos(th)),
                                         (float)(off + sin(th) * sin(ph)));
                }
                add_tri(s, p[0], p[1], p[2]);
                add_tri(s, p[0], p[2], p[3]);
            }
        }
        break;
    }
    default:
        *name = "grid of unit boxes";
        for (int x = -2; x < 2; x++)
            for (int y = -2; y < 2; y++)
                for (int z = -2; z < 2; z++)
                    if ((x + y + z) & 1)
                        add_box(s, rtk_vec3_make((float)x, (float)y, (float)z),
                                rtk_vec3_make(x + 1.0f, y + 1.0f, z + 1.0f));
        break;
    }
    return s;
}

static int brute_closest(const rtk_scene *s, const rtk_ray *ray, rtk_hit *hit)
{
    hit->prim = RTK_INVALID_ID;
    hit->t = ray->tmax;
    hit->u = hit->v = 0.0f;
    for (uint32_t i = 0; i < s->triangle_count; i++) {
        rtk_vec3 a, b, c;
        rtk_scene_triangle(s, i, &a, &b, &c);
        float t, u, v;
        if (rtk_intersect_triangle(ray, a, b, c, &t, &u, &v) && (t < hit->t || (t == hit->t && i < hit->prim)))
            hit->t = t, hit->u = u, hit->v = v, hit->prim = i;
    }
    return hit->prim != RTK_INVALID_ID;
}

static int same_hit(int a, const rtk_hit *h1, int b, const rtk_hit *h2)
{
    if (a != b)
        return 0;
    if (!a)
        return 1;
    return h1->prim == h2->prim && memcmp(&h1->t, &h2->t, sizeof(float)) == 0 &&
           memcmp(&h1->u, &h2->u, sizeof(float)) == 0 && memcmp(&h1->v, &h2->v, sizeof(float)) == 0;
}

/* Ray i of a mesh's set: aimed at triangles (a quarter on edges), random,
 * axis-aligned with +-0 components from box faces, some with tmin > 0
 * or < 0 and finite tmax. */
static rtk_ray make_ray(const rtk_scene *s, rtk_pcg32 *rng, int i)
{
    rtk_bounds b = s->bounds;
    rtk_vec3 lo = b.lower, hi = b.upper;
    if (s->triangle_count > 0 && !(lo.x <= hi.x)) {
        rtk_vec3 a, bb, c;
        rtk_scene_triangle(s, 0, &a, &bb, &c);
        lo = hi = a;
    }
    rtk_vec3 mid = rtk_vec3_scale(rtk_vec3_add(lo, hi), 0.5f);
    rtk_vec3 ext = rtk_vec3_sub(hi, lo);
    float size = fmaxf(ext.x, fmaxf(ext.y, ext.z)) + 1e-3f;
    rtk_ray r;
    r.org = rtk_vec3_make(mid.x + frand(rng, -size, size), mid.y + frand(rng, -size, size),
                          mid.z + frand(rng, -size, size));
    r.tmin = 0.0f;
    r.tmax = INFINITY;
    int kind = i % 8;
    if (kind <= 3 && s->triangle_count > 0) {
        rtk_vec3 a, bb, c;
        rtk_scene_triangle(s, rtk_pcg32_next(rng) % s->triangle_count, &a, &bb, &c);
        float u = rtk_pcg32_float(rng), v = rtk_pcg32_float(rng);
        if (kind == 0)
            v = 0.0f;
        if (u + v > 1.0f)
            u = 1.0f - u, v = 1.0f - v;
        rtk_vec3 target =
            rtk_vec3_add(a, rtk_vec3_add(rtk_vec3_scale(rtk_vec3_sub(bb, a), u), rtk_vec3_scale(rtk_vec3_sub(c, a), v)));
        r.dir = rtk_vec3_sub(target, r.org);
        if (kind == 3)
            r.dir = rtk_vec3_normalize(r.dir);
    } else if (kind <= 5) {
        /* Every component one of +1, -1, +0, -0 (not all zero); the origin
         * on a grid plane (box faces of the boxes mesh) or next to it. */
        static const float comp[4] = {1.0f, -1.0f, 0.0f, -0.0f};
        float d[3];
        do {
            for (int k = 0; k < 3; k++)
                d[k] = comp[rtk_pcg32_next(rng) % 4];
        } while (d[0] == 0.0f && d[1] == 0.0f && d[2] == 0.0f);
        r.dir = rtk_vec3_make(d[0], d[1], d[2]);
        float o[3] = {roundf(r.org.x * 2.0f) * 0.5f, roundf(r.org.y * 2.0f) * 0.5f, roundf(r.org.z * 2.0f) * 0.5f};
        for (int k = 0; k < 3; k++) {
            uint32_t m = rtk_pcg32_next(rng) % 4;
            if (m == 1)
                o[k] = nextafterf(o[k], INFINITY);
            else if (m == 2)
                o[k] = nextafterf(o[k], -INFINITY);
        }
        r.org = rtk_vec3_make(o[0], o[1], o[2]);
    } else {
        r.dir = rtk_vec3_make(frand(rng, -1, 1), frand(rng, -1, 1), frand(rng, -1, 1));
        if (r.dir.x == 0.0f && r.dir.y == 0.0f && r.dir.z == 0.0f)
            r.dir.x = 1.0f;
    }
    uint32_t range = rtk_pcg32_next(rng) % 6;
    if (range == 1)
        r.tmax = frand(rng, 0.1f, 2.0f) * size;
    else if (range == 2)
        r.tmin = frand(rng, 0.0f, 0.5f) * size;
    else if (range == 3)
        r.tmin = -frand(rng, 0.0f, 0.5f) * size;
    return r;
}

/* A builder that puts every primitive in one leaf: leaves larger than a
 * wide leaf reference can hold. */
static rtk_status one_leaf_build(void *state, rtk_build_args *a)
{
    (void)state;
    rtk_bounds b = a->prim_bounds[0];
    for (uint32_t i = 1; i < a->prim_count; i++) {
        const rtk_bounds *p = &a->prim_bounds[i];
        b.lower = rtk_vec3_make(fminf(b.lower.x, p->lower.x), fminf(b.lower.y, p->lower.y), fminf(b.lower.z, p->lower.z));
        b.upper = rtk_vec3_make(fmaxf(b.upper.x, p->upper.x), fmaxf(b.upper.y, p->upper.y), fmaxf(b.upper.z, p->upper.z));
    }
    rtk_bvh_node *n = &a->nodes[0];
    n->lower[0] = b.lower.x, n->lower[1] = b.lower.y, n->lower[2] = b.lower.z;
    n->upper[0] = b.upper.x, n->upper[1] = b.upper.y, n->upper[2] = b.upper.z;
    n->offset = 0, n->count = a->prim_count;
    for (uint32_t i = 0; i < a->prim_count; i++)
        a->prim_order[i] = i;
    a->node_count = 1;
    return RTK_OK;
}

/* A builder that makes a chain: each inner node holds one primitive's leaf
 * and the rest of the chain, 200 deep, then one leaf with everything left:
 * the deepest trees the stack must hold. */
static rtk_status chain_build(void *state, rtk_build_args *a)
{
    (void)state;
    uint32_t n = a->prim_count, links = n > 200 ? 200 : n - 1;
    for (uint32_t i = 0; i < n; i++)
        a->prim_order[i] = i;
    /* Node 2k is inner (children 2k+1 = leaf of prim k, 2k+2 = the rest) for
     * k < links; node 2 * links is the last leaf, over [links, n). */
    for (uint32_t k = 0; k <= links; k++) {
        uint32_t first = k, count = k < links ? 1 : n - links;
        rtk_bvh_node *leaf = &a->nodes[k < links ? 2 * k + 1 : 2 * k];
        rtk_bounds b = a->prim_bounds[first];
        for (uint32_t i = first + 1; i < first + count; i++) {
            const rtk_bounds *p = &a->prim_bounds[i];
            b.lower = rtk_vec3_make(fminf(b.lower.x, p->lower.x), fminf(b.lower.y, p->lower.y), fminf(b.lower.z, p->lower.z));
            b.upper = rtk_vec3_make(fmaxf(b.upper.x, p->upper.x), fmaxf(b.upper.y, p->upper.y), fmaxf(b.upper.z, p->upper.z));
        }
        leaf->lower[0] = b.lower.x, leaf->lower[1] = b.lower.y, leaf->lower[2] = b.lower.z;
        leaf->upper[0] = b.upper.x, leaf->upper[1] = b.upper.y, leaf->upper[2] = b.upper.z;
        leaf->offset = first, leaf->count = count;
    }
    for (uint32_t k = links; k-- > 0;) {
        rtk_bvh_node *n0 = &a->nodes[2 * k], *l = &a->nodes[2 * k + 1], *r = &a->nodes[2 * k + 2];
        for (int j = 0; j < 3; j++) {
            n0->lower[j] = fminf(l->lower[j], r->lower[j]);
            n0->upper[j] = fmaxf(l->upper[j], r->upper[j]);
        }
        n0->offset = 2 * k + 1, n0->count = 0;
    }
    a->node_count = 2 * links + 1;
    return RTK_OK;
}

static const rtk_accelerator_fns one_leaf_fns = {
    .size = sizeof(rtk_accelerator_fns), .create = stateless_create, .build = one_leaf_build, .destroy = stateless_destroy};
static const rtk_plugin one_leaf = {RTK_PLUGIN_HEADER, .kind = RTK_KIND_ACCELERATOR, .name = "one_leaf",
                                    .version = "1", .summary = "one leaf", .functions = &one_leaf_fns};
static const rtk_accelerator_fns chain_fns = {
    .size = sizeof(rtk_accelerator_fns), .create = stateless_create, .build = chain_build, .destroy = stateless_destroy};
static const rtk_plugin chain = {RTK_PLUGIN_HEADER, .kind = RTK_KIND_ACCELERATOR, .name = "chain",
                                 .version = "1", .summary = "a 200-deep chain", .functions = &chain_fns};

/* Compares every wide path with the binary traversal and brute force on
 * count rays of scene s built by plugin. */
static void compare_paths(rtk_scene *s, const char *mesh, const char *builder, int count)
{
    rtk_simd_path paths[RTK_SIMD_PATHS];
    int npaths = 0;
    for (int p = RTK_SIMD_SCALAR; p < RTK_SIMD_PATHS; p++)
        if (rtk_simd_supported((rtk_simd_path)p))
            paths[npaths++] = (rtk_simd_path)p;
    check(s->wide != NULL, "%s / %s: wide BVH built (%u nodes, %u blocks, depth %u)", mesh, builder,
          s->wide ? s->wide->node_count : 0, s->wide ? s->wide->tri_block_count : 0, s->wide ? s->wide->depth : 0);
    if (!s->wide)
        return;
    rtk_simd_path saved = s->wide->path;
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 5u, 11u);
    int bad_binary = 0, bad_brute[RTK_SIMD_PATHS] = {0}, bad_any[RTK_SIMD_PATHS] = {0}, bad_work = 0,
        bad_measure = 0, hits = 0, more_work = 0;
    int bad_vs_binary[RTK_SIMD_PATHS] = {0};
    char first[RTK_SIMD_PATHS][512] = {""};
    for (int i = 0; i < count; i++) {
        rtk_ray ray = make_ray(s, &rng, i);
        if (!rtk_ray_valid(&ray))
            continue;
        rtk_hit hb, hf;
        s->wide->path = RTK_SIMD_BINARY;
        int b = rtk_bvh_closest(s, &ray, &hb);
        int b_any = rtk_bvh_any(s, &ray);
        int f = brute_closest(s, &ray, &hf);
        hits += f;
        if (!same_hit(b, &hb, f, &hf))
            bad_binary++;
        /* The first path's work; for occlusion, of each family
         * (box_int_note in kernel/accel/bvh_wide_trace.c): the float
         * reductions (scalar, SSE) and the integer ones (AVX2, AVX-512). */
        rtk_trace_work work0 = {0, 0}, awork0[2] = {{0, 0}, {0, 0}};
        int seen[2] = {0, 0};
        for (int p = 0; p < npaths; p++) {
            rtk_hit hw;
            rtk_trace_work work = {0, 0};
            int w = ray.tmin >= 0.0f ? rtk_wide_closest(s, paths[p], &ray, &hw, NULL)
                                     : (s->wide->path = paths[p], rtk_bvh_closest(s, &ray, &hw));
            if (!same_hit(w, &hw, b, &hb) && !bad_vs_binary[p]++ &&
                !bad_brute[p])
                snprintf(first[p], sizeof first[p],
                         "ray %d org (%a %a %a) dir (%a %a %a) [%g, %g]: wide %d prim %u t %a u %a, binary %d prim %u t %a u %a",
                         i, ray.org.x, ray.org.y, ray.org.z, ray.dir.x, ray.dir.y, ray.dir.z, ray.tmin, ray.tmax, w,
                         hw.prim, hw.t, hw.u, b, hb.prim, hb.t, hb.u);
            if (!same_hit(w, &hw, f, &hf) && !bad_brute[p]++)
                snprintf(first[p], sizeof first[p],
                         "ray %d org (%a %a %a) dir (%a %a %a) [%g, %g]: wide %d prim %u t %a u %a, brute %d prim %u t %a u %a",
                         i, ray.org.x, ray.org.y, ray.org.z, ray.dir.x, ray.dir.y, ray.dir.z, ray.tmin, ray.tmax, w,
                         hw.prim, hw.t, hw.u, f, hf.prim, hf.t, hf.u);
            int wa = ray.tmin >= 0.0f ? rtk_wide_any(s, paths[p], &ray, NULL)
                                      : (s->wide->path = paths[p], rtk_bvh_any(s, &ray));
            if (wa != b_any)
                bad_any[p]++;
            if (ray.tmin >= 0.0f) {
                rtk_hit hm;
                int m = rtk_wide_closest(s, paths[p], &ray, &hm, &work);
                if (!same_hit(m, &hm, w, &hw))
                    bad_measure++;
                rtk_trace_work awork = {0, 0};
                if (rtk_wide_any(s, paths[p], &ray, &awork) != wa)
                    bad_measure++;
                int fam = paths[p] >= RTK_SIMD_AVX2;
                if (p == 0)
                    work0 = work;
                else if (work.nodes != work0.nodes || work.triangles != work0.triangles)
                    bad_work++;
                if (!seen[fam])
                    seen[fam] = 1, awork0[fam] = awork;
                else if (awork.nodes != awork0[fam].nodes || awork.triangles != awork0[fam].triangles)
                    bad_work++;
                /* The integer reductions pass a box the float ones miss
                 * only where an exit distance is -0 (an origin on a box's
                 * exit plane) and another is negative; nothing in such a
                 * box is hit, but the order of the occlusion's visits may
                 * change (the hits are checked above). */
                if (fam == 1 && seen[0] &&
                    (awork.nodes != awork0[0].nodes || awork.triangles != awork0[0].triangles))
                    more_work++;
            }
        }
    }
    s->wide->path = saved;
    check(bad_binary == 0, "%s / %s: binary traversal = brute force, bit for bit, on %d rays (%d hits): %d differ",
          mesh, builder, count, hits, bad_binary);
    for (int p = 0; p < npaths; p++) {
        check(bad_brute[p] == 0, "%s / %s: %s closest hit = brute force, bit for bit: %d differ%s%s", mesh, builder,
              rtk_simd_name(paths[p]), bad_brute[p], bad_brute[p] ? "; first: " : "", first[p]);
        check(bad_vs_binary[p] == 0, "%s / %s: %s closest hit = binary traversal, bit for bit: %d differ%s%s", mesh, builder,
              rtk_simd_name(paths[p]), bad_vs_binary[p], bad_vs_binary[p] && !bad_brute[p] ? "; first: " : "",
              bad_vs_binary[p] && !bad_brute[p] ? first[p] : "");
        check(bad_any[p] == 0, "%s / %s: %s any hit = binary traversal: %d differ", mesh, builder,
              rtk_simd_name(paths[p]), bad_any[p]);
    }
    check(bad_measure == 0, "%s / %s: counting work leaves hits unchanged: %d differ", mesh, builder, bad_measure);
    check(bad_work == 0,
          "%s / %s: every wide path counts the same work for closest hit, and for occlusion every path of one "
          "box arithmetic: %d differ (%d rays with other occlusion work on the integer paths)",
          mesh, builder, bad_work, more_work);
}

/* Batches (rtk_wide_closest_batch, rtk_wide_any_batch) against single
 * rays on every path, bit for bit: a pinhole camera's rays from outside
 * the mesh (coherent: the AVX paths trace most of them as frustum
 * packets), the same cut short (finite tmax), eight rays from each of
 * some hits in random directions, short and long, each with its own
 * interval (origin groups), shadow
 * rays from the hits towards one point, and eight rays from each of those
 * points aimed at a triangle's corners, edge midpoints and centroid
 * (origin groups whose lanes reach the triangle test's edge cases), each
 * set alone and all interleaved (streams). */
static void compare_batches(rtk_scene *s, const char *mesh, const char *builder)
{
    if (!s->wide)
        return;
    enum { W = 48, H = 32, SETS = 5, N = SETS * W * H };
    rtk_ray *rays = malloc(sizeof(rtk_ray) * N), *mixed = malloc(sizeof(rtk_ray) * N);
    rtk_hit *single = malloc(sizeof(rtk_hit) * N), *batch = malloc(sizeof(rtk_hit) * N);
    uint8_t *occ_single = malloc(N), *occ_batch = malloc(N);
    if (!rays || !mixed || !single || !batch || !occ_single || !occ_batch) {
        check(0, "%s / %s: memory for the batch comparison", mesh, builder);
        goto done;
    }
    const rtk_bounds b = s->bounds;
    const rtk_vec3 c = rtk_vec3_scale(rtk_vec3_add(b.lower, b.upper), 0.5f);
    const float r = 0.5f * rtk_vec3_length(rtk_vec3_sub(b.upper, b.lower));
    const rtk_vec3 eye = rtk_vec3_add(c, rtk_vec3_make(0.9f * r, 0.7f * r, 2.5f * r));
    const rtk_vec3 fwd = rtk_vec3_normalize(rtk_vec3_sub(c, eye));
    const rtk_vec3 right = rtk_vec3_normalize(rtk_vec3_cross(fwd, rtk_vec3_make(0, 1, 0)));
    const rtk_vec3 up = rtk_vec3_cross(right, fwd);
    const rtk_vec3 light = rtk_vec3_add(c, rtk_vec3_make(-3.0f * r, 4.0f * r, 1.0f * r));
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 9u, 1u);
    rtk_simd_path saved = s->wide->path;
    for (int p = RTK_SIMD_SCALAR; p < RTK_SIMD_PATHS; p++) {
        if (!rtk_simd_supported((rtk_simd_path)p))
            continue;
        s->wide->path = (rtk_simd_path)p;
        /* Camera rays, then the same ending at 60 % of the distance to the
         * centre, then from their hits: random and shadow rays. */
        uint32_t n = 0;
        for (int k = 0; k < 2; k++)
            for (int y = 0; y < H; y++)
                for (int x = 0; x < W; x++) {
                    float sx = (2.0f * ((float)x + 0.5f) / W - 1.0f) * 0.6f, sy = (1.0f - 2.0f * ((float)y + 0.5f) / H) * 0.4f;
                    rtk_ray *q = &rays[n++];
                    q->org = eye;
                    q->dir = rtk_vec3_normalize(rtk_vec3_add(fwd, rtk_vec3_add(rtk_vec3_scale(right, sx), rtk_vec3_scale(up, sy))));
                    q->tmin = 0.0f;
                    q->tmax = k ? 0.6f * rtk_vec3_length(rtk_vec3_sub(c, eye)) + 0.4f * r : INFINITY;
                }
        rtk_vec3 at = c;
        for (uint32_t i = 0; i < (uint32_t)(W * H); i++) {
            rtk_hit h;
            if (i % 8 == 0) /* eight random rays from each point, half of the groups short (occlusion) */
                at = rtk_wide_closest(s, (rtk_simd_path)p, &rays[i], &h, NULL)
                         ? rtk_vec3_add(rays[i].org, rtk_vec3_scale(rays[i].dir, h.t))
                         : rtk_vec3_add(c, rtk_vec3_make(frand(&rng, -r, r), frand(&rng, -r, r), frand(&rng, -r, r)));
            rtk_ray *q = &rays[n + i];
            q->org = at;
            q->dir = rtk_vec3_make(frand(&rng, -1, 1), frand(&rng, -1, 1), frand(&rng, -1, 1));
            /* Each lane of a group with its own interval: the first
             * starts far out, the short ones end at different distances. */
            q->tmin = i % 8 == 0 ? 0.1f * r : 1e-4f * r;
            q->tmax = i % 16 < 8 ? (0.12f + 0.02f * (float)(i % 8)) * r : INFINITY;
            rtk_ray *sh = &rays[n + W * H + i];
            sh->org = at;
            sh->dir = rtk_vec3_sub(light, at);
            sh->tmin = 1e-4f;
            sh->tmax = 1.0f;
            /* From the same point: corners, edge midpoints, centroid, and
             * the corner again with tmax ending on it. */
            rtk_vec3 v[3];
            rtk_scene_triangle(s, (i / 8 * 7919u) % s->triangle_count, &v[0], &v[1], &v[2]);
            const rtk_vec3 aims[8] = {v[0], v[1], v[2],
                                      rtk_vec3_scale(rtk_vec3_add(v[0], v[1]), 0.5f),
                                      rtk_vec3_scale(rtk_vec3_add(v[1], v[2]), 0.5f),
                                      rtk_vec3_scale(rtk_vec3_add(v[2], v[0]), 0.5f),
                                      rtk_vec3_scale(rtk_vec3_add(rtk_vec3_add(v[0], v[1]), v[2]), 1.0f / 3.0f),
                                      v[0]};
            rtk_ray *aim = &rays[n + 2 * W * H + i];
            aim->org = at;
            aim->dir = rtk_vec3_sub(aims[i % 8], at);
            aim->tmin = 0.0f;
            aim->tmax = i % 8 == 7 ? 1.0f : INFINITY;
        }
        /* All interleaved: a camera ray, a random one, a shadow ray, ... */
        for (uint32_t i = 0; i < (uint32_t)N; i++)
            mixed[i] = rays[(i % SETS) * (W * H) + i / SETS];
        for (int set = 0; set < 2; set++) {
            const rtk_ray *in = set ? mixed : rays;
            int bad_closest = 0, bad_any = 0;
            for (uint32_t i = 0; i < (uint32_t)N; i++) {
                if (!rtk_wide_closest(s, (rtk_simd_path)p, &in[i], &single[i], NULL))
                    single[i].prim = RTK_INVALID_ID;
                occ_single[i] = (uint8_t)rtk_wide_any(s, (rtk_simd_path)p, &in[i], NULL);
            }
            uint64_t before = rtk_wide_packet_rays();
            for (uint32_t i = 0; i < (uint32_t)N; i += 256) {
                rtk_wide_closest_batch(s, (rtk_simd_path)p, in + i, 256, batch + i);
                rtk_wide_any_batch(s, (rtk_simd_path)p, in + i, 256, occ_batch + i);
            }
            uint64_t packed = rtk_wide_packet_rays() - before;
            for (uint32_t i = 0; i < (uint32_t)N; i++) {
                bad_closest += !same_hit(single[i].prim != RTK_INVALID_ID, &single[i],
                                         batch[i].prim != RTK_INVALID_ID, &batch[i]);
                bad_any += occ_single[i] != occ_batch[i];
            }
            check(bad_closest == 0 && bad_any == 0,
                  "%s / %s: %s batches = single rays, bit for bit, %s (%d rays, %llu of closest and any in packets): "
                  "%d closest and %d occlusion results differ",
                  mesh, builder, rtk_simd_name((rtk_simd_path)p),
                  set ? "interleaved" : "camera, short, random, shadow, aimed",
                  N, (unsigned long long)packed, bad_closest, bad_any);
            if (p >= RTK_SIMD_AVX2 && !set) {
                /* The random rays alone: closest hit traces them all in streams, occlusion in
                 * origin groups. */
                uint64_t mark = rtk_wide_packet_rays();
                rtk_wide_closest_batch(s, (rtk_simd_path)p, rays + 2 * W * H, W * H, batch);
                rtk_wide_any_batch(s, (rtk_simd_path)p, rays + 2 * W * H, W * H, occ_batch);
                uint64_t streamed = rtk_wide_packet_rays() - mark;
                check(packed >= (uint64_t)W * H && streamed == 2u * W * H,
                      "%s / %s: %s traces the camera rays as packets (%llu rays in packets) and the random "
                      "rays in streams and origin groups (%llu of 2 x %d, closest and any)",
                      mesh, builder, rtk_simd_name((rtk_simd_path)p), (unsigned long long)packed,
                      (unsigned long long)streamed, W * H);
            }
        }
    }
    s->wide->path = saved;
done:
    free(rays);
    free(mixed);
    free(single);
    free(batch);
    free(occ_single);
    free(occ_batch);
}

/* rtk_trace_measure through a render context equals rtk_trace. */
/* The wide tree collapsed on 1 and on 3 threads equals the one the build
 * made on 2, byte for byte (bunny is large enough to be split). */
static void check_threads_same(rtk_scene *s, const char *mesh, const char *builder)
{
    if (!s->wide)
        return;
    rtk_wide_bvh *made = s->wide;
    s->wide = NULL;
    int same = 1;
    for (uint32_t t = 1; t <= 3; t += 2) {
        if (rtk_wide_build(s, t, NULL, 0, t == 3) != RTK_OK || !s->wide) { /* on 3, validating as it plans */
            same = 0;
            continue;
        }
        same &= s->wide->node_count == made->node_count && s->wide->tri_block_count == made->tri_block_count &&
                s->wide->depth == made->depth &&
                memcmp(s->wide->nodes, made->nodes, sizeof *made->nodes * made->node_count) == 0 &&
                memcmp(s->wide->tris, made->tris, sizeof *made->tris * made->tri_block_count) == 0;
        rtk_wide_free(s);
    }
    s->wide = made;
    check(same, "%s / %s: the wide tree is the same collapsed on 1, 2 and 3 threads (%u nodes, %u blocks)", mesh,
          builder, made->node_count, made->tri_block_count);
}

/* A tree with more nodes than references address is refused with a
 * message naming both numbers, and the scene then traces its binary tree
 * with the same answers (the limit lowered to reach it on bunny). */
static void check_node_limit(rtk_scene *s, const char *mesh, const char *builder, const rtk_plugin *p,
                             const rtk_params *params)
{
    if (!s->wide || s->wide->node_count < 3)
        return;
    enum { RAYS = 2000 };
    static rtk_hit wide_hits[RAYS];
    static int wide_any[RAYS];
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 17u, 3u);
    for (int i = 0; i < RAYS; i++) {
        rtk_ray ray = make_ray(s, &rng, i);
        wide_hits[i].prim = RTK_INVALID_ID;
        if (rtk_ray_valid(&ray))
            (void)rtk_bvh_closest(s, &ray, &wide_hits[i]), wide_any[i] = rtk_bvh_any(s, &ray);
    }
    const uint32_t nodes = s->wide->node_count;
    rtk_wide_node_limit = nodes - 1;
    rtk_wide_bvh *made = s->wide;
    s->wide = NULL;
    rtk_status st = rtk_wide_build(s, 2, NULL, 0, 0);
    char want[96];
    snprintf(want, sizeof want, "%u nodes and %u blocks, more than its references address (%u nodes,", nodes,
             made->tri_block_count, nodes - 1);
    check(st == RTK_ERR_NOMEM && !s->wide && strstr(rtk_error_message(), want),
          "%s / %s: a wide tree of more nodes than the limit is refused: \"%s\"", mesh, builder,
          rtk_error_message());
    rtk_wide_free(s);
    s->wide = made;
    st = rtk_bvh_build(s, p, params, 2);
    int bad = 0;
    rtk_pcg32_seed(&rng, 17u, 3u);
    for (int i = 0; i < RAYS && st == RTK_OK; i++) {
        rtk_ray ray = make_ray(s, &rng, i);
        if (!rtk_ray_valid(&ray))
            continue;
        rtk_hit h;
        int hit = rtk_bvh_closest(s, &ray, &h);
        bad += hit != (wide_hits[i].prim != RTK_INVALID_ID) || (hit && (h.prim != wide_hits[i].prim ||
                                                                       h.t != wide_hits[i].t)) ||
               rtk_bvh_any(s, &ray) != wide_any[i];
    }
    check(st == RTK_OK && !s->wide && bad == 0,
          "%s / %s: over the limit the build keeps the binary tree, whose answers are the wide tree's: %d differ",
          mesh, builder, bad);
    rtk_wide_node_limit = RTK_WIDE_MAX_NODES;
}

/* The scene's bounds from its vertices (raw scenes skip rtk_scene_finish). */
static void set_bounds(rtk_scene *s)
{
    rtk_bounds b = {rtk_vec3_make(INFINITY, INFINITY, INFINITY), rtk_vec3_make(-INFINITY, -INFINITY, -INFINITY)};
    for (uint32_t v = 0; v < s->vertex_count; v++) {
        const float *p = s->positions + 3 * (size_t)v;
        b.lower = rtk_vec3_make(fminf(b.lower.x, p[0]), fminf(b.lower.y, p[1]), fminf(b.lower.z, p[2]));
        b.upper = rtk_vec3_make(fmaxf(b.upper.x, p[0]), fmaxf(b.upper.y, p[1]), fmaxf(b.upper.z, p[2]));
    }
    s->bounds = b;
}

/* count random triangles and copies of one more, bounds set for a build. */
static rtk_scene *soup(uint32_t count, uint32_t copies)
{
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, count, 7u);
    rtk_scene *s = rtk_scene_new("soup", 0);
    add_soup(s, &rng, (int)count, .02f);
    for (uint32_t i = 0; i < copies; i++)
        add_tri(s, rtk_vec3_make(.3f, .3f, .3f), rtk_vec3_make(.31f, .3f, .3f), rtk_vec3_make(.3f, .31f, .3f));
    set_bounds(s);
    return s;
}

/* A builder on count triangles (150,000 are enough for every threaded
 * path: the builders' parts and queues, the kernel's inputs, validation,
 * leaf check and collapse plan) and copies of one more: the same binary
 * tree, leaf order and wide tree on 1, 2, 3 and 16 threads (lbvh's
 * narrower top digits and smaller subtrees there; sah's team splits of
 * more or fewer levels, and with copies nodes that nothing but a count
 * divides), byte for byte. With key set, its parameter key is value. */
static void check_builder_threads(const rtk_plugin *p, uint32_t count, uint32_t copies, const char *key,
                                  const char *value)
{
    rtk_scene *first = NULL;
    int same = 1, built = 1;
    uint32_t nodes = 0;
    static const uint32_t threads[] = {1, 2, 3, 16};
    for (size_t ti = 0; ti < sizeof threads / sizeof *threads; ti++) {
        const uint32_t t = threads[ti];
        rtk_scene *s = soup(count, copies);
        rtk_params *params = rtk_params_defaults(p);
        if (key && params)
            rtk_params_set_text(params, key, value);
        if (rtk_bvh_build(s, p, params, t) != RTK_OK || !s->wide) {
            built = 0;
        } else if (!first) {
            first = s, s = NULL;
            nodes = first->node_count;
        } else {
            same &= s->node_count == first->node_count &&
                    memcmp(s->nodes, first->nodes, sizeof *s->nodes * s->node_count) == 0 &&
                    memcmp(s->prim_ids, first->prim_ids, sizeof *s->prim_ids * s->triangle_count) == 0 &&
                    s->wide->node_count == first->wide->node_count &&
                    s->wide->tri_block_count == first->wide->tri_block_count &&
                    memcmp(s->wide->nodes, first->wide->nodes, sizeof *s->wide->nodes * s->wide->node_count) == 0 &&
                    memcmp(s->wide->tris, first->wide->tris, sizeof *s->wide->tris * s->wide->tri_block_count) == 0;
        }
        rtk_params_destroy(params);
        if (s)
            rtk_scene_free(s);
    }
    char name[96];
    snprintf(name, sizeof name, "%s%s%s%s", p->name, key ? " " : "", key ? key : "", key ? "=" : "");
    if (key)
        strncat(name, value, sizeof name - strlen(name) - 1);
    check(built, "%u triangles (%u copies of one) / %s: builds on 1, 2, 3 and 16 threads", count + copies, copies,
          name);
    check(built && same, "%u triangles (%u copies of one) / %s: the same tree (%u nodes), leaf order and wide tree "
          "on 1, 2, 3 and 16 threads", count + copies, copies, name, nodes);
    if (first)
        rtk_scene_free(first);
}

/* Morton code of centroid c, recomputed here bit by bit: quantised in
 * [lo, lo + 2^per_axis / scale) as lbvh does (NaN and below to 0, above
 * to the last cell), then x, y, z interleaved from the top. */
static uint64_t morton_ref(rtk_vec3 c, const float lo[3], const float scale[3], uint32_t per_axis)
{
    const float last = (float)(1u << per_axis) - 1.0f, v[3] = {c.x, c.y, c.z};
    uint64_t q[3], code = 0;
    for (int k = 0; k < 3; k++) {
        float f = (v[k] - lo[k]) * scale[k];
        q[k] = f >= last ? (uint64_t)last : f > 0.0f ? (uint64_t)f : 0;
    }
    for (uint32_t b = 0; b < per_axis; b++)
        for (int k = 0; k < 3; k++)
            code |= (q[k] >> b & 1) << (3 * b + 2 - k);
    return code;
}

/* Slots of s's leaf order whose codes run backwards, or tie out of
 * index order (lbvh's order is a stable sort of the Morton codes). */
static uint32_t morton_disorder(const rtk_scene *s, uint32_t bits)
{
    const uint32_t n = s->triangle_count, per_axis = bits / 3;
    rtk_bounds *bounds = malloc(sizeof *bounds * n);
    rtk_vec3 *cent = malloc(sizeof *cent * n);
    uint64_t *code = malloc(sizeof *code * n);
    if (!bounds || !cent || !code) {
        free(bounds), free(cent), free(code);
        return UINT32_MAX;
    }
    rtk_bvh_prepare_inputs(s, 1, bounds, cent, NULL);
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY}, scale[3];
    for (uint32_t i = 0; i < n; i++) {
        const float v[3] = {cent[i].x, cent[i].y, cent[i].z};
        for (int k = 0; k < 3; k++)
            lo[k] = v[k] < lo[k] ? v[k] : lo[k], hi[k] = v[k] > hi[k] ? v[k] : hi[k];
    }
    for (int k = 0; k < 3; k++)
        scale[k] = hi[k] - lo[k] > 0.0f ? (float)(1u << per_axis) / (hi[k] - lo[k]) : 0.0f;
    for (uint32_t i = 0; i < n; i++)
        code[i] = morton_ref(cent[i], lo, scale, per_axis);
    uint32_t bad = 0;
    for (uint32_t i = 0; i + 1 < n; i++) {
        const uint32_t a = s->prim_ids[i], b = s->prim_ids[i + 1];
        bad += !(code[a] < code[b] || (code[a] == code[b] && a < b));
    }
    free(bounds), free(cent), free(code);
    return bad;
}

/* lbvh's leaf order against codes recomputed here, on both sides of its
 * one-thread sort's switch to a first pass by the top digit (2^17
 * primitives), on random triangles, on copies of a few (equal codes:
 * index order) and on a cluster (top-digit buckets of thousands, sorted
 * in the fewest passes), with 30- and 63-bit codes, on 1, 2 and 16
 * threads (a narrower top digit). */
static void check_lbvh_order(const rtk_plugin *p)
{
    static const char *const kinds[] = {"random triangles", "random triangles", "copies of 30,000 triangles",
                                        "copies of 4,000 triangles", "triangles, 9 in 10 in a cluster"};
    for (int kind = 0; kind < 5; kind++) {
        for (uint32_t bits = 30; bits <= 63; bits += 33) {
            for (int ti = 0; ti < 3; ti++) {
                const uint32_t t = ti == 0 ? 1 : ti == 1 ? 2 : 16;
                rtk_pcg32 rng;
                rtk_pcg32_seed(&rng, 17u + (uint32_t)kind, 3u);
                rtk_scene *s = rtk_scene_new("morton", 0);
                const int count = kind % 2 ? 20000 : 150000, distinct = count / 5;
                if (kind == 4) {
                    /* A cube a twentieth of the scene's side holds 135,000. */
                    add_soup(s, &rng, count / 10, .02f);
                    add_soup_in(s, &rng, count - count / 10, .25f, .35f, .002f);
                } else if (kind >= 2) {
                    /* count / 5 triangles, each 5 times on average, in
                     * random order: equal codes in buckets of every size. */
                    rtk_scene *few = rtk_scene_new("few", 0);
                    add_soup(few, &rng, distinct, .02f);
                    for (int i = 0; i < count; i++) {
                        const uint32_t *idx = few->indices + 3 * (size_t)(rtk_pcg32_next(&rng) % (uint32_t)distinct);
                        rtk_vec3 v[3];
                        for (int k = 0; k < 3; k++)
                            v[k] = rtk_vec3_make(few->positions[3 * idx[k]], few->positions[3 * idx[k] + 1],
                                                 few->positions[3 * idx[k] + 2]);
                        add_tri(s, v[0], v[1], v[2]);
                    }
                    rtk_scene_free(few);
                } else {
                    add_soup(s, &rng, count, .02f);
                }
                set_bounds(s);
                rtk_params *params = rtk_params_defaults(p);
                rtk_params_set_text(params, "morton", bits == 63 ? "63" : "30");
                rtk_status st = rtk_bvh_build(s, p, params, t);
                uint32_t bad = st == RTK_OK ? morton_disorder(s, bits) : UINT32_MAX;
                check(bad == 0, "lbvh morton=%u, %u thread%s, %d %s: the leaf order is the codes' stable sort "
                      "(%u slots out of order)", bits, t, t == 1 ? "" : "s", count, kinds[kind], bad);
                rtk_params_destroy(params);
                rtk_scene_free(s);
            }
        }
    }
}

/* A stream whose lists outgrow their arena: 4,096 triangles with
 * corners anywhere in [-1, 1]^3, so that every box holds most of the
 * scene and each of 1,024 rays from inside enters nearly every child of
 * every node (the lists grow eightfold a level, past the arena three
 * levels down, where the stream hands the rays to their own traversals).
 * Batches equal single rays on the AVX paths, closest and any. */
static void check_stream_overflow(const rtk_plugin *builder)
{
    enum { TRIS = 4096, N = 1024 };
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 4096u, 3u);
    rtk_scene *s = rtk_scene_new("overlapping triangles", 0);
    for (int i = 0; i < TRIS; i++)
        add_tri(s, rtk_vec3_make(frand(&rng, -1, 1), frand(&rng, -1, 1), frand(&rng, -1, 1)),
                rtk_vec3_make(frand(&rng, -1, 1), frand(&rng, -1, 1), frand(&rng, -1, 1)),
                rtk_vec3_make(frand(&rng, -1, 1), frand(&rng, -1, 1), frand(&rng, -1, 1)));
    set_bounds(s);
    rtk_params *params = rtk_params_defaults(builder);
    rtk_ray *rays = malloc(sizeof(rtk_ray) * N);
    rtk_hit *single = malloc(sizeof(rtk_hit) * N), *batch = malloc(sizeof(rtk_hit) * N);
    uint8_t *occ_single = malloc(N), *occ_batch = malloc(N);
    int ok = rays && single && batch && occ_single && occ_batch &&
             rtk_bvh_build(s, builder, params, 2) == RTK_OK && s->wide;
    check(ok, "overlapping triangles / %s: build", builder->name);
    for (int p = RTK_SIMD_AVX2; ok && p < RTK_SIMD_PATHS; p++) {
        if (!rtk_simd_supported((rtk_simd_path)p))
            continue;
        for (uint32_t i = 0; i < N; i++) {
            rays[i].org = rtk_vec3_make(frand(&rng, -.5f, .5f), frand(&rng, -.5f, .5f), frand(&rng, -.5f, .5f));
            rays[i].dir = rtk_vec3_make(frand(&rng, -1, 1), frand(&rng, -1, 1), frand(&rng, -1, 1));
            rays[i].tmin = 0.0f;
            rays[i].tmax = INFINITY;
            if (!rtk_wide_closest(s, (rtk_simd_path)p, &rays[i], &single[i], NULL))
                single[i].prim = RTK_INVALID_ID;
            occ_single[i] = (uint8_t)rtk_wide_any(s, (rtk_simd_path)p, &rays[i], NULL);
        }
        rtk_wide_closest_batch(s, (rtk_simd_path)p, rays, N, batch);
        rtk_wide_any_batch(s, (rtk_simd_path)p, rays, N, occ_batch);
        int bad = 0;
        for (uint32_t i = 0; i < N; i++)
            bad += occ_single[i] != occ_batch[i] ||
                   !same_hit(single[i].prim != RTK_INVALID_ID, &single[i], batch[i].prim != RTK_INVALID_ID, &batch[i]);
        check(bad == 0,
              "overlapping triangles / %s: %s streams past their arena = single rays, bit for bit (%d rays, "
              "depth %u): %d differ",
              builder->name, rtk_simd_name((rtk_simd_path)p), N, s->wide->depth, bad);
    }
    free(rays);
    free(single);
    free(batch);
    free(occ_single);
    free(occ_batch);
    rtk_params_destroy(params);
    rtk_scene_free(s);
}

static void check_measure_service(rtk_scene *s)
{
    rtk_ctx ctx;
    memset(&ctx, 0, sizeof ctx);
    ctx.scene = s;
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 9u, 1u);
    int bad = 0, counted = 0;
    for (int i = 0; i < 500; i++) {
        rtk_ray ray = make_ray(s, &rng, i);
        rtk_hit h1, h2;
        rtk_trace_work work;
        int a = rtk_trace(&ctx, &ray, &h1);
        int b = rtk_trace_measure(&ctx, &ray, &h2, &work);
        bad += !same_hit(a, &h1, b, &h2);
        counted += work.nodes > 0;
    }
    rtk_ray invalid = {rtk_vec3_make(0, 0, 0), 0.0f, rtk_vec3_make(0, 0, 0), INFINITY};
    rtk_hit h;
    rtk_trace_work work = {7, 7};
    int r = rtk_trace_measure(&ctx, &invalid, &h, &work);
    check(bad == 0 && counted > 0, "rtk_trace_measure = rtk_trace (%d differ, %d of 500 counted nodes)", bad, counted);
    check(r == 0 && work.nodes == 0 && work.triangles == 0 && ctx.invalid_rays == 1,
          "rtk_trace_measure: an invalid ray misses with zero work and is counted");
}

static void check_env(void)
{
    setenv("RTK_SIMD", "scalar", 1);
    check(rtk_simd_from_env() == RTK_SIMD_SCALAR, "RTK_SIMD=scalar forces plain C");
    setenv("RTK_SIMD", "binary", 1);
    check(rtk_simd_from_env() == RTK_SIMD_BINARY, "RTK_SIMD=binary forces the binary tree");
    setenv("RTK_SIMD", "neon", 1);
    check(rtk_simd_from_env() == rtk_simd_best(), "RTK_SIMD=neon falls back to the best path (%s)",
          rtk_simd_name(rtk_simd_best()));
    unsetenv("RTK_SIMD");
    check(rtk_simd_from_env() == rtk_simd_best(), "no RTK_SIMD: the best path (%s)", rtk_simd_name(rtk_simd_best()));
}

int main(void)
{
    rtk_log_set_level(RTK_LOG_WARN);
    const char *quick = getenv("RTK_WIDE_TEST_QUICK");
    int rays = quick ? 1000 : 4000;
    check_env();
    rtk_registry *reg = NULL;
    if (rtk_registry_create(&reg) != RTK_OK) {
        printf("FAIL  registry: %s\n", rtk_error_message());
        return 1;
    }
    const rtk_plugin *builders[5];
    int nb = 0;
    static const char *names[] = {"median", "sah", "lbvh"};
    for (int i = 0; i < 3; i++) {
        const rtk_plugin *p = NULL;
        if (rtk_registry_find(reg, RTK_KIND_ACCELERATOR, names[i], &p) == RTK_OK)
            builders[nb++] = p;
    }
    check(nb >= 1, "the median builder is found");
    builders[nb++] = &one_leaf;
    builders[nb++] = &chain;
    int measured = 0;
    for (int m = 0; m < MESH_COUNT; m++) {
        for (int bi = 0; bi < nb; bi++) {
            const char *mesh = NULL;
            rtk_scene *s = make_mesh(m, &mesh);
            if (!s) {
                printf("skip  %s: not available\n", mesh);
                break;
            }
            if (m != MESH_BUNNY)
                set_bounds(s);
            int own = builders[bi] == &one_leaf || builders[bi] == &chain;
            rtk_params *params = own ? NULL : rtk_params_defaults(builders[bi]);
            rtk_status st = rtk_bvh_build(s, builders[bi], params, 2);
            check(st == RTK_OK, "%s / %s: build", mesh, builders[bi]->name);
            if (st == RTK_OK) {
                int n = m == MESH_BUNNY ? rays / 4 : rays;
                if (own && s->triangle_count > 5000)
                    n /= 4;
                compare_paths(s, mesh, builders[bi]->name, n);
                /* A degenerate tree over bunny makes every ray test all its
                 * triangles: its batches are checked on the small meshes. */
                if (!(own && s->triangle_count > 5000))
                    compare_batches(s, mesh, builders[bi]->name);
                check_threads_same(s, mesh, builders[bi]->name);
                if (m == MESH_BUNNY && !own)
                    check_node_limit(s, mesh, builders[bi]->name, builders[bi], params);
                if (!measured++)
                    check_measure_service(s);
            }
            rtk_params_destroy(params);
            rtk_scene_free(s);
        }
    }
    check_stream_overflow(builders[0]);
    for (int bi = 0; bi < nb; bi++) {
        if (builders[bi] == &one_leaf || builders[bi] == &chain)
            continue;
        check_builder_threads(builders[bi], 150000, 0, NULL, NULL);
        check_builder_threads(builders[bi], 110000, 40000, NULL, NULL);
        if (strcmp(builders[bi]->name, "sah") == 0) { /* the gap closing serves both modes */
            check_builder_threads(builders[bi], 150000, 0, "mode", "sweep");
            check_builder_threads(builders[bi], 150000, 0, "bins", "256"); /* the team's largest bin stores */
        }
        if (strcmp(builders[bi]->name, "lbvh") == 0) {
            /* Subtrees built in place (sizes counted first) by default, and
             * filled then moved down when collapsing. */
            check_builder_threads(builders[bi], 150000, 0, "collapse", "true");
            check_builder_threads(builders[bi], 150000, 0, "max_leaf", "1");
            check_builder_threads(builders[bi], 150000, 0, "morton", "63");
            /* Below 2^17 the sort is LSD on one thread and by the top digit first on threads. */
            check_builder_threads(builders[bi], 20000, 0, NULL, NULL);
            check_builder_threads(builders[bi], 20000, 0, "morton", "63");
            check_lbvh_order(builders[bi]);
        }
    }
    rtk_registry_destroy(reg);
    printf("%d passed, %d failed\n", passed, failed);
    return failed != 0;
}

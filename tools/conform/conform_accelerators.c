/* Conformance checks for accelerator plugins: builds through the kernel
 * against brute force on small meshes, degenerate inputs, +-0 direction
 * components, repeatable builds and instances for every parameter set,
 * then the hard cases (see "accelerator hard cases" below) for the
 * defaults. Groups are selected by rtk_conform_options (conform.h). */
#include "conform.h"
#include "accel/bvh_wide.h"

#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

static void add_tri(rtk_scene *s, rtk_vec3 a, rtk_vec3 b, rtk_vec3 c)
{
    uint32_t i0, i1, i2;
    rtk_scene_add_vertex(s, a.x, a.y, a.z, &i0);
    rtk_scene_add_vertex(s, b.x, b.y, b.z, &i1);
    rtk_scene_add_vertex(s, c.x, c.y, c.z, &i2);
    rtk_scene_add_triangle(s, i0, i1, i2, NULL, NULL, RTK_INVALID_ID);
}

/* Test meshes for builders; kept raw (no rtk_scene_finish) so that
 * degenerate and duplicated triangles reach the builder. */
static rtk_scene *make_mesh(int which, const char **name)
{
    rtk_scene *s = rtk_scene_new("conform", 0);
    if (!s)
        return NULL;
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 1234u + (uint64_t)which, 7u);
    switch (which) {
    case 0:
        *name = "empty mesh";
        break;
    case 1:
        *name = "one triangle";
        add_tri(s, rtk_vec3_make(-1, -1, 0), rtk_vec3_make(1, -1, 0), rtk_vec3_make(0, 1, 0));
        break;
    case 2:
        *name = "2000 random triangles";
        for (int i = 0; i < 2000; i++) {
            rtk_vec3 c = rtk_vec3_make(rtk_conform_frand(&rng, -1, 1), rtk_conform_frand(&rng, -1, 1),
                                       rtk_conform_frand(&rng, -1, 1));
            rtk_vec3 v[3];
            for (int k = 0; k < 3; k++)
                v[k] = rtk_vec3_add(c, rtk_vec3_make(rtk_conform_frand(&rng, -.1f, .1f), rtk_conform_frand(&rng, -.1f, .1f),
                                                     rtk_conform_frand(&rng, -.1f, .1f)));
            add_tri(s, v[0], v[1], v[2]);
        }
        break;
    case 3:
        *name = "degenerate triangles among good ones";
        for (int i = 0; i < 300; i++) {
            rtk_vec3 a = rtk_vec3_make(rtk_conform_frand(&rng, -1, 1), rtk_conform_frand(&rng, -1, 1),
                                       rtk_conform_frand(&rng, -1, 1));
            rtk_vec3 b = rtk_vec3_add(
                a, rtk_vec3_make(rtk_conform_frand(&rng, -.2f, .2f), rtk_conform_frand(&rng, -.2f, .2f), 0.1f));
            if (i % 3 == 0)
                add_tri(s, a, a, a); /* a point */
            else if (i % 3 == 1)
                add_tri(s, a, b, rtk_vec3_scale(rtk_vec3_add(a, b), 0.5f)); /* a line */
            else
                add_tri(s, a, b, rtk_vec3_add(a, rtk_vec3_make(0.1f, -0.05f, 0.2f)));
        }
        break;
    case 4:
        *name = "duplicated and coplanar triangles";
        for (int i = 0; i < 500; i++)
            add_tri(s, rtk_vec3_make(-1, -1, 0), rtk_vec3_make(1, -1, 0), rtk_vec3_make(0, 1, 0));
        for (int i = 0; i < 100; i++)
            add_tri(s, rtk_vec3_make(rtk_conform_frand(&rng, -1, 0), -1, 0),
                    rtk_vec3_make(1, rtk_conform_frand(&rng, -1, 0), 0), rtk_vec3_make(0, 1, 0));
        break;
    default: {
        *name = "closed sphere (shared edges)";
        const int nu = 48, nv = 24;
        for (int j = 0; j < nv; j++) {
            for (int i = 0; i < nu; i++) {
                rtk_vec3 p[4];
                for (int k = 0; k < 4; k++) {
                    int ii = i + (k == 1 || k == 2), jj = j + (k >= 2);
                    double th = M_PI * jj / nv, ph = 2.0 * M_PI * (ii % nu) / nu;
                    p[k] = rtk_vec3_make((float)(sin(th) * cos(ph)), (float)cos(th), (float)(sin(th) * sin(ph)));
                }
                add_tri(s, p[0], p[1], p[2]);
                add_tri(s, p[0], p[2], p[3]);
            }
        }
        break;
    }
    }
    return s;
}

static int brute_closest(const rtk_scene *s, const rtk_ray *ray, rtk_hit *hit)
{
    hit->prim = hit->inst = RTK_INVALID_ID;
    hit->t = ray->tmax;
    hit->u = hit->v = 0.0f;
    float best = ray->tmax;
    for (uint32_t i = 0; i < s->triangle_count; i++) {
        rtk_vec3 a, b, c;
        rtk_scene_triangle(s, i, &a, &b, &c);
        float t, u, v;
        if (rtk_intersect_triangle(ray, a, b, c, &t, &u, &v) && (t < best || (t == best && i < hit->prim))) {
            best = t;
            hit->t = t, hit->u = u, hit->v = v, hit->prim = i;
        }
    }
    return hit->prim != RTK_INVALID_ID;
}

/* Brute force's answers are the same for every parameter set and plugin
 * (the scenes and rays of the basic, degenerate, repeat and instance
 * checks depend on neither) and took most of each set's time: the runner
 * keeps them for the process, each under the fingerprint of its scene and
 * its ray's own bits. */
typedef int (*brute_fn)(const rtk_scene *s, const rtk_ray *ray, rtk_hit *hit);

typedef struct brute_answer {
    rtk_ray ray;
    rtk_hit hit;
    int found;
} brute_answer;

typedef struct brute_memo {
    uint64_t scene; /* scene_fingerprint of the scene the answers are of */
    uint32_t count, cap;
    brute_answer *answers;
} brute_memo;

/* One memo per scene of a check: basic's 6 meshes, degenerate's 4, repeat, instances. */
enum { MEMO_BASIC = 0, MEMO_DEGENERATE = 6, MEMO_REPEAT = 10, MEMO_INSTANCES = 11, MEMO_COUNT = 12 };
static brute_memo brute_memos[MEMO_COUNT];

static void brute_memos_free(void)
{
    for (int k = 0; k < MEMO_COUNT; k++) {
        free(brute_memos[k].answers);
        memset(&brute_memos[k], 0, sizeof brute_memos[k]);
    }
}

static uint64_t fnv1a(uint64_t h, const void *data, size_t n)
{
    const unsigned char *b = data;
    for (size_t i = 0; i < n; i++)
        h = (h ^ b[i]) * 0x100000001b3ull;
    return h;
}

/* A hash of what brute force reads: every triangle's corners in id order,
 * each placement's mesh and world-to-object transform, each mesh's own. */
static uint64_t scene_fingerprint(const rtk_scene *s)
{
    uint64_t h = fnv1a(0xcbf29ce484222325ull, &s->triangle_count, sizeof s->triangle_count);
    for (uint32_t i = 0; i < s->triangle_count; i++) {
        rtk_vec3 v[3];
        rtk_scene_triangle(s, i, &v[0], &v[1], &v[2]);
        h = fnv1a(h, v, sizeof v);
    }
    h = fnv1a(h, &s->instance_count, sizeof s->instance_count);
    for (uint32_t i = 0; i < s->instance_count; i++) {
        h = fnv1a(h, &s->instances[i].mesh, sizeof s->instances[i].mesh);
        h = fnv1a(h, s->instances[i].to_object, sizeof s->instances[i].to_object);
    }
    for (uint32_t m = 0; m < s->mesh_count; m++) {
        uint64_t mh = scene_fingerprint(s->meshes[m]);
        h = fnv1a(h, &mh, sizeof mh);
    }
    return h;
}

/* Opens memo slot for scene s: its answers are kept if they are s's. */
static brute_memo *brute_memo_for(int slot, const rtk_scene *s)
{
    static int registered;
    if (!registered)
        registered = atexit(brute_memos_free) == 0;
    brute_memo *m = &brute_memos[slot];
    uint64_t key = scene_fingerprint(s);
    if (m->scene != key)
        m->scene = key, m->count = 0;
    return m;
}

/* fn's answer for the i-th ray of memo m's scene: the kept one when the
 * same ray was asked before, else computed and kept (rays come in order). */
static int brute_kept(brute_memo *m, uint32_t i, const rtk_scene *s, const rtk_ray *ray, rtk_hit *hit, brute_fn fn)
{
    if (i < m->count && memcmp(&m->answers[i].ray, ray, sizeof *ray) == 0) {
        *hit = m->answers[i].hit;
        return m->answers[i].found;
    }
    int found = fn(s, ray, hit);
    if (i == m->count && i == m->cap) {
        uint32_t cap = m->cap ? 2 * m->cap : 1024;
        brute_answer *answers = realloc(m->answers, sizeof *answers * cap);
        if (answers)
            m->answers = answers, m->cap = cap;
    }
    if (i == m->count && i < m->cap)
        m->answers[m->count++] = (brute_answer){*ray, *hit, found};
    return found;
}

/* Two different triangles hit at almost the same distance (coplanar
 * neighbours) are both right when the distances agree within the rounding
 * of the watertight test: its t carries a few ulps of the vertices'
 * distance from the origin, so a tree may legitimately meet the other one
 * first. The tree's answer must still be a real hit of its triangle. */
static int same_surface(const rtk_scene *s, const rtk_ray *ray, const rtk_hit *tree, const rtk_hit *brute)
{
    if (tree->t == brute->t)
        return 0; /* an exact tie must go to the lowest id */
    rtk_vec3 v[6];
    rtk_scene_triangle(s, tree->prim, &v[0], &v[1], &v[2]);
    rtk_scene_triangle(s, brute->prim, &v[3], &v[4], &v[5]);
    float t, u, w;
    if (!rtk_intersect_triangle(ray, v[0], v[1], v[2], &t, &u, &w) || t != tree->t)
        return 0;
    float reach = 0.0f;
    for (int k = 0; k < 6; k++) {
        rtk_vec3 d = rtk_vec3_sub(v[k], ray->org);
        reach = fmaxf(reach, fmaxf(fabsf(d.x), fmaxf(fabsf(d.y), fabsf(d.z))));
    }
    float bound = 16.0f * FLT_EPSILON * reach / rtk_vec3_length(ray->dir);
    return fabsf(tree->t - brute->t) <= bound;
}

/* Random rays: half aimed at points on random triangles, half anywhere. */
static rtk_ray random_ray(const rtk_scene *s, rtk_pcg32 *rng, int i)
{
    rtk_ray r;
    r.org = rtk_vec3_make(rtk_conform_frand(rng, -2, 2), rtk_conform_frand(rng, -2, 2), rtk_conform_frand(rng, -2, 2));
    r.tmin = 0.0f;
    r.tmax = (i % 7 == 0) ? rtk_conform_frand(rng, 0.1f, 2.0f) : INFINITY;
    if (s->triangle_count > 0 && i % 2 == 0) {
        rtk_vec3 a, b, c;
        rtk_scene_triangle(s, rtk_pcg32_next(rng) % s->triangle_count, &a, &b, &c);
        float u = rtk_pcg32_float(rng), v = rtk_pcg32_float(rng);
        if (i % 4 == 0)
            v = 0.0f; /* on an edge */
        if (u + v > 1.0f)
            u = 1.0f - u, v = 1.0f - v;
        rtk_vec3 target = rtk_vec3_add(a, rtk_vec3_add(rtk_vec3_scale(rtk_vec3_sub(b, a), u),
                                                       rtk_vec3_scale(rtk_vec3_sub(c, a), v)));
        r.dir = rtk_vec3_normalize(rtk_vec3_sub(target, r.org));
    } else {
        r.dir = rtk_vec3_normalize(
            rtk_vec3_make(rtk_conform_frand(rng, -1, 1), rtk_conform_frand(rng, -1, 1), rtk_conform_frand(rng, -1, 1)));
    }
    return r;
}

/* ---- accelerator hard cases ----
 *
 * Each case states an exact pass criterion. Where the criterion needs the
 * true answer it comes from one of three places:
 * - a topological fact: a ray from a point certified outside a closed
 *   mesh to a point certified inside it (or from inside to infinity) must
 *   cross it, and the watertight test guarantees the crossing is found;
 * - convexity: a ray leaving a convex object's face plane away from it
 *   never meets that object again;
 * - the oracle: the ray against every triangle in double precision, with
 *   the float test's rounding bounded (oracle_triangle). Where the double
 *   answer lies within the bound of the float one the triangle may go
 *   either way and only finiteness and consistency are required. */

typedef struct dvec {
    double x, y, z;
} dvec;

static dvec dv(double x, double y, double z)
{
    dvec v = {x, y, z};
    return v;
}

static dvec dvf(rtk_vec3 v)
{
    return dv(v.x, v.y, v.z);
}

static rtk_vec3 fdv(dvec v)
{
    return rtk_vec3_make((float)v.x, (float)v.y, (float)v.z);
}

static dvec dadd(dvec a, dvec b)
{
    return dv(a.x + b.x, a.y + b.y, a.z + b.z);
}

static dvec dsub(dvec a, dvec b)
{
    return dv(a.x - b.x, a.y - b.y, a.z - b.z);
}

static dvec dmul(dvec a, double s)
{
    return dv(a.x * s, a.y * s, a.z * s);
}

static double ddot(dvec a, dvec b)
{
    return a.x * b.x + a.y * b.y + a.z * b.z;
}

static dvec dcross(dvec a, dvec b)
{
    return dv(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}

static double dlen(dvec a)
{
    return sqrt(ddot(a, a));
}

static dvec dunit(dvec a)
{
    return dmul(a, 1.0 / dlen(a));
}

static double dget(dvec v, int k)
{
    return k == 0 ? v.x : k == 1 ? v.y : v.z;
}

static double drand(rtk_pcg32 *rng)
{
    uint64_t hi = rtk_pcg32_next(rng) >> 5, lo = rtk_pcg32_next(rng) >> 6;
    return (double)(hi << 26 | lo) * 0x1p-53;
}

static double drange(rtk_pcg32 *rng, double lo, double hi)
{
    return lo + (hi - lo) * drand(rng);
}

/* Log-uniform in [lo, hi]. */
static double dlogrange(rtk_pcg32 *rng, double lo, double hi)
{
    return exp(drange(rng, log(lo), log(hi)));
}

static dvec drand_unit(rtk_pcg32 *rng)
{
    double z = drange(rng, -1.0, 1.0), phi = drange(rng, 0.0, 2.0 * M_PI), s = sqrt(fmax(0.0, 1.0 - z * z));
    return dv(s * cos(phi), s * sin(phi), z);
}

/* Two unit vectors completing unit n to an orthonormal frame. */
static void dframe(dvec n, dvec *t, dvec *b)
{
    dvec helper = fabs(n.x) < 0.6 ? dv(1, 0, 0) : dv(0, 1, 0);
    *t = dunit(dcross(helper, n));
    *b = dcross(n, *t);
}

/* A random unit vector whose cosine with unit n is at least cos_min. */
static dvec drand_cone(rtk_pcg32 *rng, dvec n, double cos_min)
{
    dvec t, b;
    dframe(n, &t, &b);
    double c = drange(rng, cos_min, 1.0), s = sqrt(fmax(0.0, 1.0 - c * c)), phi = drange(rng, 0.0, 2.0 * M_PI);
    return dadd(dmul(n, c), dadd(dmul(t, s * cos(phi)), dmul(b, s * sin(phi))));
}

static rtk_ray make_ray(rtk_vec3 org, rtk_vec3 dir, float tmax)
{
    rtk_ray r;
    r.org = org;
    r.dir = dir;
    r.tmin = 0.0f;
    r.tmax = tmax;
    return r;
}

static dvec tri_vertex(const rtk_scene *s, uint32_t prim, int corner)
{
    rtk_vec3 v[3];
    rtk_scene_triangle(s, prim, &v[0], &v[1], &v[2]);
    return dvf(v[corner]);
}

/* A test scene under construction; a failed allocation is remembered. */
typedef struct mesh {
    rtk_scene *s;
    int ok;
} mesh;

static mesh mesh_new(const char *name)
{
    mesh m;
    m.s = rtk_scene_new(name, 0);
    m.ok = m.s != NULL;
    return m;
}

static uint32_t mesh_vertex(mesh *m, dvec p)
{
    uint32_t i = 0;
    if (m->ok && rtk_scene_add_vertex(m->s, p.x, p.y, p.z, &i) != RTK_OK)
        m->ok = 0;
    return i;
}

static void mesh_triangle(mesh *m, uint32_t a, uint32_t b, uint32_t c)
{
    if (m->ok && rtk_scene_add_triangle(m->s, a, b, c, NULL, NULL, RTK_INVALID_ID) != RTK_OK)
        m->ok = 0;
}

/* Builds m with the plugin; a failure is one failed check. Returns 1 when
 * the scene can be traced. */
static int mesh_build(rtk_conform_runner *r, mesh *m, const rtk_plugin *p, const rtk_params *params, uint32_t threads,
                      const char *what)
{
    char name[448];
    snprintf(name, sizeof name, "build %s", what);
    if (!m->ok) {
        rtk_conform_check(r, 0, name, "out of memory for the test scene");
        return 0;
    }
    rtk_status st = rtk_bvh_build(m->s, p, params, threads);
    if (st != RTK_OK)
        rtk_conform_check(r, 0, name, "%s", rtk_error_message());
    return st == RTK_OK;
}

/* A closed box, 12 triangles facing outwards, vertices shared. */
static void mesh_box(mesh *m, dvec lo, dvec hi)
{
    static const uint8_t quads[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4},
                                        {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
    uint32_t v[8];
    for (int i = 0; i < 8; i++)
        v[i] = mesh_vertex(m, dv(i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z));
    for (int f = 0; f < 6; f++) {
        mesh_triangle(m, v[quads[f][0]], v[quads[f][1]], v[quads[f][2]]);
        mesh_triangle(m, v[quads[f][0]], v[quads[f][2]], v[quads[f][3]]);
    }
}

/* Vertex index of the midpoint of edge (a, b), created on first use. */
static uint32_t edge_midpoint(uint64_t *keys, uint32_t *vals, uint32_t mask, dvec *v, uint32_t *nv, uint32_t a,
                              uint32_t b)
{
    uint64_t key = a < b ? ((uint64_t)a << 32 | b) : ((uint64_t)b << 32 | a);
    uint32_t h = (uint32_t)((key * 0x9e3779b97f4a7c15ull) >> 40) & mask;
    while (keys[h] != UINT64_MAX) {
        if (keys[h] == key)
            return vals[h];
        h = (h + 1) & mask;
    }
    keys[h] = key;
    v[*nv] = dunit(dadd(v[a], v[b]));
    vals[h] = (*nv)++;
    return vals[h];
}

/* Unit icosphere: an icosahedron whose triangles are split in four
 * `level` times, new vertices pushed onto the sphere; every edge is
 * shared by exactly two triangles. [caller frees *verts and *tris] */
static int icosphere(int level, dvec **verts, uint32_t *nv_out, uint32_t **tris, uint32_t *nt_out)
{
    const double g = 1.6180339887498948482;
    const double base[12][3] = {{-1, g, 0}, {1, g, 0}, {-1, -g, 0}, {1, -g, 0}, {0, -1, g}, {0, 1, g},
                                {0, -1, -g}, {0, 1, -g}, {g, 0, -1}, {g, 0, 1}, {-g, 0, -1}, {-g, 0, 1}};
    static const uint8_t faces[20][3] = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                         {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                         {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                         {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
    uint32_t tmax = 20u << (2 * level), vmax = 10u * (1u << (2 * level)) + 2u, cap = 1;
    while (cap < 4 * tmax)
        cap <<= 1;
    dvec *v = malloc(sizeof *v * vmax);
    uint32_t *t = malloc(sizeof *t * 3 * tmax), *t2 = malloc(sizeof *t2 * 3 * tmax);
    uint64_t *keys = malloc(sizeof *keys * cap);
    uint32_t *vals = malloc(sizeof *vals * cap);
    if (!v || !t || !t2 || !keys || !vals) {
        free(v), free(t), free(t2), free(keys), free(vals);
        return 0;
    }
    uint32_t nv = 12, nt = 20;
    for (int i = 0; i < 12; i++)
        v[i] = dunit(dv(base[i][0], base[i][1], base[i][2]));
    for (int i = 0; i < 20; i++)
        for (int k = 0; k < 3; k++)
            t[3 * i + k] = faces[i][k];
    for (int l = 0; l < level; l++) {
        memset(keys, 0xff, sizeof *keys * cap);
        for (uint32_t i = 0; i < nt; i++) {
            uint32_t a = t[3 * i], b = t[3 * i + 1], c = t[3 * i + 2];
            uint32_t ab = edge_midpoint(keys, vals, cap - 1, v, &nv, a, b);
            uint32_t bc = edge_midpoint(keys, vals, cap - 1, v, &nv, b, c);
            uint32_t ca = edge_midpoint(keys, vals, cap - 1, v, &nv, c, a);
            const uint32_t kids[12] = {a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca};
            memcpy(t2 + 12 * (size_t)i, kids, sizeof kids);
        }
        uint32_t *tmp = t;
        t = t2, t2 = tmp;
        nt *= 4;
    }
    free(t2), free(keys), free(vals);
    *verts = v, *nv_out = nv, *tris = t, *nt_out = nt;
    return 1;
}

/* Adds a unit icosphere scaled by radius around centre. */
static void mesh_icosphere(mesh *m, const dvec *v, uint32_t nv, const uint32_t *t, uint32_t nt, dvec centre,
                           double radius)
{
    uint32_t first = m->s ? m->s->vertex_count : 0;
    for (uint32_t i = 0; i < nv; i++)
        mesh_vertex(m, dadd(centre, dmul(v[i], radius)));
    for (uint32_t i = 0; i < nt; i++)
        mesh_triangle(m, first + t[3 * i], first + t[3 * i + 1], first + t[3 * i + 2]);
}

/* ---- the oracle ---- */

typedef enum oracle_verdict { ORACLE_MISS = 0, ORACLE_HIT = 1, ORACLE_EITHER = 2 } oracle_verdict;

static double gamma_n(int n)
{
    const double u = 0x1p-24;
    return n * u / (1.0 - n * u);
}

/* The ray against one triangle in double, in the ray space of the kernel's
 * watertight test, with bounds on that test's float rounding (derived as
 * in pbrt-v3 section 3.9.6 for rtk's order of operations, then doubled):
 * a projected vertex carries gamma(4) of its magnitude, an edge function
 * de = (4 gamma(4) + 2 gamma(2)) max|x| max|y|, t the error of T / det.
 * ORACLE_HIT: the float test must report a hit, at t_out +- dt_out;
 * ORACLE_MISS: it must not; ORACLE_EITHER: within rounding of an edge,
 * of the ray's ends, or of parallel. Hits at exactly t = 0 are not
 * reported when tmin >= 0 (the kernel's rule), so they are EITHER here. */
static oracle_verdict oracle_triangle(const rtk_ray *ray, rtk_vec3 a, rtk_vec3 b, rtk_vec3 c, double *t_out,
                                      double *dt_out)
{
    float adx = fabsf(ray->dir.x), ady = fabsf(ray->dir.y), adz = fabsf(ray->dir.z);
    int kz = adx > ady ? (adx > adz ? 0 : 2) : (ady > adz ? 1 : 2);
    int kx = kz == 2 ? 0 : kz + 1;
    int ky = kx == 2 ? 0 : kx + 1;
    dvec d = dvf(ray->dir), o = dvf(ray->org);
    double dz = dget(d, kz);
    if (dz < 0.0) {
        int tmp = kx;
        kx = ky, ky = tmp;
    }
    double sx = dget(d, kx) / dz, sy = dget(d, ky) / dz, sz = 1.0 / dz;
    const dvec rel[3] = {dsub(dvf(a), o), dsub(dvf(b), o), dsub(dvf(c), o)};
    double px[3], py[3], pz[3], xm = 0.0, ym = 0.0, zm = 0.0;
    for (int i = 0; i < 3; i++) {
        double X = dget(rel[i], kx), Y = dget(rel[i], ky), Z = dget(rel[i], kz);
        px[i] = X - sx * Z;
        py[i] = Y - sy * Z;
        pz[i] = sz * Z;
        xm = fmax(xm, fabs(X) + fabs(sx * Z));
        ym = fmax(ym, fabs(Y) + fabs(sy * Z));
        zm = fmax(zm, fabs(pz[i]));
    }
    const double e[3] = {px[2] * py[1] - py[2] * px[1], px[0] * py[2] - py[0] * px[2], px[1] * py[0] - py[1] * px[0]};
    double de = (4.0 * gamma_n(4) + 2.0 * gamma_n(2)) * xm * ym, margin = 2.0 * de;
    int pos = 0, neg = 0, band = 0;
    double esum = 0.0, emax = 0.0;
    for (int k = 0; k < 3; k++) {
        pos |= e[k] > margin;
        neg |= e[k] < -margin;
        band |= fabs(e[k]) <= margin;
        esum += fabs(e[k]);
        emax = fmax(emax, fabs(e[k]));
    }
    if (pos && neg)
        return ORACLE_MISS;
    double det = e[0] + e[1] + e[2], ddet = 3.0 * de + gamma_n(2) * esum;
    if (!(fabs(det) > 2.0 * ddet))
        return ORACLE_EITHER;
    double t = (e[0] * pz[0] + e[1] * pz[1] + e[2] * pz[2]) / det;
    double dT = 3.0 * zm * (de + 2.0 * gamma_n(3) * emax);
    double dt = 2.0 * ((dT + fabs(t) * ddet) / (fabs(det) - ddet) + gamma_n(2) * fabs(t));
    *t_out = t;
    *dt_out = dt;
    if (t + dt < ray->tmin || t - dt > ray->tmax)
        return ORACLE_MISS;
    if (band || t - dt < ray->tmin || t + dt > ray->tmax || (ray->tmin >= 0.0f && !(t - dt > 0.0)))
        return ORACLE_EITHER;
    return ORACLE_HIT;
}

/* Failures of one check over many rays: how many, and the first. */
typedef struct tally {
    uint64_t rays, bad;
    char first[512];
} tally;

static void tally_bad(tally *t, const rtk_ray *ray, const char *fmt, ...) RTK_PRINTF(3, 4);

static void tally_bad(tally *t, const rtk_ray *ray, const char *fmt, ...)
{
    if (t->bad++ > 0)
        return;
    int n = snprintf(t->first, sizeof t->first, "ray org (%.9g, %.9g, %.9g) dir (%.9g, %.9g, %.9g) t [%.9g, %.9g]: ",
                     ray->org.x, ray->org.y, ray->org.z, ray->dir.x, ray->dir.y, ray->dir.z, ray->tmin, ray->tmax);
    if (n < 0 || (size_t)n >= sizeof t->first)
        return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(t->first + n, sizeof t->first - (size_t)n, fmt, ap);
    va_end(ap);
}

static void tally_check(rtk_conform_runner *r, const tally *t, const char *name)
{
    rtk_conform_check(r, t->bad == 0, name, "%llu of %llu rays; first: %s", (unsigned long long)t->bad,
                      (unsigned long long)t->rays, t->first);
}

/* The kernel's answers for one ray. */
typedef struct traced {
    int hit, any;
    rtk_hit h;
} traced;

/* rtk_bvh_closest and rtk_bvh_any, except on a device accelerator's
 * scene, where the kernel traces single rays itself: there, batches of
 * one ray, so that the checks below check the device's traversal. */
static int closest_of(const rtk_scene *s, const rtk_ray *ray, rtk_hit *hit)
{
    if (!s->device)
        return rtk_bvh_closest(s, ray, hit);
    rtk_bvh_closest_batch(s, ray, 1, hit);
    return hit->prim != RTK_INVALID_ID;
}

static int any_of(const rtk_scene *s, const rtk_ray *ray)
{
    if (!s->device)
        return rtk_bvh_any(s, ray);
    uint8_t occluded;
    rtk_bvh_any_batch(s, ray, 1, &occluded);
    return occluded;
}

static traced trace(const rtk_scene *s, const rtk_ray *ray)
{
    traced tr;
    tr.hit = closest_of(s, ray, &tr.h);
    tr.any = any_of(s, ray);
    return tr;
}

/* Checks a ray's answers against the oracle over every triangle of s:
 * any hit iff closest hit; a certain hit is never missed nor passed; the
 * triangle reported is not ruled out, and its t is within the bound when
 * certain; t, u, v are finite. Returns 1 when no triangle was in the band
 * (the whole answer was decided). */
static int oracle_check(const rtk_scene *s, const rtk_ray *ray, const traced *tr, tally *tl)
{
    double first = INFINITY;
    uint32_t first_prim = RTK_INVALID_ID, undecided = 0;
    for (uint32_t i = 0; i < s->triangle_count; i++) {
        rtk_vec3 a, b, c;
        rtk_scene_triangle(s, i, &a, &b, &c);
        double t = 0.0, dt = 0.0;
        oracle_verdict v = oracle_triangle(ray, a, b, c, &t, &dt);
        if (v == ORACLE_EITHER)
            undecided++;
        if (v == ORACLE_HIT && t + dt < first)
            first = t + dt, first_prim = i;
    }
    const rtk_hit *h = &tr->h;
    if (tr->hit != tr->any) {
        tally_bad(tl, ray, "closest hit says %s, any hit says %s", tr->hit ? "hit" : "miss", tr->any ? "hit" : "miss");
    } else if (!tr->hit && first_prim != RTK_INVALID_ID) {
        tally_bad(tl, ray, "missed; the oracle says triangle %u is certainly hit by t %.9g", first_prim, first);
    } else if (tr->hit) {
        rtk_vec3 a, b, c;
        double t = 0.0, dt = 0.0;
        oracle_verdict v = h->prim < s->triangle_count ? (rtk_scene_triangle(s, h->prim, &a, &b, &c),
                                                          oracle_triangle(ray, a, b, c, &t, &dt))
                                                       : ORACLE_MISS;
        if (!isfinite(h->t) || !isfinite(h->u) || !isfinite(h->v))
            tally_bad(tl, ray, "hit triangle %u with t %g, u %g, v %g", h->prim, h->t, h->u, h->v);
        else if (v == ORACLE_MISS)
            tally_bad(tl, ray, "hit triangle %u at t %.9g, which the oracle rules out", h->prim, h->t);
        else if (v == ORACLE_HIT && fabs(h->t - t) > dt)
            tally_bad(tl, ray, "hit triangle %u at t %.9g, the oracle says %.9g +- %.3g", h->prim, h->t, t, dt);
        else if (h->t > first)
            tally_bad(tl, ray, "hit triangle %u at t %.9g behind triangle %u, certainly hit by t %.9g", h->prim, h->t,
                      first_prim, first);
    }
    return undecided == 0;
}

/* Closest hit on the tree against brute force for one ray: equal, or a
 * coplanar neighbour within rounding. Sets *brute_hit; writes a difference
 * to detail. */
static int tree_matches_brute(const rtk_scene *s, brute_memo *memo, const rtk_ray *ray, int i, int *brute_hit,
                              char *detail, size_t cap)
{
    rtk_hit h1, h2;
    int a = closest_of(s, ray, &h1), b = brute_kept(memo, (uint32_t)i, s, ray, &h2, brute_closest);
    *brute_hit = b;
    if (a == b && (!a || (h1.prim == h2.prim && h1.t == h2.t) || same_surface(s, ray, &h1, &h2)))
        return 1;
    snprintf(detail, cap, "ray %d: bvh %s prim %u t %.9g, brute force %s prim %u t %.9g", i, a ? "hit" : "miss",
             a ? h1.prim : 0u, a ? h1.t : 0.0, b ? "hit" : "miss", b ? h2.prim : 0u, b ? h2.t : 0.0);
    return 0;
}

static void conform_basic(rtk_conform_runner *r, const rtk_plugin *p, const rtk_params *params, const char *label)
{
    char name[256];
    for (int m = 0; m < 6; m++) {
        const char *mesh = NULL;
        rtk_scene *s = make_mesh(m, &mesh);
        if (!s) {
            rtk_conform_check(r, 0, "test mesh", "out of memory");
            break;
        }
        snprintf(name, sizeof name, "build [%s] %s", label, mesh);
        rtk_status st = rtk_bvh_build(s, p, params, 2);
        rtk_conform_check(r, st == RTK_OK, name, "%s", rtk_error_message());
        if (st == RTK_OK && s->own_traversal) {
            /* A plugin's own triangle test rounds differently from the
             * kernel's: held to the oracle instead of to equality. */
            rtk_pcg32 rng;
            rtk_pcg32_seed(&rng, 99u, (uint64_t)m);
            tally tl = {0, 0, ""};
            for (int i = 0; i < 3000; i++) {
                rtk_ray ray = random_ray(s, &rng, i);
                traced tr = trace(s, &ray);
                tl.rays++;
                oracle_check(s, &ray, &tr, &tl);
            }
            snprintf(name, sizeof name, "closest and any hit agree with the oracle (own traversal) [%s] %s", label, mesh);
            tally_check(r, &tl, name);
        } else if (st == RTK_OK) {
            rtk_pcg32 rng;
            rtk_pcg32_seed(&rng, 99u, (uint64_t)m);
            int closest_bad = 0, any_bad = 0;
            char detail[256] = "", d[256];
            brute_memo *memo = brute_memo_for(MEMO_BASIC + m, s);
            for (int i = 0; i < 3000; i++) {
                rtk_ray ray = random_ray(s, &rng, i);
                int b = 0;
                if (!tree_matches_brute(s, memo, &ray, i, &b, d, sizeof d) && !closest_bad++)
                    snprintf(detail, sizeof detail, "%s", d);
                if (any_of(s, &ray) != b)
                    any_bad++;
            }
            snprintf(name, sizeof name, "closest hit = brute force [%s] %s", label, mesh);
            rtk_conform_check(r, closest_bad == 0, name, "%d of 3000 rays differ; first: %s", closest_bad, detail);
            snprintf(name, sizeof name, "any hit = brute force [%s] %s", label, mesh);
            rtk_conform_check(r, any_bad == 0, name, "%d of 3000 rays differ", any_bad);
        }
        rtk_scene_free(s);
    }
}

/* ---- degenerate inputs: every parameter set ---- */

/* Deepest leaf and largest leaf of the tree the kernel kept. */
static void tree_shape(const rtk_scene *s, uint32_t *leaves, uint32_t *largest)
{
    *leaves = *largest = 0;
    for (uint32_t i = 0; i < s->node_count; i++) {
        if (s->nodes[i].count > 0) {
            (*leaves)++;
            if (s->nodes[i].count > *largest)
                *largest = s->nodes[i].count;
        }
    }
}

/* The plugin's max_leaf parameter, or -1 when it has none. */
static int64_t max_leaf_param(const rtk_plugin *p, const rtk_params *params)
{
    for (uint32_t i = 0; i < p->param_count; i++)
        if (p->params[i].type == RTK_PARAM_INT && strcmp(p->params[i].name, "max_leaf") == 0)
            return rtk_params_int(params, "max_leaf");
    return -1;
}

static mesh degenerate_mesh(int which, const char **name)
{
    mesh m = mesh_new("conform degenerate");
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 4242u, (uint64_t)which);
    switch (which) {
    case 0: {
        *name = "100000 copies of one triangle";
        uint32_t a = mesh_vertex(&m, dv(-0.5, -0.25, 0.125)), b = mesh_vertex(&m, dv(0.75, -0.5, 0.25)),
                 c = mesh_vertex(&m, dv(0.125, 0.625, -0.375));
        for (int i = 0; i < 100000; i++)
            mesh_triangle(&m, a, b, c);
        break;
    }
    case 1: {
        /* Bounds [c - l, c + l] in x and y, z = c.z: every bounds centre is
         * c exactly, so no centroid split can separate them. */
        *name = "10000 concentric triangles with one centroid";
        const dvec c = dv(0.75, -1.5, 2.25);
        for (int i = 0; i < 10000; i++) {
            double l = (i + 1) * 0x1p-14;
            uint32_t v0 = mesh_vertex(&m, dadd(c, dv(-l, -l, 0))), v1 = mesh_vertex(&m, dadd(c, dv(l, -l, 0))),
                     v2 = mesh_vertex(&m, dadd(c, dv(0, l, 0)));
            mesh_triangle(&m, v0, v1, v2);
        }
        break;
    }
    case 2: {
        *name = "100000 triangles with every vertex at one point";
        uint32_t a = mesh_vertex(&m, dv(0.5, 0.25, -0.125));
        for (int i = 0; i < 100000; i++)
            mesh_triangle(&m, a, a, a);
        break;
    }
    default: {
        *name = "100000 triangles in a 1e-4 cube and one far away";
        const dvec lo = dv(0.3, 0.1, -0.2);
        for (int i = 0; i < 100000; i++) {
            uint32_t v[3];
            for (int k = 0; k < 3; k++)
                v[k] = mesh_vertex(&m, dadd(lo, dv(drange(&rng, 0, 1e-4), drange(&rng, 0, 1e-4), drange(&rng, 0, 1e-4))));
            mesh_triangle(&m, v[0], v[1], v[2]);
        }
        uint32_t a = mesh_vertex(&m, dv(1e3, 1e3, 1e3)), b = mesh_vertex(&m, dv(1e3 + 10, 1e3, 1e3)),
                 c = mesh_vertex(&m, dv(1e3, 1e3 + 10, 1e3 + 5));
        mesh_triangle(&m, a, b, c);
        break;
    }
    }
    return m;
}

/* A ray towards a point of triangle prim (on an edge for odd i), from a
 * random origin at distance [near, far] from it. */
static rtk_ray ray_at_triangle(const rtk_scene *s, uint32_t prim, rtk_pcg32 *rng, int i, double near, double far)
{
    dvec a = tri_vertex(s, prim, 0), b = tri_vertex(s, prim, 1), c = tri_vertex(s, prim, 2);
    double u = drand(rng), v = drand(rng);
    if (i % 2)
        v = 0.0;
    if (u + v > 1.0)
        u = 1.0 - u, v = 1.0 - v;
    dvec target = dadd(a, dadd(dmul(dsub(b, a), u), dmul(dsub(c, a), v)));
    rtk_vec3 org = fdv(dadd(target, dmul(drand_unit(rng), dlogrange(rng, near, far))));
    return make_ray(org, fdv(dsub(target, dvf(org))), INFINITY);
}

/* Rays per degenerate mesh: every ray that meets 1e5 identical triangles
 * (or points) visits all of them, since ties must go to the lowest id. */
static const int degenerate_rays[2][4] = {{16, 50, 8, 16}, {100, 300, 32, 64}};

static void conform_degenerate(rtk_conform_runner *r, const rtk_plugin *p, const rtk_params *params, const char *label,
                               int full)
{
    int64_t max_leaf = max_leaf_param(p, params);
    for (int which = 0; which < 4; which++) {
        const char *what = NULL;
        mesh m = degenerate_mesh(which, &what);
        char name[400];
        snprintf(name, sizeof name, "[%s] %s", label, what);
        double t0 = rtk_now();
        if (!mesh_build(r, &m, p, params, 2, name)) {
            rtk_scene_free(m.s);
            continue;
        }
        double build = rtk_now() - t0;
        const rtk_scene *s = m.s;
        uint32_t leaves = 0, largest = 0;
        tree_shape(s, &leaves, &largest);
        if (s->node_count == 0) {
            snprintf(name, sizeof name, "terminates (%.2f s; own traversal, no tree to inspect) [%s] %s", build, label,
                     what);
            rtk_conform_check(r, 1, name, "%s", "");
        } else {
            char bound[64] = "no max_leaf parameter";
            if (max_leaf >= 0)
                snprintf(bound, sizeof bound, "max_leaf %lld", (long long)max_leaf);
            snprintf(name, sizeof name,
                     "terminates in %.2f s, depth %u <= 256, %u leaves, largest %u (%s) [%s] %s", build,
                     s->bvh_depth, leaves, largest, bound, label, what);
            rtk_conform_check(r, s->bvh_depth <= 256 && (max_leaf < 0 || largest <= (uint64_t)max_leaf), name,
                              "a leaf holds %u triangles", largest);
        }
        rtk_pcg32 rng;
        rtk_pcg32_seed(&rng, 777u, (uint64_t)which);
        tally tl = {0, 0, ""};
        int rays = degenerate_rays[full][which];
        brute_memo *memo = brute_memo_for(MEMO_DEGENERATE + which, s);
        for (int i = 0; i < rays; i++) {
            rtk_ray ray;
            if (which == 3 && i % 8 == 7)
                ray = ray_at_triangle(s, 100000, &rng, i, 1.0, 100.0);
            else if (which == 3)
                ray = ray_at_triangle(s, rtk_pcg32_next(&rng) % 100000, &rng, i, i % 4 ? 1e-4 : 1e-6, 2.0);
            else if (i % 4 == 3)
                ray = make_ray(fdv(dmul(drand_unit(&rng), 2.0)), fdv(drand_unit(&rng)), INFINITY);
            else
                ray = ray_at_triangle(s, rtk_pcg32_next(&rng) % s->triangle_count, &rng, i, 0.1, 3.0);
            tl.rays++;
            traced tr = trace(s, &ray);
            rtk_hit want;
            int expect;
            if (s->own_traversal && which != 2) {
                oracle_check(s, &ray, &tr, &tl);
            } else if (which == 0) {
                /* Identical triangles give identical t: the lowest id wins. */
                rtk_vec3 a, b, c;
                rtk_scene_triangle(s, 0, &a, &b, &c);
                expect = rtk_intersect_triangle(&ray, a, b, c, &want.t, &want.u, &want.v);
                want.prim = 0;
                if (tr.hit != expect || tr.any != expect || (expect && (tr.h.prim != 0 || tr.h.t != want.t)))
                    tally_bad(&tl, &ray, "tree %s prim %u t %.9g (any %d); triangle 0 alone: %s t %.9g",
                              tr.hit ? "hit" : "miss", tr.h.prim, tr.h.t, tr.any, expect ? "hit" : "miss", want.t);
            } else if (which == 2) {
                if (tr.hit || tr.any)
                    tally_bad(&tl, &ray, "hit prim %u of a point (any %d)", tr.h.prim, tr.any);
            } else {
                char d[256];
                if (!tree_matches_brute(s, memo, &ray, i, &expect, d, sizeof d))
                    tally_bad(&tl, &ray, "%s", d);
                else if (tr.any != expect)
                    tally_bad(&tl, &ray, "any hit %d, brute force %d", tr.any, expect);
            }
        }
        snprintf(name, sizeof name, "closest and any hit %s, %llu rays [%s] %s",
                 s->own_traversal ? "agree with the oracle (own traversal)" : "= brute force", (unsigned long long)tl.rays,
                 label, what);
        tally_check(r, &tl, name);
        rtk_scene_free(m.s);
    }
}

/* ---- +-0 direction components: every parameter set ---- */

/* Exact answer for a ray along axis k (direction +-1 there, +-0 elsewhere)
 * on a scene of axis-aligned box faces whose coordinates, like the ray
 * origins, make every difference exact in float: the float test's signs
 * are then exact, and the truth is a 2D point-in-closed-triangle test and
 * t = (plane - origin) / direction. Per triangle, state: AXIS_MISS;
 * AXIS_HIT, hit at t > 0 (*t_best is the nearest); AXIS_EITHER, hit at
 * t = 0 (a ray starting on the surface: a matter of convention) or, for a
 * plugin's own traversal, through the boundary of the triangle (whose
 * convention, closed or half-open, is the plugin's). t holds each t. */
enum { AXIS_MISS = 0, AXIS_HIT = 1, AXIS_EITHER = 2 };

static void axis_truth(const rtk_scene *s, const rtk_ray *ray, int k, int own, double *t_best, uint8_t *state,
                       double *t)
{
    int i = k == 0 ? 1 : 0, j = k == 2 ? 1 : 2;
    double oi = dget(dvf(ray->org), i), oj = dget(dvf(ray->org), j), ok = dget(dvf(ray->org), k);
    double dk = dget(dvf(ray->dir), k);
    *t_best = INFINITY;
    for (uint32_t n = 0; n < s->triangle_count; n++) {
        state[n] = AXIS_MISS;
        dvec a = tri_vertex(s, n, 0), b = tri_vertex(s, n, 1), c = tri_vertex(s, n, 2);
        double ai = dget(a, i), aj = dget(a, j), bi = dget(b, i), bj = dget(b, j), ci = dget(c, i), cj = dget(c, j);
        double area = (bi - ai) * (cj - aj) - (bj - aj) * (ci - ai);
        if (area == 0.0)
            continue;
        double e0 = (ci - bi) * (oj - bj) - (cj - bj) * (oi - bi);
        double e1 = (ai - ci) * (oj - cj) - (aj - cj) * (oi - ci);
        double e2 = (bi - ai) * (oj - aj) - (bj - aj) * (oi - ai);
        if ((e0 < 0 || e1 < 0 || e2 < 0) && (e0 > 0 || e1 > 0 || e2 > 0))
            continue;
        t[n] = (dget(a, k) - ok) / dk;
        if (!(t[n] >= ray->tmin && t[n] <= ray->tmax))
            continue;
        state[n] = t[n] == 0.0 || (own && (e0 == 0 || e1 == 0 || e2 == 0)) ? AXIS_EITHER : AXIS_HIT;
        if (state[n] == AXIS_HIT && t[n] < *t_best)
            *t_best = t[n];
    }
}

/* Same answer: hit, any, triangle and equal t, u, v (+0 equals -0). */
static int same_answer(const traced *a, const traced *b)
{
    if (a->hit != b->hit || a->any != b->any)
        return 0;
    return !a->hit || (a->h.prim == b->h.prim && a->h.t == b->h.t && a->h.u == b->h.u && a->h.v == b->h.v);
}

/* For the defaults every origin of the grid, for other parameter sets
 * one in eight. */
static void conform_signed_zero(rtk_conform_runner *r, const rtk_plugin *p, const rtk_params *params, const char *label,
                                int full)
{
    /* Eight touching cubes (shared face planes) and a thin slab, all in
     * [1, 2) where float differences are exact. */
    mesh m = mesh_new("conform signed zero");
    for (int i = 0; i < 8; i++) {
        dvec lo = dv(i & 1 ? 1.5 : 1.25, i & 2 ? 1.5 : 1.25, i & 4 ? 1.5 : 1.25);
        mesh_box(&m, lo, dadd(lo, dv(0.25, 0.25, 0.25)));
    }
    mesh_box(&m, dv(1.0625, 1.0625, 1.0625), dv(1.1875, 1.0625 + 0x1p-10, 1.9375));
    char name[400];
    snprintf(name, sizeof name, "[%s] boxes for +-0 directions", label);
    if (!mesh_build(r, &m, p, params, 2, name)) {
        rtk_scene_free(m.s);
        return;
    }
    const rtk_scene *s = m.s;
    int own = s->own_traversal != NULL;
    static const float base[] = {-4.0f, 0.0f, 1.0f, 1.125f, 1.375f, 1.625f, 1.875f, 8.0f};
    static const float planes[] = {1.0625f, 1.0634765625f, 1.1875f, 1.25f, 1.5f, 1.75f, 1.9375f};
    float vals[8 + 7 * 3];
    int nvals = 0;
    for (size_t i = 0; i < RTK_COUNTOF(base); i++)
        vals[nvals++] = base[i];
    for (size_t i = 0; i < RTK_COUNTOF(planes); i++) {
        vals[nvals++] = planes[i];
        vals[nvals++] = nextafterf(planes[i], -INFINITY);
        vals[nvals++] = nextafterf(planes[i], INFINITY);
    }
    uint8_t *state = malloc(s->triangle_count);
    double *tt = malloc(sizeof *tt * s->triangle_count);
    if (!state || !tt) {
        rtk_conform_check(r, 0, "signed zero: memory", "out of memory");
        free(state), free(tt), rtk_scene_free(m.s);
        return;
    }
    tally truth = {0, 0, ""}, sym = {0, 0, ""};
    uint64_t hits = 0;
    rtk_pcg32 pick;
    rtk_pcg32_seed(&pick, 88u, 1u);
    for (int x = 0; x < nvals; x++)
        for (int y = 0; y < nvals; y++)
            for (int z = 0; z < nvals; z++)
                for (int k = 0; k < 3 && (full || rtk_pcg32_next(&pick) % 8 == 0); k++)
                    for (int sign = -1; sign <= 1; sign += 2) {
                        rtk_ray ray = make_ray(rtk_vec3_make(vals[x], vals[y], vals[z]), rtk_vec3_make(0, 0, 0), INFINITY);
                        double t_best = INFINITY;
                        traced first = {0, 0, {0, 0, 0, 0, 0}};
                        for (int zeros = 0; zeros < 4; zeros++) {
                            float comp[3];
                            for (int c = 0, bit = 0; c < 3; c++)
                                comp[c] = c == k ? (float)sign : ((zeros >> bit++) & 1) ? -0.0f : 0.0f;
                            ray.dir = rtk_vec3_make(comp[0], comp[1], comp[2]);
                            if (zeros == 0)
                                axis_truth(s, &ray, k, own, &t_best, state, tt);
                            traced tr = trace(s, &ray);
                            truth.rays++;
                            uint32_t q = tr.h.prim;
                            double tol = 0x1p-22 * fabs(t_best);
                            if (tr.hit != tr.any)
                                tally_bad(&truth, &ray, "closest %s, any %s", tr.hit ? "hit" : "miss", tr.any ? "hit" : "miss");
                            else if (!tr.hit && t_best < INFINITY)
                                tally_bad(&truth, &ray, "missed; exact: hit at t %.17g", t_best);
                            else if (tr.hit && (q >= s->triangle_count || state[q] == AXIS_MISS))
                                tally_bad(&truth, &ray, "hit prim %u at t %.9g, which the ray misses (exact: %s at t %.17g)", q,
                                          tr.h.t, t_best < INFINITY ? "hit" : "miss", t_best);
                            else if (tr.hit && (fabs(tr.h.t - tt[q]) > 0x1p-22 * fabs(tt[q]) || tr.h.t > t_best + tol))
                                tally_bad(&truth, &ray, "hit prim %u at t %.9g; exact: prim %u at t %.17g, nearest hit %.17g",
                                          q, tr.h.t, q, tt[q], t_best);
                            hits += (uint64_t)tr.hit;
                            if (zeros == 0)
                                first = tr;
                            else if (!same_answer(&first, &tr))
                                tally_bad(&sym, &ray, "prim %u t %.9g u %.9g v %.9g any %d; with +0: prim %u t %.9g u "
                                          "%.9g v %.9g any %d", tr.h.prim, tr.h.t, tr.h.u, tr.h.v, tr.any,
                                          first.h.prim, first.h.t, first.h.u, first.h.v, first.any);
                            sym.rays++;
                        }
                    }
    snprintf(name, sizeof name,
             "axis rays with every +-0 combination, origins on and one float next to box faces: %llu rays "
             "(%llu hits) = exact answer%s [%s]",
             (unsigned long long)truth.rays, (unsigned long long)hits,
             own ? " (own traversal: boundary hits either way)" : "", label);
    tally_check(r, &truth, name);
    snprintf(name, sizeof name, "+0 and -0 components give the same answers [%s]", label);
    tally_check(r, &sym, name);
    free(state);
    free(tt);
    rtk_scene_free(m.s);
}

/* ---- the same answers on every build: every parameter set ---- */

static void conform_repeat(rtk_conform_runner *r, const rtk_plugin *p, const rtk_params *params, const char *label,
                           int full)
{
    mesh m = mesh_new("conform repeat");
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 31u, 3u);
    uint32_t a = mesh_vertex(&m, dv(-1, -1, 0)), b = mesh_vertex(&m, dv(1, -1, 0)), c = mesh_vertex(&m, dv(0, 1, 0));
    for (int i = 0; i < 300; i++)
        mesh_triangle(&m, a, b, c);
    for (int i = 0; i < 200; i++) {
        uint32_t v0 = mesh_vertex(&m, dv(drange(&rng, -1, 0), -1, 0)), v1 = mesh_vertex(&m, dv(1, drange(&rng, -1, 0), 0));
        mesh_triangle(&m, v0, v1, c);
        mesh_triangle(&m, v1, v0, c);
    }
    for (int i = 0; i < 500; i++) {
        dvec centre = dv(drange(&rng, -1, 1), drange(&rng, -1, 1), drange(&rng, -1, 1));
        uint32_t v[3];
        for (int k = 0; k < 3; k++)
            v[k] = mesh_vertex(&m, dadd(centre, dmul(drand_unit(&rng), 0.2)));
        mesh_triangle(&m, v[0], v[1], v[2]);
    }
    const int rays = full ? 3000 : 500;
    traced *res = malloc(sizeof *res * 3 * rays);
    rtk_ray *ray = malloc(sizeof *ray * rays);
    if (!res || !ray || !m.ok) {
        rtk_conform_check(r, 0, "repeat: memory", "out of memory");
        free(res), free(ray), rtk_scene_free(m.s);
        return;
    }
    rtk_pcg32_seed(&rng, 32u, 3u);
    for (int i = 0; i < rays; i++)
        ray[i] = random_ray(m.s, &rng, i);
    static const uint32_t threads[3] = {1, 2, 2};
    char name[400];
    int built = 1;
    for (int run = 0; run < 3 && built; run++) {
        snprintf(name, sizeof name, "[%s] coplanar and duplicated triangles on %u thread(s)", label, threads[run]);
        built = mesh_build(r, &m, p, params, threads[run], name);
        for (int i = 0; i < rays && built; i++)
            res[run * rays + i] = trace(m.s, &ray[i]);
    }
    if (built) {
        int own = m.s->own_traversal != NULL;
        tally same = {0, 0, ""}, ref = {0, 0, ""};
        uint64_t near_ties = 0;
        brute_memo *memo = brute_memo_for(MEMO_REPEAT, m.s);
        for (int i = 0; i < rays; i++) {
            const traced *t1 = &res[i], *t2 = &res[rays + i], *t3 = &res[2 * rays + i];
            same.rays++;
            if (!same_answer(t1, t2) || !same_answer(t1, t3))
                tally_bad(&same, &ray[i], "1 thread: prim %u t %.9g; 2 threads: prim %u t %.9g; again: prim %u t %.9g",
                          t1->h.prim, t1->h.t, t2->h.prim, t2->h.t, t3->h.prim, t3->h.t);
            ref.rays++;
            if (own) {
                oracle_check(m.s, &ray[i], t1, &ref);
                continue;
            }
            traced want;
            want.hit = want.any = brute_kept(memo, (uint32_t)i, m.s, &ray[i], &want.h, brute_closest);
            if (same_answer(t1, &want))
                continue;
            if (t1->hit && want.hit && t1->any && same_surface(m.s, &ray[i], &t1->h, &want.h))
                near_ties++;
            else
                tally_bad(&ref, &ray[i], "tree: %s prim %u t %.9g u %.9g v %.9g; brute force: %s prim %u t %.9g u %.9g "
                          "v %.9g", t1->hit ? "hit" : "miss", t1->h.prim, t1->h.t, t1->h.u, t1->h.v,
                          want.hit ? "hit" : "miss", want.h.prim, want.h.t, want.h.u, want.h.v);
        }
        snprintf(name, sizeof name, "identical answers built twice, on 1 and 2 threads: %d rays [%s]", rays, label);
        tally_check(r, &same, name);
        if (own)
            snprintf(name, sizeof name,
                     "answers agree with the oracle: %d rays (own traversal: which of tied triangles wins is the "
                     "plugin's) [%s]",
                     rays, label);
        else
            snprintf(name, sizeof name,
                     "identical to brute force, exact ties to the lowest id: %d rays, %llu near-ties within "
                     "rounding [%s]",
                     rays, (unsigned long long)near_ties, label);
        tally_check(r, &ref, name);
    }
    free(res);
    free(ray);
    rtk_scene_free(m.s);
}

/* ---- closed icosphere; cameras inside it ---- */

/* Rays from outside aimed at vertices and at points of shared edges, from
 * directions within 60 degrees of the outward normal. Criterion: the
 * ray's line passes within 0.95 of the centre (checked in double), the
 * surface lies between radii 0.993 and 1.007 even after rounding to float
 * at 1e5, so the segment from the origin to the line's closest point to
 * the centre crosses the closed surface: closest and any hit must report
 * a hit, and the closest at or before that point. */
static void icosphere_rays(rtk_conform_runner *r, const rtk_scene *s, dvec centre, uint32_t nv, uint32_t count,
                           const char *where)
{
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 2024u, (uint64_t)count);
    tally tl = {0, 0, ""}, oracle = {0, 0, ""};
    uint64_t skipped = 0;
    uint32_t sample = count / 32 ? count / 32 : 1;
    for (uint32_t i = 0; i < count; i++) {
        uint32_t prim = rtk_pcg32_next(&rng) % s->triangle_count;
        int corner = (int)(rtk_pcg32_next(&rng) % 3);
        dvec target = tri_vertex(s, prim, corner);
        if (i % 2) {
            dvec b = tri_vertex(s, prim, (corner + 1) % 3);
            double u = i % 8 == 1 ? 0.5 : drand(&rng);
            target = dvf(fdv(dadd(target, dmul(dsub(b, target), u))));
        }
        dvec n = dunit(dsub(target, centre));
        dvec o = dvf(fdv(dadd(target, dmul(drand_cone(&rng, n, 0.5), dlogrange(&rng, 0.1, 4.0)))));
        rtk_ray ray = make_ray(fdv(o), fdv(dsub(target, o)), INFINITY);
        dvec d = dvf(ray.dir);
        o = dvf(ray.org);
        double tc = ddot(dsub(centre, o), d) / ddot(d, d);
        if (dlen(dsub(dadd(o, dmul(d, tc)), centre)) > 0.95 || dlen(dsub(o, centre)) < 1.02) {
            skipped++;
            continue;
        }
        tl.rays++;
        traced tr = trace(s, &ray);
        if (!tr.hit || !tr.any)
            tally_bad(&tl, &ray, "closest %s, any %s (aimed at %s of triangle %u)", tr.hit ? "hit" : "MISSED",
                      tr.any ? "hit" : "MISSED", i % 2 ? "an edge" : "a vertex", prim);
        else if (!(tr.h.t >= 0.0f && tr.h.t <= tc))
            tally_bad(&tl, &ray, "hit triangle %u at t %.9g, past the centre's t %.9g", tr.h.prim, tr.h.t, tc);
        if (i % sample == 0) {
            oracle.rays++;
            oracle_check(s, &ray, &tr, &oracle);
        }
    }
    char name[400];
    snprintf(name, sizeof name,
             "icosphere (%u triangles, %u vertices) at %s: %llu rays at vertices and shared edges, zero misses, "
             "closest and any (%llu skipped)",
             s->triangle_count, nv, where, (unsigned long long)tl.rays, (unsigned long long)skipped);
    tally_check(r, &tl, name);
    snprintf(name, sizeof name, "icosphere at %s: %llu of those rays agree with the oracle over every triangle", where,
             (unsigned long long)oracle.rays);
    tally_check(r, &oracle, name);
}

/* Pinhole cameras strictly inside the closed icosphere (within 0.95 of the
 * centre, the surface is beyond 0.993): every primary ray starts inside
 * and must hit, closest and any. */
static void inside_rays(rtk_conform_runner *r, const rtk_scene *s, dvec centre, uint32_t scale, const char *where)
{
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 555u, 1u);
    tally tl = {0, 0, ""};
    const uint32_t size = 48;
    for (uint32_t cam_i = 0; cam_i < 8 * scale; cam_i++) {
        rtk_camera_desc d;
        dvec eye = cam_i == 0 ? centre : dadd(centre, dmul(drand_unit(&rng), cam_i == 1 ? 0.9 : drange(&rng, 0, 0.9)));
        dvec look = cam_i == 2 ? dv(1, 0, 0) : drand_unit(&rng);
        d.position = fdv(eye);
        d.look_at = fdv(dadd(eye, look));
        d.up = cam_i == 2 ? rtk_vec3_make(0, 1, 0) : fdv(drand_unit(&rng));
        d.fov_deg = cam_i % 3 == 0 ? 120.0f : 60.0f;
        rtk_camera cam;
        if (dlen(dsub(dvf(d.position), centre)) > 0.95 || rtk_camera_init(&cam, &d, size, size) != RTK_OK)
            continue;
        for (uint32_t y = 0; y < size; y++)
            for (uint32_t x = 0; x < size; x++) {
                rtk_ray ray = rtk_camera_ray(&cam, x + 0.5f, y + 0.5f);
                tl.rays++;
                traced tr = trace(s, &ray);
                if (!tr.hit || !tr.any || !(tr.h.t > 0.0f))
                    tally_bad(&tl, &ray, "closest %s (t %.9g), any %s: the background shows", tr.hit ? "hit" : "MISSED",
                              tr.h.t, tr.any ? "hit" : "MISSED");
            }
    }
    char name[400];
    snprintf(name, sizeof name, "cameras inside the closed icosphere at %s: %llu primary rays, no background", where,
             (unsigned long long)tl.rays);
    tally_check(r, &tl, name);
}

static void conform_icosphere(rtk_conform_runner *r, const rtk_plugin *p, const rtk_params *params, uint32_t cases,
                              uint32_t count, uint32_t scale)
{
    dvec *v = NULL;
    uint32_t *t = NULL, nv = 0, nt = 0;
    if (!icosphere(6, &v, &nv, &t, &nt)) {
        rtk_conform_check(r, 0, "icosphere", "out of memory");
        return;
    }
    for (int place = 0; place < 2; place++) {
        dvec centre = place ? dv(1e5, 1e5, 1e5) : dv(0, 0, 0);
        const char *where = place ? "(1e5, 1e5, 1e5)" : "the origin";
        mesh m = mesh_new("conform icosphere");
        mesh_icosphere(&m, v, nv, t, nt, centre, 1.0);
        char what[128];
        snprintf(what, sizeof what, "icosphere at %s", where);
        if (mesh_build(r, &m, p, params, 2, what)) {
            if (cases & RTK_CONFORM_ICOSPHERE)
                icosphere_rays(r, m.s, centre, nv, count, where);
            if (cases & RTK_CONFORM_INSIDE)
                inside_rays(r, m.s, centre, scale, where);
        }
        rtk_scene_free(m.s);
    }
    free(v);
    free(t);
}

/* ---- grazing rays ---- */

/* Rays parallel to three quads (in their plane, and just above and below)
 * and at 1e-7..1e-2 rad to them, aimed at points inside, outside, on the
 * edges, the shared diagonal and the corners. Criterion: the oracle. The
 * rounding band widens as 1/angle: at 1e-7 rad nearly every ray near the
 * quad is undecided, at 1e-2 nearly none; the check line says how many
 * rays the oracle decided entirely. */
static void conform_grazing(rtk_conform_runner *r, const rtk_plugin *p, const rtk_params *params, uint32_t scale)
{
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 8080u, 1u);
    const dvec centres[3] = {dv(0, 0, 0), dv(0.3, -0.2, 0.7), dv(1e3, -2e3, 5e2)};
    const double half[3] = {1.0, 1.0, 10.0};
    dvec e1[3], e2[3], nrm[3];
    mesh m = mesh_new("conform grazing");
    for (int q = 0; q < 3; q++) {
        nrm[q] = q == 0 ? dv(0, 0, 1) : drand_unit(&rng);
        if (q == 0)
            e1[q] = dv(1, 0, 0), e2[q] = dv(0, 1, 0);
        else
            dframe(nrm[q], &e1[q], &e2[q]);
        uint32_t v[4];
        for (int k = 0; k < 4; k++) {
            double s = (k == 1 || k == 2) ? 1 : -1, t = k >= 2 ? 1 : -1;
            v[k] = mesh_vertex(&m, dadd(centres[q], dadd(dmul(e1[q], s * half[q]), dmul(e2[q], t * half[q]))));
        }
        mesh_triangle(&m, v[0], v[1], v[2]);
        mesh_triangle(&m, v[0], v[2], v[3]);
    }
    if (!mesh_build(r, &m, p, params, 2, "grazing quads")) {
        rtk_scene_free(m.s);
        return;
    }
    static const double angles[] = {0.0, 1e-7, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2, -1.0};
    tally tl = {0, 0, ""};
    uint64_t decided = 0, hits = 0;
    for (uint32_t i = 0; i < 20000 * scale; i++) {
        int q = (int)(rtk_pcg32_next(&rng) % 3);
        double s = drange(&rng, -1.3, 1.3), t = drange(&rng, -1.3, 1.3);
        switch (i % 5) {
        case 1: s = rtk_pcg32_next(&rng) % 2 ? 1.0 : -1.0; break;
        case 2: t = s; break;
        case 3: s = rtk_pcg32_next(&rng) % 2 ? 1.0 : -1.0, t = rtk_pcg32_next(&rng) % 2 ? 1.0 : -1.0; break;
        default: break;
        }
        dvec target = dadd(centres[q], dadd(dmul(e1[q], s * half[q]), dmul(e2[q], t * half[q])));
        double theta = angles[rtk_pcg32_next(&rng) % RTK_COUNTOF(angles)];
        if (theta < 0.0)
            theta = dlogrange(&rng, 1e-7, 1e-2);
        if (rtk_pcg32_next(&rng) % 2)
            theta = -theta;
        double phi = drange(&rng, 0, 2 * M_PI);
        dvec dir = dadd(dmul(dadd(dmul(e1[q], cos(phi)), dmul(e2[q], sin(phi))), cos(theta)), dmul(nrm[q], sin(theta)));
        double len = half[q] * drange(&rng, 0.1, 5.0);
        dvec org = dsub(target, dmul(dir, len));
        if (theta == 0.0) {
            static const double heights[] = {0.0, 1e-7, -1e-7, 1e-5, -1e-5};
            org = dadd(org, dmul(nrm[q], half[q] * heights[rtk_pcg32_next(&rng) % RTK_COUNTOF(heights)]));
        }
        float tmax = i % 5 == 4 ? (float)(len * drange(&rng, 0.5, 1.5)) : INFINITY;
        rtk_ray ray = make_ray(fdv(org), fdv(dir), tmax);
        tl.rays++;
        traced tr = trace(m.s, &ray);
        decided += (uint64_t)oracle_check(m.s, &ray, &tr, &tl);
        hits += (uint64_t)tr.hit;
    }
    char name[400];
    snprintf(name, sizeof name,
             "grazing rays at 0 and 1e-7..1e-2 rad to quads: %llu rays (%llu hits) agree with the oracle, %llu "
             "decided entirely, the rest within rounding and finite",
             (unsigned long long)tl.rays, (unsigned long long)hits, (unsigned long long)decided);
    tally_check(r, &tl, name);
    rtk_scene_free(m.s);
}

/* ---- secondary rays from offset origins ---- */

/* The surface scene: a closed room (a box seen from inside), a sphere and
 * a block standing on the floor; each convex and closed. */
typedef struct surface_scene {
    mesh m;
    uint8_t *object;   /* per triangle: 0 room, 1 sphere, 2 block */
    uint32_t *plane;   /* per triangle; coplanar box faces share the id */
    dvec *normal;      /* per triangle: unnormalised, pointing out of its object */
    dvec centre[3];    /* of each object */
    uint32_t first[3], end[3];
} surface_scene;

/* Sign of the plane of triangle prim (normal pointing out of its object)
 * at point x: +1 outside, -1 inside, 0 when double rounding cannot tell
 * (Shewchuk's orient3d error bound). */
static int plane_side(const surface_scene *sc, uint32_t prim, dvec x)
{
    dvec a = tri_vertex(sc->m.s, prim, 0), b = tri_vertex(sc->m.s, prim, 1), c = tri_vertex(sc->m.s, prim, 2);
    dvec ad = dsub(a, x), bd = dsub(b, x), cd = dsub(c, x);
    double det = ad.x * (bd.y * cd.z - bd.z * cd.y) + bd.x * (cd.y * ad.z - cd.z * ad.y) +
                 cd.x * (ad.y * bd.z - ad.z * bd.y);
    double perm = fabs(ad.x) * (fabs(bd.y * cd.z) + fabs(bd.z * cd.y)) +
                  fabs(bd.x) * (fabs(cd.y * ad.z) + fabs(cd.z * ad.y)) +
                  fabs(cd.x) * (fabs(ad.y * bd.z) + fabs(ad.z * bd.y));
    if (fabs(det) <= 8.0 * DBL_EPSILON * perm)
        return 0;
    /* det = (a - x) . ((b - x) x (c - x)) = -(x - a) . ((b - a) x (c - a)) */
    double outward = ddot(dcross(dsub(b, a), dsub(c, a)), sc->normal[prim]) > 0 ? 1.0 : -1.0;
    return -det * outward > 0 ? 1 : -1;
}

/* Whether x is certainly inside every face plane of object obj. */
static int strictly_inside(const surface_scene *sc, int obj, dvec x)
{
    for (uint32_t i = sc->first[obj]; i < sc->end[obj]; i++)
        if (plane_side(sc, i, x) != -1)
            return 0;
    return 1;
}

static int surface_scene_make(surface_scene *sc, double scale, dvec offset, const dvec *iv, uint32_t inv,
                              const uint32_t *it, uint32_t int_)
{
    memset(sc, 0, sizeof *sc);
    sc->m = mesh_new("conform surface");
    const dvec room_lo = dv(-1, -1, -1), sphere = dv(0.3, -0.2, 0.1);
    const dvec block_lo = dv(-0.8, -1, -0.8), block_hi = dv(-0.5, -0.7, -0.5);
    sc->centre[0] = offset;
    sc->centre[1] = dadd(offset, dmul(sphere, scale));
    sc->centre[2] = dadd(offset, dmul(dmul(dadd(block_lo, block_hi), 0.5), scale));
    sc->first[0] = 0;
    mesh_box(&sc->m, dadd(offset, dmul(room_lo, scale)), dadd(offset, dmul(dv(1, 1, 1), scale)));
    sc->end[0] = sc->first[1] = 12;
    mesh_icosphere(&sc->m, iv, inv, it, int_, sc->centre[1], 0.35 * scale);
    sc->end[1] = sc->first[2] = 12 + int_;
    /* The block's floor is the room's floor plane, computed identically. */
    mesh_box(&sc->m, dadd(offset, dmul(block_lo, scale)), dadd(offset, dmul(block_hi, scale)));
    sc->end[2] = 24 + int_;
    if (!sc->m.ok)
        return 0;
    uint32_t n = sc->m.s->triangle_count;
    sc->object = malloc(n);
    sc->plane = malloc(sizeof *sc->plane * n);
    sc->normal = malloc(sizeof *sc->normal * n);
    if (!sc->object || !sc->plane || !sc->normal)
        return 0;
    for (int obj = 0; obj < 3; obj++) {
        for (uint32_t i = sc->first[obj]; i < sc->end[obj]; i++) {
            dvec a = tri_vertex(sc->m.s, i, 0), b = tri_vertex(sc->m.s, i, 1), c = tri_vertex(sc->m.s, i, 2);
            dvec nrm = dcross(dsub(b, a), dsub(c, a));
            dvec mid = dmul(dadd(a, dadd(b, c)), 1.0 / 3.0);
            sc->normal[i] = ddot(nrm, dsub(mid, sc->centre[obj])) >= 0 ? nrm : dmul(nrm, -1.0);
            sc->object[i] = (uint8_t)obj;
            sc->plane[i] = i;
            if (obj != 1) {
                /* Box faces: the axis on which all three corners agree. */
                for (int k = 0; k < 3; k++) {
                    if (dget(a, k) == dget(b, k) && dget(a, k) == dget(c, k)) {
                        for (uint32_t j = 0; j < i; j++) {
                            if (sc->object[j] == 1)
                                continue;
                            dvec aj = tri_vertex(sc->m.s, j, 0), bj = tri_vertex(sc->m.s, j, 1),
                                 cj = tri_vertex(sc->m.s, j, 2);
                            if (dget(aj, k) == dget(a, k) && dget(bj, k) == dget(a, k) && dget(cj, k) == dget(a, k)) {
                                sc->plane[i] = sc->plane[j];
                                break;
                            }
                        }
                    }
                }
            }
        }
    }
    return 1;
}

static void surface_scene_free(surface_scene *sc)
{
    rtk_scene_free(sc->m.s);
    free(sc->object);
    free(sc->plane);
    free(sc->normal);
}

/* A random point of the room's free space (local coordinates), outside
 * the sphere and the block. */
static dvec free_point(rtk_pcg32 *rng)
{
    for (;;) {
        dvec x = dv(drange(rng, -0.9, 0.9), drange(rng, -0.9, 0.9), drange(rng, -0.9, 0.9));
        if (dlen(dsub(x, dv(0.3, -0.2, 0.1))) < 0.45)
            continue;
        if (x.x < -0.4 && x.y < -0.6 && x.z < -0.4)
            continue;
        return x;
    }
}

/* A camera ray from eye to a random point of a random triangle and the
 * surface it hits, as an integrator sees it. Returns 0 on a miss. */
static int surface_hit(const surface_scene *sc, rtk_pcg32 *rng, rtk_vec3 eye, rtk_ray *ray, rtk_hit *hit,
                       rtk_surface *sf, tally *tl)
{
    const rtk_scene *s = sc->m.s;
    uint32_t prim = rtk_pcg32_next(rng) % 3 == 0 ? rtk_pcg32_next(rng) % s->triangle_count
                                                 : sc->first[1] + rtk_pcg32_next(rng) % (sc->end[1] - sc->first[1]);
    dvec a = tri_vertex(s, prim, 0), b = tri_vertex(s, prim, 1), c = tri_vertex(s, prim, 2);
    double u = drand(rng), v = drand(rng);
    if (u + v > 1.0)
        u = 1.0 - u, v = 1.0 - v;
    dvec target = dadd(a, dadd(dmul(dsub(b, a), u), dmul(dsub(c, a), v)));
    *ray = make_ray(eye, fdv(dsub(target, dvf(eye))), INFINITY);
    if (!closest_of(s, ray, hit)) {
        tl->rays++;
        tally_bad(tl, ray, "a camera ray inside the closed room missed everything");
        return 0;
    }
    rtk_surface_at(s, ray, hit, sf);
    return 1;
}

typedef enum spawn_kind { SPAWN_AO, SPAWN_MIRROR, SPAWN_REFRACT, SPAWN_LIGHT, SPAWN_SURFACE, SPAWN_KINDS } spawn_kind;

/* Checks one secondary ray leaving triangle prim0 from the side `out0`
 * (+1 outside its object, -1 inside); for SPAWN_SURFACE also arriving at
 * triangle prim1 on side out1. The exact claims, each only when its
 * premises are certified in double:
 * - the origin is strictly on side out0 of prim0's plane (else the offset
 *   failed), and likewise the end point for prim1;
 * - leaving outwards (out0 = +1, direction away from the plane), the ray
 *   stays in the open half-space beyond a face of a convex object: it
 *   never hits that object (no self-hit);
 * - leaving inwards, it moves away from the plane: it never hits the
 *   triangles of that plane; from strictly inside a closed object an
 *   unbounded ray must hit something (no leak);
 * - a shadow segment whose two ends are strictly outside one face plane
 *   of the target's object never hits that object (no false occlusion);
 *   ends strictly on the inner side of the target's plane never hit that
 *   plane;
 * - and the oracle over every triangle. */
static void surface_ray(const surface_scene *sc, const rtk_ray *ray, uint32_t prim0, int out0, uint32_t prim1,
                        int out1, tally *self, tally *oracle)
{
    const rtk_scene *s = sc->m.s;
    dvec o = dvf(ray->org), d = dvf(ray->dir);
    traced tr = trace(s, ray);
    self->rays++;
    oracle->rays++;
    oracle_check(s, ray, &tr, oracle);
    int obj0 = sc->object[prim0];
    if (plane_side(sc, prim0, o) != out0) {
        tally_bad(self, ray, "the offset origin is not strictly %s triangle %u's plane",
                  out0 > 0 ? "outside" : "inside", prim0);
        return;
    }
    double along = ddot(d, sc->normal[prim0]), tol = 1e-12 * dlen(d) * dlen(sc->normal[prim0]);
    if (out0 > 0 && along > tol && tr.hit && sc->object[tr.h.prim] == obj0)
        tally_bad(self, ray, "self-hit: left object %d outwards from triangle %u and hit its triangle %u at t %.9g",
                  obj0, prim0, tr.h.prim, tr.h.t);
    if (out0 < 0 && along < -tol && tr.hit && sc->plane[tr.h.prim] == sc->plane[prim0])
        tally_bad(self, ray, "self-hit: left triangle %u's plane inwards and hit triangle %u of that plane at t %.9g",
                  prim0, tr.h.prim, tr.h.t);
    if (out0 < 0 && along < -tol && ray->tmax == INFINITY && !tr.hit && strictly_inside(sc, obj0, o))
        tally_bad(self, ray, "leak: from strictly inside closed object %d the ray hit nothing", obj0);
    if (prim1 == RTK_INVALID_ID)
        return;
    dvec end = dadd(o, dmul(d, ray->tmax));
    int obj1 = sc->object[prim1];
    if (plane_side(sc, prim1, end) != out1) {
        tally_bad(self, ray, "the offset end point is not strictly %s triangle %u's plane",
                  out1 > 0 ? "outside" : "inside", prim1);
        return;
    }
    int separated = plane_side(sc, prim1, o) == out1;
    if (separated && out1 > 0 && tr.hit && sc->object[tr.h.prim] == obj1)
        tally_bad(self, ray, "false occlusion: the segment to triangle %u hit its object %d (triangle %u at t %.9g)",
                  prim1, obj1, tr.h.prim, tr.h.t);
    if (separated && out1 < 0 && tr.hit && sc->plane[tr.h.prim] == sc->plane[prim1])
        tally_bad(self, ray, "false occlusion: the segment to triangle %u hit triangle %u of its plane at t %.9g", prim1,
                  tr.h.prim, tr.h.t);
}

/* Offsets and directions as an integrator makes them, from a surface hit. */
static void conform_surface(rtk_conform_runner *r, const rtk_plugin *p, const rtk_params *params, uint32_t scale)
{
    dvec *iv = NULL;
    uint32_t *it = NULL, inv = 0, int_ = 0;
    if (!icosphere(3, &iv, &inv, &it, &int_)) {
        rtk_conform_check(r, 0, "surface scene", "out of memory");
        return;
    }
    static const double scales[] = {1e-3, 1e-2, 1e-1, 1.0, 1e1, 1e2, 1e3, 1e4};
    static const double offsets[] = {0.0, 1.0, 1e2, 1e4};
    const dvec heading = dv(0.6, -0.64, 0.48);
    tally self = {0, 0, ""}, oracle = {0, 0, ""};
    uint64_t kinds[SPAWN_KINDS] = {0};
    int configs = 0, skipped = 0;
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 4711u, 2u);
    for (size_t oi = 0; oi < RTK_COUNTOF(offsets); oi++) {
        for (size_t si = 0; si < RTK_COUNTOF(scales); si++) {
            double sc_ = scales[si], off = offsets[oi];
            /* Only where float resolves the scene: one step at the largest
             * coordinate is at most 2^-12 of the scale. */
            double big = off * 0.64 + sc_;
            if (ldexp(1.0, ilogb(big) - 23) > ldexp(sc_, -12)) {
                skipped++;
                continue;
            }
            configs++;
            surface_scene sc;
            dvec offset = dmul(heading, off);
            char what[128];
            snprintf(what, sizeof what, "surface scene at scale %g, offset %g", sc_, off);
            if (!surface_scene_make(&sc, sc_, offset, iv, inv, it, int_) ||
                !mesh_build(r, &sc.m, p, params, 2, what)) {
                if (!sc.m.ok || !sc.normal)
                    rtk_conform_check(r, 0, what, "out of memory");
                surface_scene_free(&sc);
                continue;
            }
            for (uint32_t cam = 0; cam < 120 * scale; cam++) {
                rtk_vec3 eye = fdv(dadd(offset, dmul(free_point(&rng), sc_)));
                rtk_ray ray;
                rtk_hit hit;
                rtk_surface sf;
                if (!surface_hit(&sc, &rng, eye, &ray, &hit, &sf, &self))
                    continue;
                uint32_t prim0 = hit.prim;
                int camera_side = ddot(dvf(sf.ng), sc.normal[prim0]) > 0 ? 1 : -1;
                rtk_vec3 dn = rtk_vec3_normalize(ray.dir), ng = sf.ng;
                rtk_vec3 up = rtk_offset_ray_origin(sf.p, ng), down = rtk_offset_ray_origin(sf.p, rtk_vec3_neg(ng));
                for (int k = 0; k < SPAWN_KINDS; k++) {
                    rtk_ray sec;
                    uint32_t prim1 = RTK_INVALID_ID;
                    int side = camera_side, side1 = 0;
                    if (k == SPAWN_AO) {
                        float u1 = rtk_pcg32_float(&rng), u2 = rtk_pcg32_float(&rng);
                        dvec t, b;
                        dframe(dvf(ng), &t, &b);
                        float rr = sqrtf(u1), ph = 2.0f * (float)M_PI * u2;
                        rtk_vec3 dir = rtk_vec3_add(rtk_vec3_scale(ng, sqrtf(fmaxf(0.0f, 1.0f - u1))),
                                                    rtk_vec3_add(rtk_vec3_scale(fdv(t), rr * cosf(ph)),
                                                                 rtk_vec3_scale(fdv(b), rr * sinf(ph))));
                        sec = make_ray(up, dir, INFINITY);
                    } else if (k == SPAWN_MIRROR) {
                        rtk_vec3 dir = rtk_vec3_sub(dn, rtk_vec3_scale(ng, 2.0f * rtk_vec3_dot(dn, ng)));
                        sec = make_ray(up, dir, INFINITY);
                    } else if (k == SPAWN_REFRACT) {
                        float eta = 1.0f / 1.5f, cosi = -rtk_vec3_dot(dn, ng);
                        float k2 = 1.0f - eta * eta * (1.0f - cosi * cosi);
                        rtk_vec3 dir = rtk_vec3_add(rtk_vec3_scale(dn, eta), rtk_vec3_scale(ng, eta * cosi - sqrtf(k2)));
                        sec = make_ray(down, dir, INFINITY);
                        side = -camera_side;
                    } else if (k == SPAWN_LIGHT) {
                        rtk_vec3 light = fdv(dadd(offset, dmul(free_point(&rng), sc_)));
                        if (rtk_vec3_dot(rtk_vec3_sub(light, sf.p), ng) <= 0.0f)
                            continue;
                        sec = rtk_shadow_ray(sf.p, ng, light, rtk_vec3_make(0.0f, 0.0f, 0.0f));
                    } else {
                        /* The far end is found as a path tracer finds
                         * the next vertex: by a ray from the offset origin. */
                        rtk_ray probe = make_ray(up, fdv(drand_cone(&rng, dvf(ng), 0.05)), INFINITY);
                        rtk_hit hit2;
                        rtk_surface sf2;
                        if (!closest_of(sc.m.s, &probe, &hit2) || hit2.prim == prim0)
                            continue;
                        rtk_surface_at(sc.m.s, &probe, &hit2, &sf2);
                        if (rtk_vec3_dot(rtk_vec3_sub(sf2.p, sf.p), ng) <= 0.0f ||
                            rtk_vec3_dot(rtk_vec3_sub(sf.p, sf2.p), sf2.ng) <= 0.0f)
                            continue;
                        sec = rtk_shadow_ray(sf.p, ng, sf2.p, sf2.ng);
                        prim1 = hit2.prim;
                        side1 = ddot(dvf(sf2.ng), sc.normal[prim1]) > 0 ? 1 : -1;
                    }
                    kinds[k]++;
                    surface_ray(&sc, &sec, prim0, side, prim1, side1, &self, &oracle);
                }
            }
            surface_scene_free(&sc);
        }
    }
    free(iv);
    free(it);
    char name[512];
    snprintf(name, sizeof name,
             "rays leaving surfaces through rtk_offset_ray_origin and rtk_shadow_ray at scales 1e-3..1e4, offsets 0..1e4 (%d scenes; "
             "%d combinations float cannot resolve left out): %llu AO, %llu mirror, %llu refraction, %llu shadow "
             "to a point, %llu shadow to a surface: no self-hit, no leak, no false occlusion",
             configs, skipped, (unsigned long long)kinds[0], (unsigned long long)kinds[1], (unsigned long long)kinds[2],
             (unsigned long long)kinds[3], (unsigned long long)kinds[4]);
    tally_check(r, &self, name);
    snprintf(name, sizeof name, "the same %llu rays agree with the oracle over every triangle",
             (unsigned long long)oracle.rays);
    tally_check(r, &oracle, name);
}

/* ---- closed boxes far from the origin ---- */

/* A closed box tessellated n x n per face with shared vertices: corner
 * centre + rot * (h * (2 i / n - 1), ...). */
static void mesh_tessellated_box(mesh *m, dvec centre, const dvec rot[3], double h, int n)
{
    uint32_t *id = malloc(sizeof *id * (size_t)(n + 1) * (n + 1) * (n + 1));
    if (!id) {
        m->ok = 0;
        return;
    }
    for (int i = 0; i <= n; i++)
        for (int j = 0; j <= n; j++)
            for (int k = 0; k <= n; k++) {
                if (i != 0 && i != n && j != 0 && j != n && k != 0 && k != n)
                    continue;
                dvec l = dv(h * (2.0 * i / n - 1), h * (2.0 * j / n - 1), h * (2.0 * k / n - 1));
                dvec w = dadd(dmul(rot[0], l.x), dadd(dmul(rot[1], l.y), dmul(rot[2], l.z)));
                id[(i * (n + 1) + j) * (n + 1) + k] = mesh_vertex(m, dadd(centre, w));
            }
    for (int axis = 0; axis < 3; axis++)
        for (int side = 0; side <= n; side += n)
            for (int a = 0; a < n; a++)
                for (int b = 0; b < n; b++) {
                    uint32_t q[4];
                    for (int c = 0; c < 4; c++) {
                        int g[3], u = a + (c == 1 || c == 2), v = b + (c >= 2);
                        g[axis] = side, g[(axis + 1) % 3] = u, g[(axis + 2) % 3] = v;
                        q[c] = id[(g[0] * (n + 1) + g[1]) * (n + 1) + g[2]];
                    }
                    mesh_triangle(m, q[0], q[1], q[2]);
                    mesh_triangle(m, q[0], q[2], q[3]);
                }
    free(id);
}

/* Closed boxes at 1e6 and 1e7 (float steps 0.0625 and 1), 4, 64 and 4096
 * steps wide, axis-aligned and rotated, each face 4 x 4 quads. Origins
 * strictly inside (3 steps from every face, more than the rounding of the
 * corners), rays in random directions, at vertices and edge points of the
 * tessellation, and along the axes with +-0 components. Criterion: every
 * ray hits, closest and any, at t > 0; and the oracle. */
static void conform_far_box(rtk_conform_runner *r, const rtk_plugin *p, const rtk_params *params, uint32_t scale)
{
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 10000000u, 6u);
    tally tl = {0, 0, ""}, oracle = {0, 0, ""};
    static const double offsets[] = {1e6, 1e7}, widths[] = {4, 64, 4096};
    for (int oi = 0; oi < 2; oi++)
        for (int wi = 0; wi < 3; wi++)
            for (int rot_i = 0; rot_i < 2; rot_i++) {
                double step = ldexp(1.0, ilogb(offsets[oi]) - 23), h = widths[wi] * step;
                dvec centre = dmul(dv(1.0, -0.75, 0.5), offsets[oi]);
                centre = dv(round(centre.x / (2 * step)) * 2 * step, round(centre.y / (2 * step)) * 2 * step,
                            round(centre.z / (2 * step)) * 2 * step);
                dvec rot[3] = {dv(1, 0, 0), dv(0, 1, 0), dv(0, 0, 1)};
                if (rot_i) {
                    rot[2] = drand_unit(&rng);
                    dframe(rot[2], &rot[0], &rot[1]);
                }
                mesh m = mesh_new("conform far box");
                mesh_tessellated_box(&m, centre, rot, h, 4);
                char what[128];
                snprintf(what, sizeof what, "closed box at %g, %g steps wide%s", offsets[oi], widths[wi],
                         rot_i ? ", rotated" : "");
                if (!mesh_build(r, &m, p, params, 2, what)) {
                    rtk_scene_free(m.s);
                    continue;
                }
                const rtk_scene *s = m.s;
                double reach = h - 3 * step;
                for (uint32_t i = 0; i < 2000 * scale; i++) {
                    dvec l = dv(drange(&rng, -reach, reach), drange(&rng, -reach, reach), drange(&rng, -reach, reach));
                    rtk_vec3 org = fdv(dadd(centre, dadd(dmul(rot[0], l.x), dadd(dmul(rot[1], l.y), dmul(rot[2], l.z)))));
                    dvec lo = dsub(dvf(org), centre);
                    if (fabs(ddot(lo, rot[0])) > reach + step || fabs(ddot(lo, rot[1])) > reach + step ||
                        fabs(ddot(lo, rot[2])) > reach + step)
                        continue;
                    rtk_vec3 dir;
                    uint32_t prim = rtk_pcg32_next(&rng) % s->triangle_count;
                    int corner = (int)(rtk_pcg32_next(&rng) % 3);
                    switch (i % 4) {
                    case 0: dir = fdv(drand_unit(&rng)); break;
                    case 1: dir = fdv(dsub(tri_vertex(s, prim, corner), dvf(org))); break;
                    case 2: {
                        dvec a = tri_vertex(s, prim, corner), b = tri_vertex(s, prim, (corner + 1) % 3);
                        dir = fdv(dsub(dadd(a, dmul(dsub(b, a), drand(&rng))), dvf(org)));
                        break;
                    }
                    default: {
                        float c[3] = {rtk_pcg32_next(&rng) % 2 ? 0.0f : -0.0f, rtk_pcg32_next(&rng) % 2 ? 0.0f : -0.0f,
                                      rtk_pcg32_next(&rng) % 2 ? 0.0f : -0.0f};
                        c[corner] = rtk_pcg32_next(&rng) % 2 ? 1.0f : -1.0f;
                        dir = rtk_vec3_make(c[0], c[1], c[2]);
                        break;
                    }
                    }
                    if (dir.x == 0.0f && dir.y == 0.0f && dir.z == 0.0f)
                        continue;
                    rtk_ray ray = make_ray(org, dir, INFINITY);
                    traced tr = trace(s, &ray);
                    tl.rays++;
                    if (!tr.hit || !tr.any || !(tr.h.t > 0.0f))
                        tally_bad(&tl, &ray, "leak at %s: closest %s (t %.9g), any %s", what,
                                  tr.hit ? "hit" : "MISSED", tr.h.t, tr.any ? "hit" : "MISSED");
                    oracle.rays++;
                    oracle_check(s, &ray, &tr, &oracle);
                }
                rtk_scene_free(m.s);
            }
    char name[400];
    snprintf(name, sizeof name,
             "closed boxes at 1e6 and 1e7, 4..4096 float steps wide, straight and rotated: %llu rays from inside, "
             "no leak (closest and any)",
             (unsigned long long)tl.rays);
    tally_check(r, &tl, name);
    snprintf(name, sizeof name, "the same %llu rays agree with the oracle over every triangle",
             (unsigned long long)oracle.rays);
    tally_check(r, &oracle, name);
}

/* ---- tiny triangles ---- */

/* 48 triangles per size, edges about 1e-3 .. 1e-8, placed 1000-2000 edge
 * lengths from the origin (so float resolves each by ~8000 steps), rays
 * from 2..100 edge lengths away aimed at the centroid, at least 17
 * degrees off the plane. Criterion: every ray the oracle certifies as a
 * hit of its target hits it (or something certainly before it), closest
 * and any; every ray agrees with the oracle. */
static void conform_tiny(rtk_conform_runner *r, const rtk_plugin *p, const rtk_params *params, uint32_t scale)
{
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 1313u, 8u);
    mesh m = mesh_new("conform tiny");
    const int per = 48, sizes = 6;
    for (int si = 0; si < sizes; si++) {
        double e = pow(10.0, -3 - si);
        for (int i = 0; i < per; i++) {
            dvec c = dmul(drand_unit(&rng), e * drange(&rng, 1000, 2000));
            dvec v[3];
            do {
                for (int k = 0; k < 3; k++)
                    v[k] = dadd(c, dmul(drand_unit(&rng), 0.6 * e));
            } while (dlen(dcross(dsub(v[1], v[0]), dsub(v[2], v[0]))) < 0.2 * e * e);
            uint32_t a = mesh_vertex(&m, v[0]), b = mesh_vertex(&m, v[1]), cc = mesh_vertex(&m, v[2]);
            mesh_triangle(&m, a, b, cc);
        }
    }
    if (!mesh_build(r, &m, p, params, 2, "tiny triangles")) {
        rtk_scene_free(m.s);
        return;
    }
    const rtk_scene *s = m.s;
    tally oracle = {0, 0, ""};
    for (int si = 0; si < sizes; si++) {
        double e = pow(10.0, -3 - si);
        tally tl = {0, 0, ""};
        uint64_t certified = 0;
        for (int i = 0; i < per; i++) {
            uint32_t prim = (uint32_t)(si * per + i);
            dvec a = tri_vertex(s, prim, 0), b = tri_vertex(s, prim, 1), c = tri_vertex(s, prim, 2);
            dvec n = dunit(dcross(dsub(b, a), dsub(c, a)));
            rtk_vec3 target = fdv(dmul(dadd(a, dadd(b, c)), 1.0 / 3.0));
            for (uint32_t j = 0; j < 30 * scale; j++) {
                dvec w = drand_cone(&rng, j % 2 ? n : dmul(n, -1.0), 0.3);
                rtk_vec3 org = fdv(dadd(dvf(target), dmul(w, e * dlogrange(&rng, 2, 100))));
                rtk_ray ray = make_ray(org, fdv(dsub(dvf(target), dvf(org))), INFINITY);
                rtk_vec3 va, vb, vc;
                rtk_scene_triangle(s, prim, &va, &vb, &vc);
                double t = 0, dt = 0;
                traced tr = trace(s, &ray);
                oracle.rays++;
                oracle_check(s, &ray, &tr, &oracle);
                if (oracle_triangle(&ray, va, vb, vc, &t, &dt) != ORACLE_HIT)
                    continue;
                certified++;
                tl.rays++;
                if (!tr.hit || !tr.any || tr.h.t > t + dt)
                    tally_bad(&tl, &ray, "aimed at triangle %u (certain hit at t %.9g): closest %s prim %u t %.9g, any %s",
                              prim, t, tr.hit ? "hit" : "MISSED", tr.h.prim, tr.h.t, tr.any ? "hit" : "MISSED");
            }
        }
        char name[400];
        snprintf(name, sizeof name,
                 "triangles with edges ~%g: %d triangles, %llu rays at centroids, every certain hit found "
                 "(%llu of %u aimed rays certified)",
                 e, per, (unsigned long long)tl.rays, (unsigned long long)certified, per * 30 * scale);
        tally_check(r, &tl, name);
    }
    char name[400];
    snprintf(name, sizeof name, "tiny triangles: all %llu rays agree with the oracle over every triangle",
             (unsigned long long)oracle.rays);
    tally_check(r, &oracle, name);
    rtk_scene_free(m.s);
}

/* ---- sliver fans ---- */

/* Three fans of 1000 needles sharing a centre vertex: a full disc of
 * radius 1, an arc of 0.1 rad (needles 1e-4 rad wide) and a disc of
 * radius 100 at (1e3, -2e3, 5e2). Rays aimed at points of shared edges
 * (and the disc centres) at least 1e-4 radii inside the fan's outline, from
 * 0.01..10 radii away, at least 10 degrees off the plane; a ray is kept
 * when its line meets the fan plane within 1e-5 radii of its target
 * (double). Criterion: every kept ray hits, closest and any (watertight
 * edges: no ray slips between two needles); and the oracle on a quarter. */
static void conform_fans(rtk_conform_runner *r, const rtk_plugin *p, const rtk_params *params, uint32_t scale)
{
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 1000u, 9u);
    const dvec centres[3] = {dv(0.1, 0.2, -0.3), dv(3, 1, 2), dv(1e3, -2e3, 5e2)};
    const double radii[3] = {1, 1, 100}, spans[3] = {2 * M_PI, 0.1, 2 * M_PI};
    const int needles = 1000;
    dvec e1[3], e2[3], nrm[3];
    uint32_t first[3];
    mesh m = mesh_new("conform fans");
    for (int f = 0; f < 3; f++) {
        nrm[f] = drand_unit(&rng);
        dframe(nrm[f], &e1[f], &e2[f]);
        first[f] = m.s ? m.s->triangle_count : 0;
        uint32_t c = mesh_vertex(&m, centres[f]), rim[1001];
        int full = spans[f] > 6;
        for (int i = 0; i <= needles; i++) {
            if (full && i == needles) {
                rim[i] = rim[0];
                continue;
            }
            double a = spans[f] * i / needles;
            rim[i] = mesh_vertex(&m, dadd(centres[f], dmul(dadd(dmul(e1[f], cos(a)), dmul(e2[f], sin(a))), radii[f])));
        }
        for (int i = 0; i < needles; i++)
            mesh_triangle(&m, c, rim[i], rim[i + 1]);
    }
    if (!mesh_build(r, &m, p, params, 2, "sliver fans")) {
        rtk_scene_free(m.s);
        return;
    }
    const rtk_scene *s = m.s;
    tally tl = {0, 0, ""}, oracle = {0, 0, ""};
    uint64_t skipped = 0;
    for (uint32_t i = 0; i < 6000 * scale; i++) {
        int f = (int)(i % 3), full = spans[f] > 6;
        int edge = full ? (int)(rtk_pcg32_next(&rng) % needles) : 50 + (int)(rtk_pcg32_next(&rng) % (needles - 100));
        /* Needle `edge` is (centre, rim[edge], rim[edge + 1]): its corner 1 is rim[edge]. */
        dvec c = tri_vertex(s, first[f] + (uint32_t)(edge < needles ? edge : 0), 0);
        dvec rim = tri_vertex(s, first[f] + (uint32_t)edge, 1);
        double t = full && i % 16 == 0 ? 0.0 : drange(&rng, 0.05, 0.98);
        rtk_vec3 target = fdv(dadd(c, dmul(dsub(rim, c), t)));
        dvec w = drand_cone(&rng, rtk_pcg32_next(&rng) % 2 ? nrm[f] : dmul(nrm[f], -1.0), 0.17);
        rtk_vec3 org = fdv(dadd(dvf(target), dmul(w, radii[f] * dlogrange(&rng, 0.01, 10))));
        rtk_ray ray = make_ray(org, fdv(dsub(dvf(target), dvf(org))), INFINITY);
        dvec o = dvf(ray.org), d = dvf(ray.dir);
        double tp = ddot(dsub(dvf(target), o), nrm[f]) / ddot(d, nrm[f]);
        if (dlen(dsub(dadd(o, dmul(d, tp)), dvf(target))) > 1e-5 * radii[f]) {
            skipped++;
            continue;
        }
        tl.rays++;
        traced tr = trace(s, &ray);
        if (!tr.hit || !tr.any)
            tally_bad(&tl, &ray, "aimed at shared edge %d of fan %d: closest %s, any %s", edge, f,
                      tr.hit ? "hit" : "MISSED", tr.any ? "hit" : "MISSED");
        if (i % 4 == 0) {
            oracle.rays++;
            oracle_check(s, &ray, &tr, &oracle);
        }
    }
    char name[400];
    snprintf(name, sizeof name,
             "1000-needle sliver fans: %llu rays at shared edges, zero misses, closest and any (%llu skipped)",
             (unsigned long long)tl.rays, (unsigned long long)skipped);
    tally_check(r, &tl, name);
    snprintf(name, sizeof name, "sliver fans: %llu of those rays agree with the oracle over every triangle",
             (unsigned long long)oracle.rays);
    tally_check(r, &oracle, name);
    rtk_scene_free(m.s);
}

/* 3x4 row-major T R S: rotation by degrees about axis. */
static void instance_transform(dvec t, dvec axis, double degrees, dvec s, double m[12])
{
    dvec u = dunit(axis);
    double a = degrees * M_PI / 180.0, c = cos(a), sn = sin(a), k = 1.0 - c;
    double rot[9] = {c + u.x * u.x * k,       u.x * u.y * k - u.z * sn, u.x * u.z * k + u.y * sn,
                     u.y * u.x * k + u.z * sn, c + u.y * u.y * k,       u.y * u.z * k - u.x * sn,
                     u.z * u.x * k - u.y * sn, u.z * u.y * k + u.x * sn, c + u.z * u.z * k};
    const double sc[3] = {s.x, s.y, s.z}, tr[3] = {t.x, t.y, t.z};
    for (int row = 0; row < 3; row++) {
        for (int col = 0; col < 3; col++)
            m[4 * row + col] = rot[3 * row + col] * sc[col];
        m[4 * row + 3] = tr[row];
    }
}

/* Brute force over every placed triangle: the scene's own with the world
 * ray, each instance's with the ray in its object space as the kernel
 * makes it; ties to own triangles, then the lowest instance and triangle. */
static int brute_instances(const rtk_scene *s, const rtk_ray *ray, rtk_hit *hit)
{
    int found = brute_closest(s, ray, hit);
    hit->inst = RTK_INVALID_ID;
    float best = found ? hit->t : ray->tmax;
    for (uint32_t i = 0; i < s->instance_count; i++) {
        rtk_ray lr;
        if (!rtk_instance_local_ray(&s->instances[i], ray, &lr))
            continue;
        const rtk_scene *mesh = s->meshes[s->instances[i].mesh];
        for (uint32_t k = 0; k < mesh->triangle_count; k++) {
            rtk_vec3 a, b, c;
            rtk_scene_triangle(mesh, k, &a, &b, &c);
            float t, u, v;
            if (rtk_intersect_triangle(&lr, a, b, c, &t, &u, &v) && (t < best || (t == best && !found))) {
                best = t;
                found = 1;
                hit->t = t, hit->u = u, hit->v = v, hit->prim = k, hit->inst = i;
            }
        }
    }
    return found;
}

/* The instanced scene, unfinished: a mesh of 200 triangles placed 60
 * times (rotated, scaled unevenly, mirrored, one 1e3 away) beside 40
 * world-space triangles; NULL when out of memory. */
static rtk_scene *instanced_scene(rtk_pcg32 *rng)
{
    rtk_scene *s = rtk_scene_new("conform instances", 0);
    uint32_t mi = 0;
    if (!s || rtk_scene_add_mesh(s, "conform mesh", &mi) != RTK_OK) {
        rtk_scene_free(s);
        return NULL;
    }
    for (int i = 0; i < 240; i++) {
        rtk_vec3 c = rtk_vec3_make(rtk_conform_frand(rng, -1, 1), rtk_conform_frand(rng, -1, 1),
                                   rtk_conform_frand(rng, -1, 1)),
                 v[3];
        for (int k = 0; k < 3; k++)
            v[k] = rtk_vec3_add(c, rtk_vec3_make(rtk_conform_frand(rng, -.3f, .3f), rtk_conform_frand(rng, -.3f, .3f),
                                                 rtk_conform_frand(rng, -.3f, .3f)));
        add_tri(i < 200 ? s->meshes[mi] : s, v[0], v[1], v[2]);
    }
    for (int i = 0; i < 60; i++) {
        double m[12];
        double sc = drange(rng, 0.3, 2.0);
        dvec scale = dv(sc * (i % 4 == 3 ? -1.0 : 1.0), sc * drange(rng, 0.5, 1.5), sc);
        dvec at = dv(drange(rng, -6, 6), drange(rng, -6, 6), drange(rng, -6, 6));
        if (i == 59)
            at = dv(1e3, -1e3, 5e2);
        instance_transform(at, drand_unit(rng), drange(rng, -180, 180), scale, m);
        rtk_scene_add_instance(s, mi, m, "conform");
    }
    return s;
}

/* Two-level instancing: the plugin builds a mesh's tree and the top level
 * over 60 placements (rotated, scaled unevenly, mirrored, 1e3 away)
 * beside 40 world-space triangles; closest and any hit must be brute
 * force's (another triangle only at the same distance within rounding).
 * An accelerator with its own traversal must refuse the scene, saying so. */
static void conform_instances(rtk_conform_runner *r, const rtk_plugin *p, const rtk_params *params, const char *label)
{
    char name[256];
    snprintf(name, sizeof name, "instanced scene (a mesh placed 60 times, top level by the plugin) = brute force [%s]",
             label);
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 60, 2);
    rtk_scene *s = instanced_scene(&rng);
    if (!s) {
        rtk_conform_check(r, 0, name, "out of memory");
        return;
    }
    rtk_status st = rtk_scene_finish(s);
    rtk_bvh_cache_use use;
    if (st == RTK_OK)
        st = rtk_bvh_build_cached(s, p, params, 2, NULL, &use);
    if (rtk_accelerator_traverses_itself(p)) {
        snprintf(name, sizeof name, "an instanced scene is refused, naming the alternatives (own traversal) [%s]", label);
        rtk_conform_check(r, st != RTK_OK && strstr(rtk_error_message(), "cannot nest"), name, "%s",
                          st == RTK_OK ? "built" : rtk_error_message());
        rtk_scene_free(s);
        return;
    }
    if (st != RTK_OK) {
        rtk_conform_check(r, 0, name, "build failed: %s", rtk_error_message());
        rtk_scene_free(s);
        return;
    }
    tally tl;
    memset(&tl, 0, sizeof tl);
    brute_memo *memo = brute_memo_for(MEMO_INSTANCES, s);
    for (int i = 0; i < 4000; i++) {
        dvec o = i == 3999 ? dv(1e3 + 20, -1e3, 5e2) : dv(drange(&rng, -9, 9), drange(&rng, -9, 9), drange(&rng, -9, 9));
        dvec d = i == 3999 ? dv(-1, 0, 0) : drand_unit(&rng);
        rtk_ray ray = make_ray(fdv(o), fdv(d), i % 3 == 0 ? (float)drange(&rng, 0.5, 8) : INFINITY);
        traced tr = trace(s, &ray);
        rtk_hit b;
        int bh = brute_kept(memo, (uint32_t)i, s, &ray, &b, brute_instances);
        tl.rays++;
        double slack = 8.0 * FLT_EPSILON * (dlen(o) + fabs((double)b.t));
        if (tr.hit != tr.any || tr.hit != bh)
            tally_bad(&tl, &ray, "closest %s, any %s, brute force %s", tr.hit ? "hit" : "miss", tr.any ? "hit" : "miss",
                      bh ? "hit" : "miss");
        else if (bh && (tr.h.inst != b.inst || tr.h.prim != b.prim) && !(fabs((double)tr.h.t - b.t) <= slack))
            tally_bad(&tl, &ray, "hit (instance %u, triangle %u) at t %.9g, brute force (%u, %u) at %.9g", tr.h.inst,
                      tr.h.prim, tr.h.t, b.inst, b.prim, b.t);
        else if (bh && tr.h.inst == b.inst && tr.h.prim == b.prim && tr.h.t != b.t)
            tally_bad(&tl, &ray, "t %.9g, brute force %.9g on the same triangle", tr.h.t, b.t);
    }
    tally_check(r, &tl, name);
    rtk_scene_free(s);
}

/* ---- batches: every parameter set ---- */

/* Batch sizes, used in turn: one ray, a packet less one, one and one more,
 * and whole tiles. */
static const uint32_t batch_sizes[] = {1, 7, 8, 9, 64, 256};

/* The box the rays of a batch check start around: s's triangles, or
 * [-1, 1]^3 when it has none. */
static void batch_box(const rtk_scene *s, dvec *lo, dvec *hi)
{
    *lo = dv(INFINITY, INFINITY, INFINITY), *hi = dv(-INFINITY, -INFINITY, -INFINITY);
    for (uint32_t i = 0; i < s->triangle_count; i++)
        for (int k = 0; k < 3; k++) {
            dvec v = tri_vertex(s, i, k);
            *lo = dv(fmin(lo->x, v.x), fmin(lo->y, v.y), fmin(lo->z, v.z));
            *hi = dv(fmax(hi->x, v.x), fmax(hi->y, v.y), fmax(hi->z, v.z));
        }
    if (!(lo->x <= hi->x))
        *lo = dv(-1, -1, -1), *hi = dv(1, 1, 1);
}

/* A point of a random triangle of s (on an edge or at a corner for some
 * i), or of the box when s has no triangles. */
static dvec batch_target(const rtk_scene *s, dvec lo, dvec hi, rtk_pcg32 *rng, uint32_t i)
{
    if (!s->triangle_count)
        return dv(drange(rng, lo.x, hi.x), drange(rng, lo.y, hi.y), drange(rng, lo.z, hi.z));
    uint32_t prim = rtk_pcg32_next(rng) % s->triangle_count;
    dvec a = tri_vertex(s, prim, 0), b = tri_vertex(s, prim, 1), c = tri_vertex(s, prim, 2);
    double u = drand(rng), v = i % 4 == 1 ? 0.0 : drand(rng);
    if (u + v > 1.0)
        u = 1.0 - u, v = 1.0 - v;
    return i % 8 == 3 ? a : dadd(a, dadd(dmul(dsub(b, a), u), dmul(dsub(c, a), v)));
}

/* count rays in blocks, as a renderer makes them: a tile of camera rays
 * (one origin outside or inside the box, neighbouring directions 1e-4 to
 * 0.05 rad apart, row by row), one point's 8 AO rays (random directions
 * about the normal of a triangle, origin just off it, short), or
 * incoherent rays (random origins and directions, half aimed at
 * triangles, some with a finite tmax, a positive or a negative tmin). */
static void batch_rays(const rtk_scene *s, dvec lo, dvec hi, rtk_pcg32 *rng, rtk_ray *rays, uint32_t count)
{
    dvec centre = dmul(dadd(lo, hi), 0.5);
    double radius = fmax(0.5 * dlen(dsub(hi, lo)), 1e-3);
    for (uint32_t n = 0; n < count;) {
        uint32_t kind = rtk_pcg32_next(rng) % 3, left = count - n;
        if (kind == 0) {
            static const uint32_t widths[] = {4, 8, 16, 37};
            uint32_t w = widths[rtk_pcg32_next(rng) % RTK_COUNTOF(widths)], h = 1 + rtk_pcg32_next(rng) % 8;
            dvec eye = rtk_pcg32_next(rng) % 4 ? dadd(centre, dmul(drand_unit(rng), radius * drange(rng, 1.5, 4.0)))
                                               : dadd(centre, dmul(drand_unit(rng), radius * drange(rng, 0.0, 0.5)));
            dvec fwd = dunit(dsub(batch_target(s, lo, hi, rng, n), eye)), right, up;
            dframe(fwd, &right, &up);
            double step = dlogrange(rng, 1e-4, 0.05);
            float tmax = rtk_pcg32_next(rng) % 4 ? INFINITY : (float)(radius * drange(rng, 0.5, 4.0));
            for (uint32_t y = 0; y < h && n < count; y++)
                for (uint32_t x = 0; x < w && n < count; x++) {
                    dvec d = dadd(fwd, dadd(dmul(right, step * (x - 0.5 * w)), dmul(up, step * (y - 0.5 * h))));
                    rays[n++] = make_ray(fdv(eye), fdv(dunit(d)), tmax);
                }
        } else if (kind == 1) {
            dvec p = batch_target(s, lo, hi, rng, n), nrm = drand_unit(rng);
            if (s->triangle_count) {
                uint32_t prim = rtk_pcg32_next(rng) % s->triangle_count;
                dvec a = tri_vertex(s, prim, 0), b = tri_vertex(s, prim, 1), c = tri_vertex(s, prim, 2);
                dvec ng = dcross(dsub(b, a), dsub(c, a));
                double u = drand(rng), v = drand(rng);
                if (u + v > 1.0)
                    u = 1.0 - u, v = 1.0 - v;
                p = dadd(a, dadd(dmul(dsub(b, a), u), dmul(dsub(c, a), v)));
                if (dlen(ng) > 0.0)
                    nrm = dmul(dunit(ng), rtk_pcg32_next(rng) % 2 ? 1.0 : -1.0);
            }
            rtk_vec3 org = fdv(dadd(p, dmul(nrm, 1e-4 * radius)));
            for (uint32_t k = 0; k < 8 && n < count; k++)
                rays[n++] = make_ray(org, fdv(drand_cone(rng, nrm, 0.0)), (float)(0.2 * radius));
        } else {
            uint32_t m = 1 + rtk_pcg32_next(rng) % 64;
            for (uint32_t k = 0; k < m && k < left; k++) {
                dvec o = dadd(centre, dmul(dv(drange(rng, -1.5, 1.5), drange(rng, -1.5, 1.5), drange(rng, -1.5, 1.5)),
                                           radius));
                dvec d = rtk_pcg32_next(rng) % 2 ? dsub(batch_target(s, lo, hi, rng, n), o) : drand_unit(rng);
                rtk_ray ray = make_ray(fdv(o), fdv(d), n % 5 == 0 ? (float)(radius * drange(rng, 0.1, 3.0)) : INFINITY);
                if (n % 16 == 7)
                    ray.tmin = (float)(-radius * drand(rng));
                else if (n % 16 == 11)
                    ray.tmin = (float)(1e-3 * radius);
                rays[n++] = ray;
            }
        }
    }
}

/* Traces rays in batches of batch_sizes in turn (from size index first)
 * through rtk_bvh_closest_batch and rtk_bvh_any_batch, then one by one,
 * and tallies every ray whose answers differ: with a hit, every field of
 * rtk_hit bit for bit; on a miss prim RTK_INVALID_ID; occluded 0 or 1 as
 * rtk_bvh_any says. hits and occluded have room for count. */
static void batch_compare(const rtk_scene *s, const rtk_ray *rays, uint32_t count, uint32_t first, rtk_hit *hits,
                          uint8_t *occluded, tally *tl, uint64_t *got, uint64_t *blocked)
{
    memset(hits, 0x5a, sizeof *hits * count);
    memset(occluded, 0x5a, count);
    for (uint32_t i = 0, k = first; i < count; k++) {
        uint32_t n = batch_sizes[k % RTK_COUNTOF(batch_sizes)];
        n = n < count - i ? n : count - i;
        rtk_bvh_closest_batch(s, rays + i, n, hits + i);
        rtk_bvh_any_batch(s, rays + i, n, occluded + i);
        i += n;
    }
    for (uint32_t i = 0; i < count; i++) {
        rtk_hit h;
        memset(&h, 0x5a, sizeof h);
        int hit = rtk_bvh_closest(s, &rays[i], &h), any = rtk_bvh_any(s, &rays[i]) != 0;
        const rtk_hit *b = &hits[i];
        tl->rays++;
        *got += (uint64_t)hit;
        *blocked += (uint64_t)any;
        if (hit ? memcmp(&h, b, sizeof h) != 0 : b->prim != RTK_INVALID_ID)
            tally_bad(tl, &rays[i],
                      "ray %u: batch prim %u inst %u t %a u %a v %a; single %s prim %u inst %u t %a u %a v %a", i,
                      b->prim, b->inst, b->t, b->u, b->v, hit ? "hit" : "miss", h.prim, h.inst, h.t, h.u, h.v);
        else if (occluded[i] != any)
            tally_bad(tl, &rays[i], "ray %u: batch occluded %u, single any hit %d", i, occluded[i], any);
    }
}

/* Batches of count rays over s against single rays, one check line. */
static void batch_check(rtk_conform_runner *r, const rtk_scene *s, dvec lo, dvec hi, uint32_t count, uint64_t seed,
                        const char *what, const char *label)
{
    rtk_ray *rays = malloc(sizeof *rays * count);
    rtk_hit *hits = malloc(sizeof *hits * count);
    uint8_t *occluded = malloc(count);
    char name[448];
    snprintf(name, sizeof name, "batches = single rays, closest and any: %s [%s]", what, label);
    if (!rays || !hits || !occluded) {
        rtk_conform_check(r, 0, name, "out of memory");
        free(rays), free(hits), free(occluded);
        return;
    }
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 2929u, seed);
    batch_rays(s, lo, hi, &rng, rays, count);
    tally tl = {0, 0, ""};
    uint64_t got = 0, blocked = 0, packed = rtk_wide_packet_rays();
    batch_compare(s, rays, count, (uint32_t)seed, hits, occluded, &tl, &got, &blocked);
    packed = rtk_wide_packet_rays() - packed;
    snprintf(name, sizeof name,
             "batches of 1, 7, 8, 9, 64, 256 rays = single rays bit for bit, closest and any: %s, %u rays (%llu hits, "
             "%llu occluded; %llu of 2 x %u traced in the kernel's packets, origin groups or streams) [%s]",
             what, count, (unsigned long long)got, (unsigned long long)blocked, (unsigned long long)packed, count,
             label);
    tally_check(r, &tl, name);
    free(rays), free(hits), free(occluded);
}

/* The first of rays whose closest hit changes when it is the sample's
 * camera ray (it meets the back of a single-sided material first), or
 * count when none does. */
static uint32_t camera_ray_pick(const rtk_scene *s, const rtk_ray *rays, uint32_t count)
{
    rtk_camera camera;
    memset(&camera, 0, sizeof camera);
    rtk_ctx plain, cam;
    memset(&plain, 0, sizeof plain);
    plain.scene = s;
    cam = plain;
    cam.camera = &camera;
    for (uint32_t i = 0; i < count && s->single_sided; i++) {
        rtk_hit a, b;
        cam.camera_ray = rays[i];
        int ha = rtk_trace(&plain, &rays[i], &a), hb = rtk_trace(&cam, &rays[i], &b);
        if (ha != hb || (ha && (a.prim != b.prim || a.t != b.t)))
            return i;
    }
    return count;
}

/* rtk_trace_batch and rtk_occluded_batch against rtk_trace and
 * rtk_occluded with every fifth ray made invalid (NaN or infinite origin,
 * zero or infinite direction, tmin > tmax, NaN tmax) and one ray marked as
 * the sample's camera ray (one that passes the back of a single-sided
 * material where the scene has one): equal answers (invalid rays miss and
 * are not occluded), equal counts returned, and the counters advance
 * alike. */
static void batch_sdk(rtk_conform_runner *r, const rtk_scene *s, const char *what, const char *label)
{
    enum { COUNT = 1500 };
    rtk_ray *rays = malloc(sizeof *rays * COUNT);
    rtk_hit *hits = malloc(sizeof *hits * COUNT);
    uint8_t *occluded = malloc(COUNT);
    char name[448];
    snprintf(name, sizeof name, "rtk_trace_batch and rtk_occluded_batch = rtk_trace and rtk_occluded: %s [%s]", what,
             label);
    if (!rays || !hits || !occluded) {
        rtk_conform_check(r, 0, name, "out of memory");
        free(rays), free(hits), free(occluded);
        return;
    }
    dvec lo, hi;
    batch_box(s, &lo, &hi);
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 3131u, 1u);
    batch_rays(s, lo, hi, &rng, rays, COUNT);
    uint64_t invalid = 0;
    for (uint32_t i = 2; i < COUNT; i += 5, invalid++) {
        switch (invalid % 6) {
        case 0: rays[i].org.y = NAN; break;
        case 1: rays[i].org.x = -INFINITY; break;
        case 2: rays[i].dir = rtk_vec3_make(0.0f, -0.0f, 0.0f); break;
        case 3: rays[i].dir.z = INFINITY; break;
        case 4: rays[i].tmin = 2.0f, rays[i].tmax = 1.0f; break;
        default: rays[i].tmax = NAN; break;
        }
    }
    uint32_t marked = camera_ray_pick(s, rays, COUNT);
    rtk_camera camera;
    memset(&camera, 0, sizeof camera);
    rtk_ctx batch, single;
    memset(&batch, 0, sizeof batch);
    batch.scene = s;
    batch.camera = &camera;
    batch.camera_ray = rays[marked < COUNT ? marked : COUNT / 3];
    single = batch;
    memset(hits, 0x5a, sizeof *hits * COUNT);
    memset(occluded, 0x5a, COUNT);
    uint64_t got = 0, blocked = 0, got1 = 0, blocked1 = 0;
    for (uint32_t i = 0, k = 0; i < COUNT; k++) {
        uint32_t n = batch_sizes[k % RTK_COUNTOF(batch_sizes)];
        n = n < COUNT - i ? n : COUNT - i;
        got += rtk_trace_batch(&batch, rays + i, n, hits + i);
        blocked += rtk_occluded_batch(&batch, rays + i, n, occluded + i);
        i += n;
    }
    tally tl = {0, 0, ""};
    for (uint32_t i = 0; i < COUNT; i++) {
        rtk_hit h;
        memset(&h, 0x5a, sizeof h);
        int hit = rtk_trace(&single, &rays[i], &h), any = rtk_occluded(&single, &rays[i]) != 0;
        int valid = i < 2 || (i - 2) % 5 != 0;
        got1 += (uint64_t)hit;
        blocked1 += (uint64_t)any;
        const rtk_hit *b = &hits[i];
        tl.rays++;
        if (hit || !valid ? memcmp(&h, b, sizeof h) != 0 : b->prim != RTK_INVALID_ID)
            tally_bad(&tl, &rays[i],
                      "ray %u (%s): batch prim %u inst %u t %a u %a v %a; single %s prim %u inst %u t %a u %a v %a", i,
                      valid ? "valid" : "invalid", b->prim, b->inst, b->t, b->u, b->v, hit ? "hit" : "miss", h.prim,
                      h.inst, h.t, h.u, h.v);
        else if (occluded[i] != any)
            tally_bad(&tl, &rays[i], "ray %u (%s): batch occluded %u, single %d", i, valid ? "valid" : "invalid",
                      occluded[i], any);
        else if (!valid && (hit || any || b->prim != RTK_INVALID_ID))
            tally_bad(&tl, &rays[i], "ray %u: invalid, yet hit", i);
    }
    if (tl.bad == 0 && (got != got1 || blocked != blocked1))
        tally_bad(&tl, &rays[0], "the batch calls returned %llu hits and %llu occluded, single rays %llu and %llu",
                  (unsigned long long)got, (unsigned long long)blocked, (unsigned long long)got1,
                  (unsigned long long)blocked1);
    if (tl.bad == 0 && (batch.rays != single.rays || batch.invalid_rays != single.invalid_rays ||
                        batch.invalid_rays != 2 * invalid))
        tally_bad(&tl, &rays[0], "counters: batches %llu rays, %llu invalid; single %llu, %llu; %llu invalid given",
                  (unsigned long long)batch.rays, (unsigned long long)batch.invalid_rays,
                  (unsigned long long)single.rays, (unsigned long long)single.invalid_rays,
                  (unsigned long long)(2 * invalid));
    snprintf(name, sizeof name,
             "rtk_trace_batch and rtk_occluded_batch = rtk_trace and rtk_occluded: %s, %d rays, %llu invalid, one "
             "camera ray%s (%llu hits, %llu occluded) [%s]",
             what, COUNT, (unsigned long long)invalid, marked < COUNT ? " through a single-sided back" : "",
             (unsigned long long)got, (unsigned long long)blocked, label);
    tally_check(r, &tl, name);
    free(rays), free(hits), free(occluded);
}

/* Quads stacked along z, with cut-out materials: a glTF BLEND coverage of
 * 1/2 (stochastic, decided per ray and triangle), a MASK below its cutoff
 * (all cut away), a single-sided one (camera rays pass its back) and an
 * opaque one; finished. NULL when out of memory. */
static rtk_scene *cutout_scene(void)
{
    rtk_scene *s = rtk_scene_new("conform cut-outs", 0);
    if (!s)
        return NULL;
    rtk_material m[4];
    for (int k = 0; k < 4; k++)
        m[k] = rtk_conform_diffuse(rtk_rgb_make(0.5f, 0.5f, 0.5f), 0.0f);
    m[0].alpha_mode = RTK_ALPHA_BLEND, m[0].coverage = 1, m[0].alpha = 0.5f;
    m[1].alpha_mode = RTK_ALPHA_MASK, m[1].alpha = 0.25f, m[1].alpha_cutoff = 0.5f;
    m[2].single_sided = 1;
    uint32_t id[4];
    for (int k = 0; k < 4; k++)
        if ((id[k] = rtk_conform_add_material(s, m[k])) == RTK_INVALID_ID) {
            rtk_scene_free(s);
            return NULL;
        }
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 77u, 5u);
    for (int i = 0; i < 64; i++) {
        float z = -1.0f + i / 32.0f, x = rtk_conform_frand(&rng, -1, 0), y = rtk_conform_frand(&rng, -1, 0);
        rtk_conform_add_quad(s, rtk_vec3_make(x, y, z), rtk_vec3_make(1, 0, 0.01f * (i % 3)), rtk_vec3_make(0, 1, 0),
                             id[i % 4], 1);
    }
    if (rtk_scene_finish(s) != RTK_OK) {
        rtk_scene_free(s);
        return NULL;
    }
    return s;
}

/* Batches against single rays on the conform meshes, a cut-out scene and
 * the instanced scene (the last two when the kernel traverses), through
 * the SDK with invalid rays, and on the closed icosphere at 1e5 (rays at
 * its vertices and edges, where rounding decides); with full, more rays
 * there, the icosphere at the origin and the surface scene. */
static void conform_batch(rtk_conform_runner *r, const rtk_plugin *p, const rtk_params *params, const char *label,
                          int full)
{
    int own = rtk_accelerator_traverses_itself(p), device = rtk_accelerator_is_device(p);
    char what[256];
    for (int which = 0; which < 6; which++) {
        const char *mesh_name = NULL;
        mesh m;
        m.s = make_mesh(which, &mesh_name);
        m.ok = m.s != NULL;
        snprintf(what, sizeof what, "batches on %s", mesh_name);
        if (mesh_build(r, &m, p, params, 2, what)) {
            dvec lo, hi;
            batch_box(m.s, &lo, &hi);
            batch_check(r, m.s, lo, hi, 3000, (uint64_t)which, mesh_name, label);
            if (which == 2)
                batch_sdk(r, m.s, mesh_name, label);
            rtk_device_report rep;
            if (device && m.s->triangle_count) {
                snprintf(what, sizeof what, "the device traced the batches on %s [%s]", mesh_name, label);
                int on_device = rtk_device_report_of(m.s, &rep);
                rtk_conform_check(r, on_device && rep.rays + rep.cpu_rays > 0, what,
                                  on_device ? "its report counts no rays" : "the scene has no device");
            }
        }
        rtk_scene_free(m.s);
    }
    if (device) {
        mesh m;
        m.s = cutout_scene();
        rtk_bvh_cache_use use;
        rtk_status st = m.s ? rtk_bvh_build_cached(m.s, p, params, 2, NULL, &use) : RTK_ERR_NOMEM;
        snprintf(what, sizeof what, "a scene with cut-outs is refused, naming the alternatives (device) [%s]", label);
        rtk_conform_check(r, st != RTK_OK && strstr(rtk_error_message(), "does not test"), what, "%s",
                          st == RTK_OK ? "built" : rtk_error_message());
        rtk_scene_free(m.s);
    } else if (!own) {
        mesh m;
        m.s = cutout_scene();
        m.ok = m.s != NULL;
        if (mesh_build(r, &m, p, params, 2, "batches on quads with cut-outs")) {
            dvec lo, hi;
            batch_box(m.s, &lo, &hi);
            batch_check(r, m.s, lo, hi, 3000, 6u, "64 quads with cut-outs (coverage, mask, single-sided)", label);
            batch_sdk(r, m.s, "quads with cut-outs", label);
        }
        rtk_scene_free(m.s);
    }
    if (!own) {
        rtk_pcg32 rng;
        rtk_pcg32_seed(&rng, 60, 2);
        rtk_scene *s = instanced_scene(&rng);
        rtk_status st = s ? rtk_scene_finish(s) : RTK_ERR_NOMEM;
        rtk_bvh_cache_use use;
        if (st == RTK_OK)
            st = rtk_bvh_build_cached(s, p, params, 2, NULL, &use);
        if (st != RTK_OK) {
            rtk_conform_check(r, 0, "build the instanced scene for batches", "%s",
                              s ? rtk_error_message() : "out of memory");
        } else {
            batch_check(r, s, dv(-9, -9, -9), dv(9, 9, 9), 3000, 7u, "a mesh placed 60 times beside 40 triangles",
                        label);
            batch_sdk(r, s, "instanced scene", label);
            rtk_device_report rep;
            if (device) {
                snprintf(what, sizeof what, "the device traced the batches on the instanced scene [%s]", label);
                int on_device = rtk_device_report_of(s, &rep);
                rtk_conform_check(r, on_device && rep.rays + rep.cpu_rays > 0, what,
                                  on_device ? "its report counts no rays" : "the scene has no device");
            }
        }
        rtk_scene_free(s);
    } else {
        fprintf(r->out,
                "# batches [%s]: own traversal: no cut-out scene (it ignores alpha), no instanced scene (it refuses "
                "them)\n",
                label);
    }
    dvec *v = NULL, *iv = NULL;
    uint32_t *t = NULL, *it = NULL, nv = 0, nt = 0, inv = 0, int_ = 0;
    if (!icosphere(6, &v, &nv, &t, &nt) || !icosphere(3, &iv, &inv, &it, &int_)) {
        rtk_conform_check(r, 0, "batches on the icosphere", "out of memory");
        free(v), free(t), free(iv), free(it);
        return;
    }
    for (int place = full ? 0 : 1; place < 2; place++) {
        dvec centre = place ? dv(1e5, 1e5, 1e5) : dv(0, 0, 0);
        mesh m = mesh_new("conform icosphere");
        mesh_icosphere(&m, v, nv, t, nt, centre, 1.0);
        snprintf(what, sizeof what, "closed icosphere (%u triangles) at %s", nt,
                 place ? "(1e5, 1e5, 1e5)" : "the origin");
        if (mesh_build(r, &m, p, params, 2, what))
            batch_check(r, m.s, dadd(centre, dv(-1, -1, -1)), dadd(centre, dv(1, 1, 1)), full ? 20000 : 5000,
                        8u + (uint64_t)place, what, label);
        rtk_scene_free(m.s);
    }
    surface_scene sc;
    if (full && surface_scene_make(&sc, 1.0, dv(0, 0, 0), iv, inv, it, int_) &&
        mesh_build(r, &sc.m, p, params, 2, "batches on the surface scene")) {
        dvec lo, hi;
        batch_box(sc.m.s, &lo, &hi);
        batch_check(r, sc.m.s, lo, hi, 10000, 10u, "surface scene (closed room, sphere, block)", label);
    } else if (full && (!sc.m.ok || !sc.normal)) {
        rtk_conform_check(r, 0, "batches on the surface scene", "out of memory");
    }
    if (full)
        surface_scene_free(&sc);
    free(v), free(t), free(iv), free(it);
}

/* Whether device accelerator p starts here (with its defaults): if not,
 * a "skip" line says why and every check that traces is left out. */
static int device_present(rtk_conform_runner *r, const rtk_plugin *p)
{
    rtk_params *params = rtk_params_defaults(p);
    rtk_status st = params ? rtk_device_probe(p, params) : RTK_ERR_NOMEM;
    rtk_params_destroy(params);
    if (st == RTK_OK)
        return 1;
    fprintf(r->out, "skip  every check that traces: device accelerator '%s' cannot start on this machine: %s\n",
            p->name, params ? rtk_error_message() : "out of memory");
    r->skipped++;
    return 0;
}

void rtk_conform_accelerator(rtk_conform_runner *r, const rtk_plugin *p, const rtk_conform_options *o)
{
    uint32_t cases = o && o->cases ? o->cases : RTK_CONFORM_ALL;
    uint32_t ico = o && o->icosphere_rays ? o->icosphere_rays : 100000;
    uint32_t scale = o && o->ray_scale ? o->ray_scale : 1;
    uint32_t variants = o && o->defaults_only ? 1 : rtk_conform_variant_count(p);
    if (rtk_accelerator_is_device(p) && !device_present(r, p))
        return;
    for (uint32_t vi = 0; vi < variants; vi++) {
        char label[128], name[256];
        rtk_params *params = rtk_conform_param_variant(p, (int)vi, label, sizeof label);
        if (!params) {
            snprintf(name, sizeof name, "parameter set %u is accepted", vi);
            rtk_conform_check(r, 0, name, "%s", rtk_error_message());
            continue;
        }
        double t0 = rtk_now();
        const uint32_t each = RTK_CONFORM_BASIC | RTK_CONFORM_DEGENERATE | RTK_CONFORM_SIGNED_ZERO | RTK_CONFORM_REPEAT |
                              RTK_CONFORM_INSTANCES | RTK_CONFORM_BATCH;
        if (cases & RTK_CONFORM_BASIC)
            conform_basic(r, p, params, label);
        if (cases & RTK_CONFORM_DEGENERATE)
            conform_degenerate(r, p, params, label, vi == 0);
        if (cases & RTK_CONFORM_SIGNED_ZERO)
            conform_signed_zero(r, p, params, label, vi == 0);
        if (cases & RTK_CONFORM_REPEAT)
            conform_repeat(r, p, params, label, vi == 0);
        if (cases & RTK_CONFORM_INSTANCES)
            conform_instances(r, p, params, label);
        if (cases & RTK_CONFORM_BATCH)
            conform_batch(r, p, params, label, vi == 0);
        if (cases & each)
            fprintf(r->out, "# [%s] %.2f s\n", label, rtk_now() - t0);
        if (vi == 0) {
            static const struct {
                uint32_t bit;
                const char *name;
            } heavy[] = {{RTK_CONFORM_ICOSPHERE | RTK_CONFORM_INSIDE, "icosphere"},
                         {RTK_CONFORM_GRAZING, "grazing"},
                         {RTK_CONFORM_SURFACE, "surface"},
                         {RTK_CONFORM_FAR_BOX, "far box"},
                         {RTK_CONFORM_TINY, "tiny"},
                         {RTK_CONFORM_FANS, "fans"}};
            for (size_t h = 0; h < RTK_COUNTOF(heavy); h++) {
                if (!(cases & heavy[h].bit))
                    continue;
                t0 = rtk_now();
                switch (heavy[h].bit) {
                case RTK_CONFORM_GRAZING: conform_grazing(r, p, params, scale); break;
                case RTK_CONFORM_SURFACE: conform_surface(r, p, params, scale); break;
                case RTK_CONFORM_FAR_BOX: conform_far_box(r, p, params, scale); break;
                case RTK_CONFORM_TINY: conform_tiny(r, p, params, scale); break;
                case RTK_CONFORM_FANS: conform_fans(r, p, params, scale); break;
                default: conform_icosphere(r, p, params, cases, ico, scale); break;
                }
                fprintf(r->out, "# %s [defaults] %.2f s\n", heavy[h].name, rtk_now() - t0);
            }
        }
        rtk_params_destroy(params);
    }
}

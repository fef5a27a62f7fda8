/* The wide BVH's traversal (see bvh_wide.h) in plain C, SSE, AVX2 and
 * AVX-512, the SIMD paths compiled here with target attributes and chosen
 * at run time. The AVX2 and AVX-512 paths are one node loop,
 * bvh_wide_isa.inc, included once per target.
 *
 * Every path computes the same numbers: the box test (differences,
 * products by the reciprocal, NaN of 0 * inf dropped, far distances
 * widened by 1 + 2 gamma(3), tmax by rtk_cull_distance) is the same
 * sequence of operations on every path, and the triangle test is
 * rtk_intersect_triangle's arithmetic, operation for operation, on four
 * triangles at once, lanes that need double precision handed to it.
 * Nothing here may contract a * b + c into an FMA, which is why the AVX2
 * target does not include FMA (and the kernel is compiled with
 * -ffp-contract=off, which also holds for the AVX-512 target). */
#include "accel.h"
#include "slab.h"

#include <float.h>
#include <pthread.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#if RTK_HAVE_X86
#include <immintrin.h>
#endif

#define RTK_INLINE static inline __attribute__((always_inline))

/* Each node on the path from the root (depth 0 .. RTK_WIDE_MAX_DEPTH)
 * leaves at most RTK_WIDE - 1 entries on the stack. */
#define RTK_WIDE_STACK ((RTK_WIDE - 1) * (RTK_WIDE_MAX_DEPTH + 1) + 1)

/* ---- path selection ---- */

int rtk_simd_supported(rtk_simd_path path)
{
    switch (path) {
    case RTK_SIMD_BINARY:
    case RTK_SIMD_SCALAR:
        return 1;
#if RTK_HAVE_X86
    case RTK_SIMD_SSE:
        return 1; /* SSE2 is part of x86-64; nothing newer is used */
    case RTK_SIMD_AVX2:
        __builtin_cpu_init();
        return __builtin_cpu_supports("avx2") != 0;
    case RTK_SIMD_AVX512:
        __builtin_cpu_init();
        return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("avx512f") &&
               __builtin_cpu_supports("avx512vl");
#endif
    default:
        return 0;
    }
}

rtk_simd_path rtk_simd_best(void)
{
    if (rtk_simd_supported(RTK_SIMD_AVX512))
        return RTK_SIMD_AVX512;
    if (rtk_simd_supported(RTK_SIMD_AVX2))
        return RTK_SIMD_AVX2;
    if (rtk_simd_supported(RTK_SIMD_SSE))
        return RTK_SIMD_SSE;
    return RTK_SIMD_SCALAR;
}

const char *rtk_simd_name(rtk_simd_path path)
{
    static const char *const names[RTK_SIMD_PATHS] = {"binary", "scalar", "sse", "avx2", "avx512"};
    return (unsigned)path < RTK_SIMD_PATHS ? names[path] : "?";
}

rtk_simd_path rtk_simd_from_env(void)
{
    const char *e = getenv("RTK_SIMD");
    if (!e || !*e)
        return rtk_simd_best();
    for (int p = RTK_SIMD_BINARY; p < RTK_SIMD_PATHS; p++) {
        if (strcmp(e, rtk_simd_name((rtk_simd_path)p)) == 0) {
            if (rtk_simd_supported((rtk_simd_path)p))
                return (rtk_simd_path)p;
            rtk_warn_once("RTK_SIMD unsupported", "RTK_SIMD=%s: this CPU cannot run it; using %s", e,
                          rtk_simd_name(rtk_simd_best()));
            return rtk_simd_best();
        }
    }
    rtk_warn_once("RTK_SIMD unknown", "RTK_SIMD=%s is not one of binary, scalar, sse, avx2, avx512; using %s", e,
                  rtk_simd_name(rtk_simd_best()));
    return rtk_simd_best();
}

/* ---- per-ray constants ---- */

/* The box test's constants. The triangle test's (tri_ray) are made only
 * when a ray reaches its first leaf: most primary rays of a mesh that
 * fills part of the image miss the root's children and never do. */
typedef struct wide_ray {
    float org[3], ninv[4], ninv_far[4]; /* -1 / d and its widening; lane 3 unused */
    int near[3], far[3];   /* rows of rtk_wide_node.bounds: entry and exit plane per axis */
} wide_ray;

/* The exit distance is widened through the reciprocal: more roundings
 * than bvh.c's, still inside 1 + 2 gamma(3) (see the callers: only rays
 * with tmin >= 0 come here, so a negative exit distance is a box behind
 * the origin and needs no care). 1 / +-0 gives +-inf.
 *
 * The paths compute a slab distance as (o - b) * (-1 / d): negation is
 * exact and rounding symmetric, so this is (b - o) * (1 / d) bit for bit
 * (NaN where that is NaN; a 0 may change sign, and the box test treats
 * +0 and -0 alike), and the subtraction can take the node's bounds
 * straight from memory. */
RTK_INLINE void wide_prepare(const rtk_ray *r, wide_ray *p)
{
    const float d[3] = {r->dir.x, r->dir.y, r->dir.z};
    p->org[0] = r->org.x, p->org[1] = r->org.y, p->org[2] = r->org.z;
#if RTK_HAVE_X86
    /* The three reciprocals in one packed division, the widened ones in one
     * multiplication: the same IEEE results as one at a time, without three
     * trips through the divider per ray; the signs in one movemask. */
    const __m128 d4 = _mm_set_ps(1.0f, d[2], d[1], d[0]);
    const __m128 ninv = _mm_div_ps(_mm_set1_ps(-1.0f), d4);
    _mm_storeu_ps(p->ninv, ninv);
    _mm_storeu_ps(p->ninv_far, _mm_mul_ps(ninv, _mm_set1_ps(rtk_slab_slack)));
    const int neg = _mm_movemask_ps(d4);
#else
    int neg = 0;
    for (int k = 0; k < 3; k++) {
        p->ninv[k] = -1.0f / d[k];
        p->ninv_far[k] = p->ninv[k] * rtk_slab_slack;
        neg |= (signbit(d[k]) != 0) << k;
    }
#endif
    p->near[0] = neg & 1, p->near[1] = 2 + (neg >> 1 & 1), p->near[2] = 4 + (neg >> 2 & 1);
    p->far[0] = p->near[0] ^ 1, p->far[1] = p->near[1] ^ 1, p->far[2] = p->near[2] ^ 1;
}

/* The widened tmax of the box test (bvh.c's). */
RTK_INLINE float widen(float tmax)
{
    return rtk_cull_distance(tmax);
}

/* The node an inner reference names: its byte offset from the first
 * node, so that the node loop adds it to the base without a shift. */
RTK_INLINE const rtk_wide_node *wide_node_at(const rtk_wide_node *nodes, uint32_t ref)
{
    return (const rtk_wide_node *)(const void *)((const char *)nodes + ref);
}

/* A pending subtree and its entry distance. */
typedef struct stack_entry {
    uint32_t ref;
    float t;
} stack_entry;

/* Orders the hit children (mask over lanes, entry distances dist) nearest
 * last on the stack and returns the nearest. At least two bits set. */
RTK_INLINE uint32_t push_sorted(const rtk_wide_node *n, uint32_t mask, const float *dist, stack_entry *stack,
                                int *top)
{
    uint32_t i0 = (uint32_t)__builtin_ctz(mask);
    mask &= mask - 1;
    uint32_t i1 = (uint32_t)__builtin_ctz(mask);
    mask &= mask - 1;
    if (mask == 0) {
        if (dist[i1] < dist[i0]) {
            uint32_t tmp = i0;
            i0 = i1;
            i1 = tmp;
        }
        stack[*top].ref = n->child[i1];
        stack[*top].t = dist[i1];
        ++*top;
        return n->child[i0];
    }
    /* Three or more: insertion sort, farthest first. */
    stack_entry *base = stack + *top;
    int count = 0;
    uint32_t lanes[RTK_WIDE];
    lanes[0] = i0, lanes[1] = i1;
    int nl = 2;
    while (mask) {
        lanes[nl++] = (uint32_t)__builtin_ctz(mask);
        mask &= mask - 1;
    }
    for (int j = 0; j < nl; j++) {
        stack_entry e = {n->child[lanes[j]], dist[lanes[j]]};
        int k = count++;
        while (k > 0 && base[k - 1].t < e.t) {
            base[k] = base[k - 1];
            k--;
        }
        base[k] = e;
    }
    *top += count - 1;
    return base[count - 1].ref;
}

/* Occlusion needs no order: pushes all hit children but the first and
 * returns that one. Their distances are left unset: occlusion pops
 * without reading them. */
RTK_INLINE uint32_t push_unsorted(const rtk_wide_node *n, uint32_t mask, stack_entry *stack, int *top)
{
    uint32_t first = n->child[__builtin_ctz(mask)];
    for (mask &= mask - 1; mask; mask &= mask - 1)
        stack[(*top)++].ref = n->child[__builtin_ctz(mask)];
    return first;
}

/* The child to enter next among a node's hit children (mask, not 0):
 * the only one, or for occlusion the first (push_unsorted), for closest
 * hit the nearest (push_sorted); the others pushed. */
RTK_INLINE uint32_t push_children(const rtk_wide_node *n, uint32_t mask, const float *dist, int any,
                                  stack_entry *stack, int *top)
{
    if ((mask & (mask - 1)) == 0)
        return n->child[__builtin_ctz(mask)];
    return any ? push_unsorted(n, mask, stack, top) : push_sorted(n, mask, dist, stack, top);
}

/* Records a hit found at (t, u, v) on prim if it is closer, or as close
 * with a lower id. Returns 1 when the hit changed. */
RTK_INLINE int record_hit(rtk_hit *hit, float t, float u, float v, uint32_t prim)
{
    if (t < hit->t || (t == hit->t && prim < hit->prim)) {
        hit->t = t, hit->u = u, hit->v = v, hit->prim = prim;
        return 1;
    }
    return 0;
}

/* The hit before traversal, as rtk_bvh_closest reports a miss. */
RTK_INLINE void hit_reset(rtk_hit *hit, const rtk_ray *ray)
{
    hit->prim = RTK_INVALID_ID;
    hit->t = ray->tmax;
    hit->u = hit->v = 0.0f;
}

/* ---- plain C ---- */

/* Entry distance of child i, or +inf when missed; same arithmetic and
 * NaN handling as the SIMD paths. */
/* box_reduce_note: every path reduces the three slab distances and the ray
 * interval as max(max(y, z), max(x, tmin)) and likewise with min, a tree
 * of depth 2 (the sequential chain costs a latency step per node). max and
 * min return their second operand when either is NaN, so the NaN of
 * 0 * inf (origin on a slab plane of a +-0 direction component) never
 * survives: the result is always a real distance, at worst with a slab
 * dropped, which only lets more boxes through. The AVX paths' occlusion
 * reduces as integers instead, for the rays that can have no NaN
 * (box_int_note).
 *
 * _mm_max_ps / _mm_min_ps exactly: the second operand when either is NaN. */
RTK_INLINE float max_ps(float a, float b)
{
    return a > b ? a : b;
}
RTK_INLINE float min_ps(float a, float b)
{
    return a < b ? a : b;
}

/* box_int_note: the AVX paths' occlusion reduces the slab distances with
 * integer max and min of their bit patterns where no slab distance can be
 * NaN: for rays whose direction components are all at least FLT_MIN in
 * magnitude (and finite, as rtk_ray_valid has checked before any
 * traversal), -1 / d and its widening are finite and not 0, and the
 * bounds and origin are not NaN, so (o - b) * (-1 / d) is never NaN
 * (empty lanes' infinite bounds give infinities). Signed integer order
 * is float order on values with the sign bit clear, puts every value
 * with the sign bit set below them (-0 lowest, then increasing
 * magnitude) and +inf above every finite value. So:
 * - the entry, max(x, y, z, tmin) with tmin >= +0 (its -0 made +0), is
 *   the float maximum exactly: values with the sign bit set lose to
 *   tmin in both orders;
 * - the exit, min(x, y, z, tmax) with tmax >= +0, is the float minimum
 *   where every distance has the sign bit clear; where one has it set,
 *   both minima have it set (the integer one is the one nearest 0), and
 *   the entry (>= 0) is <= it only where it is -0 and the entry 0: a box
 *   the float test misses passes where one exit is -0 (an origin on the
 *   exit plane) and another negative, a box nothing in which is hit (more
 *   boxes pass, never fewer; tests/accel/wide counts the rays whose work
 *   changes).
 * Rays with a direction component below FLT_MIN in magnitude (or 0) take
 * the SSE path's float reductions instead. Integer max and min have a
 * shorter latency than float ones. */
RTK_INLINE int box_int_ok(const rtk_ray *r)
{
    return fabsf(r->dir.x) >= FLT_MIN && fabsf(r->dir.y) >= FLT_MIN && fabsf(r->dir.z) >= FLT_MIN;
}

RTK_INLINE int scalar_box(const rtk_wide_node *n, int i, const wide_ray *p, float tmin, float tmax_w, float *entry)
{
    float a[3], b[3];
    for (int k = 0; k < 3; k++) {
        a[k] = (p->org[k] - n->bounds[p->near[k]][i]) * p->ninv[k];
        b[k] = (p->org[k] - n->bounds[p->far[k]][i]) * p->ninv_far[k];
    }
    float t0 = max_ps(max_ps(a[1], a[2]), max_ps(a[0], tmin));
    float t1 = min_ps(min_ps(b[1], b[2]), min_ps(b[0], tmax_w));
    *entry = t0;
    return t0 <= t1;
}

RTK_INLINE int scalar_lane(const rtk_wide_tris *t, int lane, const rtk_ray *ray, float *tt, float *u, float *v)
{
    return rtk_intersect_triangle(ray, rtk_vec3_make(t->v[0][lane], t->v[1][lane], t->v[2][lane]),
                                  rtk_vec3_make(t->v[3][lane], t->v[4][lane], t->v[5][lane]),
                                  rtk_vec3_make(t->v[6][lane], t->v[7][lane], t->v[8][lane]), tt, u, v);
}

RTK_INLINE int scalar_traverse(const rtk_scene *s, const rtk_ray *ray_in, rtk_hit *hit, int any,
                               rtk_trace_work *work)
{
    const rtk_wide_bvh *w = s->wide;
    rtk_ray ray = *ray_in;
    if (!any)
        hit_reset(hit, ray_in);
    wide_ray p;
    wide_prepare(&ray, &p);
    float tmax_w = widen(ray.tmax);
    stack_entry stack[RTK_WIDE_STACK];
    int top = 0;
    uint32_t cur = 0;
    for (;;) {
        while (!(cur & RTK_WIDE_LEAF)) {
            const rtk_wide_node *n = wide_node_at(w->nodes, cur);
            if (work)
                work->nodes++;
            float dist[RTK_WIDE];
            uint32_t mask = 0;
            for (int i = 0; i < RTK_WIDE; i++)
                mask |= (uint32_t)scalar_box(n, i, &p, ray.tmin, tmax_w, &dist[i]) << i;
            if (mask == 0)
                goto pop;
            cur = push_children(n, mask, dist, any, stack, &top);
        }
        {
            const rtk_wide_tris *t = &w->tris[(cur & ~RTK_WIDE_LEAF) >> RTK_WIDE_LEAF_SHIFT];
            const rtk_wide_tris *end = t + (cur & (RTK_WIDE_LEAF_BLOCKS - 1)) + 1;
            for (; t < end; t++) {
                if (work)
                    for (int lane = 0; lane < RTK_WIDE_TRIS; lane++)
                        work->triangles += t->prim[lane] != RTK_INVALID_ID;
                for (int lane = 0; lane < RTK_WIDE_TRIS; lane++) {
                    if (t->prim[lane] == RTK_INVALID_ID)
                        continue;
                    float tt, u, v;
                    if (!scalar_lane(t, lane, &ray, &tt, &u, &v) ||
                        (s->has_cutouts && !rtk_alpha_opaque(s, &ray, t->prim[lane], u, v)))
                        continue;
                    if (any)
                        return 1;
                    if (record_hit(hit, tt, u, v, t->prim[lane])) {
                        ray.tmax = tt;
                        tmax_w = widen(tt);
                    }
                }
            }
        }
    pop:
        do {
            if (top == 0)
                return any ? 0 : hit->prim != RTK_INVALID_ID;
            --top;
        } while (!any && stack[top].t > tmax_w);
        cur = stack[top].ref;
    }
}

#if RTK_HAVE_X86

/* ---- four triangles at once (SSE2; VEX-encoded inside the AVX2 path) ---- */

/* Ray constants of the triangle test, broadcast. */
typedef struct tri_ray {
    __m128 ox, oy, oz; /* origin components kx, ky, kz */
    __m128 sx, sy, sz;
    size_t rx, ry, rz; /* byte offsets of rows kx, ky, kz in rtk_wide_tris.v */
} tri_ray;

/* rtk_intersect_triangle's shear constants (axes from rtk_shear_axes):
 * d[kx] / d[kz], d[ky] / d[kz] and 1 / d[kz] in one packed division. */
RTK_INLINE void tri_prepare(const rtk_ray *ray, tri_ray *r)
{
    const float d[3] = {ray->dir.x, ray->dir.y, ray->dir.z};
    const float o[3] = {ray->org.x, ray->org.y, ray->org.z};
    int kx, ky, kz;
    rtk_shear_axes(d, &kx, &ky, &kz);
    float dz = d[kz];
    r->rx = (size_t)kx * sizeof(float[RTK_WIDE_TRIS]), r->ry = (size_t)ky * sizeof(float[RTK_WIDE_TRIS]),
    r->rz = (size_t)kz * sizeof(float[RTK_WIDE_TRIS]);
    const __m128 q = _mm_div_ps(_mm_set_ps(1.0f, 1.0f, d[ky], d[kx]), _mm_set1_ps(dz));
    r->sx = _mm_shuffle_ps(q, q, 0x00);
    r->sy = _mm_shuffle_ps(q, q, 0x55);
    r->sz = _mm_shuffle_ps(q, q, 0xaa);
    r->ox = _mm_set1_ps(o[kx]);
    r->oy = _mm_set1_ps(o[ky]);
    r->oz = _mm_set1_ps(o[kz]);
}

/* The constants of tri_test4's error bound (see there). */
#define TRI_K0 (12.0f * (3.0f * 0.5f * FLT_EPSILON / (1.0f - 3.0f * 0.5f * FLT_EPSILON)) * (1.0f + 1.0f / 1048576.0f))
#define TRI_G25                                                                                                 \
    ((2.0f * 0.5f * FLT_EPSILON / (1.0f - 2.0f * 0.5f * FLT_EPSILON)) +                                         \
     2.0f * (5.0f * 0.5f * FLT_EPSILON / (1.0f - 5.0f * 0.5f * FLT_EPSILON)))
#define TRI_G5 (5.0f * 0.5f * FLT_EPSILON / (1.0f - 5.0f * 0.5f * FLT_EPSILON))

/* Lanes of block b hit within [tmin, tmax] (bit mask), with t, u, v; the
 * arithmetic is rtk_intersect_triangle's, lane by lane. Lanes the scalar
 * test decides in double (on an edge in float, or a hit too near the
 * origin for float) are left to it: *scalar receives them. flat (a
 * constant) takes the lanes near the origin through the range check
 * without a branch: where rays leave a surface, the first block of a
 * leaf often holds the triangle left behind, and whether its t is within
 * the float bound of 0 is a coin toss for the branch predictor. */
RTK_INLINE int tri_test4(const rtk_wide_tris *b, const tri_ray *r, float tmin, float tmax, __m128 *t_out,
                         __m128 *u_out, __m128 *v_out, int *scalar, int flat)
{
    const __m128 zero = _mm_setzero_ps();
    /* Row k of corner c: v[3 c + k]. */
    const char *base = (const char *)b->v;
    const size_t corner = 3 * sizeof(float[RTK_WIDE_TRIS]);
#define RTK_ROW(c, off) _mm_loadu_ps((const float *)(base + (c) * corner + (off)))
    __m128 Az = _mm_sub_ps(RTK_ROW(0, r->rz), r->oz);
    __m128 Bz = _mm_sub_ps(RTK_ROW(1, r->rz), r->oz);
    __m128 Cz = _mm_sub_ps(RTK_ROW(2, r->rz), r->oz);
    __m128 ax = _mm_sub_ps(_mm_sub_ps(RTK_ROW(0, r->rx), r->ox), _mm_mul_ps(r->sx, Az));
    __m128 ay = _mm_sub_ps(_mm_sub_ps(RTK_ROW(0, r->ry), r->oy), _mm_mul_ps(r->sy, Az));
    __m128 bx = _mm_sub_ps(_mm_sub_ps(RTK_ROW(1, r->rx), r->ox), _mm_mul_ps(r->sx, Bz));
    __m128 by = _mm_sub_ps(_mm_sub_ps(RTK_ROW(1, r->ry), r->oy), _mm_mul_ps(r->sy, Bz));
    __m128 cx = _mm_sub_ps(_mm_sub_ps(RTK_ROW(2, r->rx), r->ox), _mm_mul_ps(r->sx, Cz));
    __m128 cy = _mm_sub_ps(_mm_sub_ps(RTK_ROW(2, r->ry), r->oy), _mm_mul_ps(r->sy, Cz));
#undef RTK_ROW
    __m128 U = _mm_sub_ps(_mm_mul_ps(cx, by), _mm_mul_ps(cy, bx));
    __m128 V = _mm_sub_ps(_mm_mul_ps(ax, cy), _mm_mul_ps(ay, cx));
    __m128 W = _mm_sub_ps(_mm_mul_ps(bx, ay), _mm_mul_ps(by, ax));
    __m128 onedge = _mm_or_ps(_mm_or_ps(_mm_cmpeq_ps(U, zero), _mm_cmpeq_ps(V, zero)), _mm_cmpeq_ps(W, zero));
    /* Signs mixed: the least below 0 and the greatest above. Where none
     * is 0 (onedge) or NaN (det, below), that is the least's sign bit set
     * and the greatest's clear: the sign bit of lo & ~hi. */
    __m128 lo = _mm_min_ps(_mm_min_ps(U, V), W), hi = _mm_max_ps(_mm_max_ps(U, V), W);
    __m128 mixed = _mm_andnot_ps(hi, lo);
    __m128 det = _mm_add_ps(_mm_add_ps(U, V), W);
    /* det is NaN in unused lanes (and wherever U, V or W is: min and max
     * may pass a NaN over, the sum does not). U, V, W of one strict sign
     * cannot sum to 0, so det == 0 needs no test of its own. */
    __m128 miss = _mm_or_ps(_mm_or_ps(mixed, onedge), _mm_cmpunord_ps(det, det)); /* sign bits */
    *scalar = _mm_movemask_ps(onedge);
    if (_mm_movemask_ps(miss) == 0xf)
        return 0;
    __m128 az = _mm_mul_ps(r->sz, Az), bz = _mm_mul_ps(r->sz, Bz), cz = _mm_mul_ps(r->sz, Cz);
    __m128 T = _mm_add_ps(_mm_add_ps(_mm_mul_ps(U, az), _mm_mul_ps(V, bz)), _mm_mul_ps(W, cz));
    __m128 rcp = _mm_div_ps(_mm_set1_ps(1.0f), det);
    __m128 t = _mm_mul_ps(T, rcp);
    int cand = ~_mm_movemask_ps(miss) & 0xf;
    /* bvh.c's bound on the error of t (pbrt-v4), 3 (g3 mE mZ + dE mZ +
     * dZ mE) |rcp| with dZ = g3 mZ, dE = 2 ((g2 + 2 g5) mX mY + g5 mZ (mX +
     * mY)) (mX the largest |ax|, |bx|, |cx|, and so on), taken twice (6 for
     * 3) to cover its rounding and this one's: where it may exceed
     * RTK_T_TOLERANCE * t, the scalar test decides in double. mE, the
     * largest of |U|, |V|, |W|, is not computed: they share a sign, so
     * mE <= |det| and mE |rcp| <= 1 + 2^-24, and
     * 6 |rcp| (2 g3 mE mZ + dE mZ) <= mZ (12 g3 (1 + 2^-20) + 12 |rcp| dE / 2). */
    const __m128 k0 = _mm_set1_ps(TRI_K0), g25 = _mm_set1_ps(TRI_G25), g5 = _mm_set1_ps(TRI_G5);
    const __m128 abs_mask = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
#define RTK_ABS(x) _mm_and_ps(x, abs_mask)
#define RTK_MAX3(a, b, c) _mm_max_ps(RTK_ABS(a), _mm_max_ps(RTK_ABS(b), RTK_ABS(c)))
    __m128 max_z = RTK_MAX3(az, bz, cz), max_x = RTK_MAX3(ax, bx, cx), max_y = RTK_MAX3(ay, by, cy);
#undef RTK_MAX3
    __m128 de_half = _mm_add_ps(_mm_mul_ps(g25, _mm_mul_ps(max_x, max_y)),
                                _mm_mul_ps(_mm_mul_ps(g5, max_z), _mm_add_ps(max_x, max_y)));
    __m128 rcp12 = _mm_mul_ps(_mm_set1_ps(12.0f), RTK_ABS(rcp));
    __m128 bound = _mm_mul_ps(max_z, _mm_add_ps(k0, _mm_mul_ps(de_half, rcp12)));
    __m128 allowed = _mm_mul_ps(_mm_set1_ps(RTK_T_TOLERANCE), RTK_ABS(t));
#undef RTK_ABS
    int near = _mm_movemask_ps(_mm_cmpnlt_ps(bound, allowed)) & cand;
    const __m128 tmin4 = _mm_set1_ps(tmin), tmax4 = _mm_set1_ps(tmax);
    if (flat || near) {
        /* Those the scalar test rejects before its double: outside the
         * range by twice the bound (itself twice the scalar one). */
        __m128 err2 = _mm_add_ps(bound, bound);
        __m128 out = _mm_or_ps(_mm_cmplt_ps(_mm_add_ps(t, err2), tmin4), _mm_cmpgt_ps(_mm_sub_ps(t, err2), tmax4));
        *scalar |= near & ~_mm_movemask_ps(out);
    }
    __m128 inside = _mm_and_ps(_mm_cmpge_ps(t, tmin4), _mm_cmple_ps(t, tmax4));
    int mask = _mm_movemask_ps(inside) & cand & ~near;
    if (!mask)
        return 0;
    *t_out = t;
    *u_out = _mm_mul_ps(V, rcp);
    *v_out = _mm_mul_ps(W, rcp);
    return mask;
}

/* The scalar test on one lane, with the ray's tmax set to tmax. */
RTK_INLINE int lane_scalar(const rtk_wide_tris *b, int lane, const rtk_ray *ray, float tmax, float *t, float *u,
                           float *v)
{
    rtk_ray r = *ray;
    r.tmax = tmax;
    return scalar_lane(b, lane, &r, t, u, v);
}

RTK_INLINE const rtk_wide_tris *leaf_blocks(const rtk_wide_bvh *w, uint32_t ref, const rtk_wide_tris **end)
{
    const rtk_wide_tris *b = &w->tris[(ref & ~RTK_WIDE_LEAF) >> RTK_WIDE_LEAF_SHIFT];
    *end = b + (ref & (RTK_WIDE_LEAF_BLOCKS - 1)) + 1;
    return b;
}

/* Counts a block's triangles into work. */
RTK_INLINE void count_block(const rtk_wide_tris *b, rtk_trace_work *work)
{
    if (work) {
        __m128i invalid = _mm_cmpeq_epi32(_mm_loadu_si128((const __m128i *)b->prim), _mm_set1_epi32(-1));
        work->triangles += 4 - (uint32_t)__builtin_popcount((unsigned)_mm_movemask_ps(_mm_castsi128_ps(invalid)));
    }
}

/* Tests blocks [b, end); for closest hit updates hit and returns 1 when
 * it changed, for any hit returns 1 on the first hit. Hits on cutout
 * triangles count only where their alpha is opaque. */
RTK_INLINE int blocks_test(const rtk_scene *s, const rtk_wide_tris *b, const rtk_wide_tris *end, const tri_ray *r,
                           const rtk_ray *ray, rtk_hit *hit, int any, rtk_trace_work *work)
{
    int changed = 0;
    for (; b < end; b++) {
        count_block(b, work);
        __m128 t, u, v;
        int scalar;
        int mask = tri_test4(b, r, ray->tmin, any ? ray->tmax : hit->t, &t, &u, &v, &scalar, 0);
        if (any && mask && !s->has_cutouts)
            return 1;
        if (mask) {
            float ft[4], fu[4], fv[4];
            _mm_storeu_ps(ft, t), _mm_storeu_ps(fu, u), _mm_storeu_ps(fv, v);
            for (; mask; mask &= mask - 1) {
                int i = __builtin_ctz((unsigned)mask);
                if (s->has_cutouts && !rtk_alpha_opaque(s, ray, b->prim[i], fu[i], fv[i]))
                    continue;
                if (any)
                    return 1;
                changed |= record_hit(hit, ft[i], fu[i], fv[i], b->prim[i]);
            }
        }
        for (; scalar; scalar &= scalar - 1) {
            int i = __builtin_ctz((unsigned)scalar);
            float st, su, sv;
            if (!lane_scalar(b, i, ray, any ? ray->tmax : hit->t, &st, &su, &sv) ||
                (s->has_cutouts && !rtk_alpha_opaque(s, ray, b->prim[i], su, sv)))
                continue;
            if (any)
                return 1;
            changed |= record_hit(hit, st, su, sv, b->prim[i]);
        }
    }
    return changed;
}

/* Tests a leaf's blocks (blocks_test). */
RTK_INLINE int leaf_test(const rtk_scene *s, const rtk_wide_bvh *w, uint32_t ref, const tri_ray *r,
                         const rtk_ray *ray, rtk_hit *hit, int any, rtk_trace_work *work)
{
    const rtk_wide_tris *end;
    const rtk_wide_tris *b = leaf_blocks(w, ref, &end);
    return blocks_test(s, b, end, r, ray, hit, any, work);
}

/* ---- SSE: the eight children as two groups of four ---- */

RTK_INLINE __m128 sse_box4(const rtk_wide_node *n, int half, const wide_ray *p, __m128 ox, __m128 oy, __m128 oz,
                           __m128 ix, __m128 iy, __m128 iz, __m128 fx, __m128 fy, __m128 fz, __m128 tmin4,
                           __m128 tmax4, int *mask)
{
    const int o = 4 * half;
    __m128 nx = _mm_mul_ps(_mm_sub_ps(ox, _mm_load_ps(&n->bounds[p->near[0]][o])), ix);
    __m128 ny = _mm_mul_ps(_mm_sub_ps(oy, _mm_load_ps(&n->bounds[p->near[1]][o])), iy);
    __m128 nz = _mm_mul_ps(_mm_sub_ps(oz, _mm_load_ps(&n->bounds[p->near[2]][o])), iz);
    __m128 gx = _mm_mul_ps(_mm_sub_ps(ox, _mm_load_ps(&n->bounds[p->far[0]][o])), fx);
    __m128 gy = _mm_mul_ps(_mm_sub_ps(oy, _mm_load_ps(&n->bounds[p->far[1]][o])), fy);
    __m128 gz = _mm_mul_ps(_mm_sub_ps(oz, _mm_load_ps(&n->bounds[p->far[2]][o])), fz);
    /* See box_reduce_note. */
    __m128 t0 = _mm_max_ps(_mm_max_ps(ny, nz), _mm_max_ps(nx, tmin4));
    __m128 t1 = _mm_min_ps(_mm_min_ps(gy, gz), _mm_min_ps(gx, tmax4));
    *mask = _mm_movemask_ps(_mm_cmple_ps(t0, t1));
    return t0;
}

RTK_INLINE int sse_traverse(const rtk_scene *s, const rtk_ray *ray, rtk_hit *hit, int any, rtk_trace_work *work)
{
    const rtk_wide_bvh *w = s->wide;
    if (!any)
        hit_reset(hit, ray);
    wide_ray p;
    wide_prepare(ray, &p);
    tri_ray tr;
    int tri_ready = 0;
    const __m128 ox = _mm_set1_ps(p.org[0]), oy = _mm_set1_ps(p.org[1]), oz = _mm_set1_ps(p.org[2]);
    const __m128 ix = _mm_set1_ps(p.ninv[0]), iy = _mm_set1_ps(p.ninv[1]), iz = _mm_set1_ps(p.ninv[2]);
    const __m128 fx = _mm_set1_ps(p.ninv_far[0]), fy = _mm_set1_ps(p.ninv_far[1]), fz = _mm_set1_ps(p.ninv_far[2]);
    const __m128 tmin4 = _mm_set1_ps(ray->tmin);
    float tmax_w = widen(any ? ray->tmax : hit->t);
    __m128 tmax4 = _mm_set1_ps(tmax_w);
    stack_entry stack[RTK_WIDE_STACK];
    int top = 0;
    uint32_t cur = 0;
    for (;;) {
        while (!(cur & RTK_WIDE_LEAF)) {
            const rtk_wide_node *n = wide_node_at(w->nodes, cur);
            if (work)
                work->nodes++;
            int m0, m1;
            float dist[RTK_WIDE];
            _mm_storeu_ps(dist, sse_box4(n, 0, &p, ox, oy, oz, ix, iy, iz, fx, fy, fz, tmin4, tmax4, &m0));
            _mm_storeu_ps(dist + 4, sse_box4(n, 1, &p, ox, oy, oz, ix, iy, iz, fx, fy, fz, tmin4, tmax4, &m1));
            uint32_t mask = (uint32_t)(m0 | m1 << 4);
            if (mask == 0)
                goto pop;
            cur = push_children(n, mask, dist, any, stack, &top);
        }
        if (!tri_ready) {
            tri_prepare(ray, &tr);
            tri_ready = 1;
        }
        if (leaf_test(s, w, cur, &tr, ray, hit, any, work)) {
            if (any)
                return 1;
            tmax_w = widen(hit->t);
            tmax4 = _mm_set1_ps(tmax_w);
        }
    pop:
        do {
            if (top == 0)
                return any ? 0 : hit->prim != RTK_INVALID_ID;
            --top;
        } while (!any && stack[top].t > tmax_w);
        cur = stack[top].ref;
    }
}

static int sse_closest(const rtk_scene *s, const rtk_ray *r, rtk_hit *h)
{
    return sse_traverse(s, r, h, 0, NULL);
}
static int sse_any(const rtk_scene *s, const rtk_ray *r)
{
    return sse_traverse(s, r, NULL, 1, NULL);
}
static int sse_closest_work(const rtk_scene *s, const rtk_ray *r, rtk_hit *h, rtk_trace_work *wk)
{
    return sse_traverse(s, r, h, 0, wk);
}
static int sse_any_work(const rtk_scene *s, const rtk_ray *r, rtk_trace_work *wk)
{
    return sse_traverse(s, r, NULL, 1, wk);
}
/* ---- AVX2 and AVX-512: the eight children at once ---- */

/* Occlusion pushes a node's hit children without a branch on how many
 * were hit: for each 8-bit hit mask, the lanes of its set bits but the
 * lowest, in order, 3 bits each from bit 0. One permutation packs those
 * children, one store pushes them (all eight lanes; the stack has room),
 * and the lowest hit child is traversed next: a branch on the number of
 * hits would be mispredicted on random AO directions.
 * The table is made by the compiler: the j-th set bit of r, at lane l,
 * contributes l << 3 j, j being the number of r's set bits below l. */
#define PACK_BIT(r, l) (((r) >> (l)) & 1u)
#define PACK_BELOW(r, l) ((uint32_t)__builtin_popcount((r) & ((1u << (l)) - 1u)))
#define PACK_LANE(r, l) (PACK_BIT(r, l) * ((uint32_t)(l) << (3u * PACK_BELOW(r, l))))
#define PACK_REST(r)                                                                                              \
    (PACK_LANE(r, 1) + PACK_LANE(r, 2) + PACK_LANE(r, 3) + PACK_LANE(r, 4) + PACK_LANE(r, 5) + PACK_LANE(r, 6) + \
     PACK_LANE(r, 7))
#define PACK_1(m) PACK_REST((m) & ((m) - 1u))
#define PACK_2(m) PACK_1(m), PACK_1((m) + 1u)
#define PACK_8(m) PACK_2(m), PACK_2((m) + 2u), PACK_2((m) + 4u), PACK_2((m) + 6u)
#define PACK_32(m) PACK_8(m), PACK_8((m) + 8u), PACK_8((m) + 16u), PACK_8((m) + 24u)
static const uint32_t pack_lanes[256] = {PACK_32(0u), PACK_32(32u), PACK_32(64u), PACK_32(96u),
                                         PACK_32(128u), PACK_32(160u), PACK_32(192u), PACK_32(224u)};
#undef PACK_32
#undef PACK_8
#undef PACK_2
#undef PACK_1
#undef PACK_REST
#undef PACK_LANE
#undef PACK_BELOW
#undef PACK_BIT

#define RTK_ALIGN32 __attribute__((aligned(32)))

/* Lane l's bit in every lane: origin groups on AVX2 gather a lane's
 * entered children into per-child lane masks with it. */
static const RTK_ALIGN32 uint32_t lane_bits[RTK_WIDE][RTK_WIDE] = {
    {1, 1, 1, 1, 1, 1, 1, 1},         {2, 2, 2, 2, 2, 2, 2, 2},         {4, 4, 4, 4, 4, 4, 4, 4},
    {8, 8, 8, 8, 8, 8, 8, 8},         {16, 16, 16, 16, 16, 16, 16, 16}, {32, 32, 32, 32, 32, 32, 32, 32},
    {64, 64, 64, 64, 64, 64, 64, 64}, {128, 128, 128, 128, 128, 128, 128, 128}};

/* A frustum packet's constants (packet_setup): each lane's single-ray box
 * constants, and per axis the intervals of origins, reciprocals and
 * widened reciprocals over the lanes, with the rows of the shared
 * octant. */
typedef struct wide_packet {
    RTK_ALIGN32 float ox[RTK_WIDE];
    RTK_ALIGN32 float oy[RTK_WIDE];
    RTK_ALIGN32 float oz[RTK_WIDE];
    RTK_ALIGN32 float ix[RTK_WIDE];
    RTK_ALIGN32 float iy[RTK_WIDE];
    RTK_ALIGN32 float iz[RTK_WIDE];
    RTK_ALIGN32 float fx[RTK_WIDE];
    RTK_ALIGN32 float fy[RTK_WIDE];
    RTK_ALIGN32 float fz[RTK_WIDE];
    RTK_ALIGN32 float tmin[RTK_WIDE];
    float olo[3], ohi[3], ilo[3], ihi[3], flo[3], fhi[3];
    float tmin_all, tmax_all; /* least tmin, greatest widened tmax */
    size_t nx, ny, nz;        /* entry rows times RTK_WIDE */
    uint32_t count;
} wide_packet;

/* A pending subtree of a packet: entry distance of the frustum, and the
 * lanes that enter it (all live lanes for an inner node). */
typedef struct packet_entry {
    uint32_t ref;
    float t;
    uint32_t lanes;
} packet_entry;

/* An origin group's constants (group_any): per ray (lane), the box
 * test's reciprocals and interval, the triangle test's shear, and the
 * shared origin. */
typedef struct wide_group {
    RTK_ALIGN32 float ninv[3][RTK_WIDE]; /* wide_ray's -1 / d and its widening */
    RTK_ALIGN32 float ninv_far[3][RTK_WIDE];
    RTK_ALIGN32 int32_t kx[RTK_WIDE]; /* shear axes */
    RTK_ALIGN32 int32_t ky[RTK_WIDE];
    RTK_ALIGN32 int32_t kz[RTK_WIDE];
    RTK_ALIGN32 float sx[RTK_WIDE]; /* d[kx] / d[kz], d[ky] / d[kz], 1 / d[kz] */
    RTK_ALIGN32 float sy[RTK_WIDE];
    RTK_ALIGN32 float sz[RTK_WIDE];
    RTK_ALIGN32 float tmin[RTK_WIDE]; /* + 0 (box_int_note) */
    RTK_ALIGN32 float tmax[RTK_WIDE];
    float org[3];
} wide_group;

/* The box constants wide_prepare makes for ray, lane l of origin group
 * g, from the group's own (the same divisions, lane by lane). */
RTK_INLINE void group_lane_box(const wide_group *g, const rtk_ray *ray, int l, wide_ray *p)
{
    const float d[3] = {ray->dir.x, ray->dir.y, ray->dir.z};
    for (int k = 0; k < 3; k++) {
        p->org[k] = g->org[k];
        p->ninv[k] = g->ninv[k][l];
        p->ninv_far[k] = g->ninv_far[k][l];
        p->near[k] = 2 * k + (signbit(d[k]) != 0);
        p->far[k] = p->near[k] ^ 1;
    }
    p->ninv[3] = p->ninv_far[3] = 0.0f; /* unused */
}

/* The triangle constants tri_prepare makes for lane l of origin group g,
 * from the group's own. */
RTK_INLINE void group_lane_tri(const wide_group *g, int l, tri_ray *t)
{
    const int kx = g->kx[l], ky = g->ky[l], kz = g->kz[l];
    t->rx = (size_t)kx * sizeof(float[RTK_WIDE_TRIS]), t->ry = (size_t)ky * sizeof(float[RTK_WIDE_TRIS]),
    t->rz = (size_t)kz * sizeof(float[RTK_WIDE_TRIS]);
    t->sx = _mm_set1_ps(g->sx[l]), t->sy = _mm_set1_ps(g->sy[l]), t->sz = _mm_set1_ps(g->sz[l]);
    t->ox = _mm_set1_ps(g->org[kx]), t->oy = _mm_set1_ps(g->org[ky]), t->oz = _mm_set1_ps(g->org[kz]);
}

/* A ray of an occlusion stream: its single-ray box constants (the
 * node loop's, for rays where box_int_ok holds). */
typedef struct stream_ray {
    float org[3], ninv[3], ninv_far[3];
    float tmin, tmaxw;         /* tmin + 0 and the widened tmax */
    uint32_t nx, ny, nz, pad;  /* entry rows times RTK_WIDE */
} stream_ray;

/* Rays per stream, and room for the lists of rays of the pending
 * subtrees: a node's children's lists are at most eight times its own. */
#define STREAM_MAX 1024u
#define STREAM_ARENA (16u * STREAM_MAX)

/* A pending subtree of a stream and its rays: ids[start .. start + count). */
typedef struct stream_entry {
    uint32_t ref, start, count;
} stream_entry;

/* A thread's stream state, made on its first stream. */
typedef struct stream_buf {
    stream_ray ray[STREAM_MAX];
    tri_ray tri[STREAM_MAX];                  /* made at a ray's first leaf */
    uint32_t which[STREAM_MAX];               /* the stream's rays in the batch */
    uint32_t ids[STREAM_ARENA + 8];           /* the pending subtrees' rays */
    uint32_t child[RTK_WIDE][STREAM_MAX + 8]; /* a node's children's rays */
    stream_entry stack[RTK_WIDE_STACK];
    uint8_t mask[STREAM_MAX + 8];             /* the children each of a node's rays enters */
    uint8_t dead[STREAM_MAX];                 /* occluded */
    uint8_t tri_ready[STREAM_MAX];
} stream_buf;

static pthread_key_t stream_key;
static int stream_key_ok;
static pthread_once_t stream_once = PTHREAD_ONCE_INIT;

static void stream_key_make(void)
{
    stream_key_ok = pthread_key_create(&stream_key, free) == 0;
}

/* This thread's stream state, or NULL where none can be had (the caller
 * then traces one ray at a time). */
static stream_buf *stream_state(void)
{
    pthread_once(&stream_once, stream_key_make);
    if (!stream_key_ok)
        return NULL;
    stream_buf *b = pthread_getspecific(stream_key);
    if (!b) {
        b = aligned_alloc(64, (sizeof *b + 63) / 64 * 64);
        if (b && pthread_setspecific(stream_key, b) != 0) {
            free(b);
            b = NULL;
        }
    }
    return b;
}

/* rtk_wide_packet_rays' count. */
static __thread uint64_t packet_rays;

uint64_t rtk_wide_packet_rays(void)
{
    return packet_rays;
}

/* Fewest rays traced as a packet: below, one at a time is cheaper. */
#define PACKET_MIN 3u
/* Fewest occlusion rays of a batch worth a stream. */
#define STREAM_MIN 16u
/* A stream's, a packet's or an origin group's subtree entered by this
 * many rays or fewer is traced by each ray's own traversal from there. */
#define HANDOFF_RAYS 2u

/* The node loop of bvh_wide_isa.inc, once per target: RTK_AVX names
 * a function of the pass, RTK_AVX512 selects the two places where the
 * passes differ (the hit mask straight from the compare into a mask
 * register, and occlusion's push by one compress instead of the table
 * above). AVX-512VL on 256-bit vectors also gives the loop 32 vector
 * registers: its box test reads no broadcast of the ray from the stack
 * (the AVX2 loop's, eight). */
#define RTK_AVX512 0
#define RTK_AVX(name) avx2_##name
#define RTK_TARGET_AVX __attribute__((target("avx2")))
#include "bvh_wide_isa.inc"
#undef RTK_TARGET_AVX
#undef RTK_AVX
#undef RTK_AVX512
#define RTK_AVX512 1
#define RTK_AVX(name) avx512_##name
#define RTK_TARGET_AVX __attribute__((target("avx2,avx512f,avx512vl")))
#include "bvh_wide_isa.inc"
#undef RTK_TARGET_AVX
#undef RTK_AVX
#undef RTK_AVX512

#endif

static int scalar_closest(const rtk_scene *s, const rtk_ray *r, rtk_hit *h, rtk_trace_work *wk)
{
    return scalar_traverse(s, r, h, 0, wk);
}
static int scalar_any(const rtk_scene *s, const rtk_ray *r, rtk_trace_work *wk)
{
    return scalar_traverse(s, r, NULL, 1, wk);
}

static int scalar_closest_fast(const rtk_scene *s, const rtk_ray *r, rtk_hit *h)
{
    return scalar_traverse(s, r, h, 0, NULL);
}
static int scalar_any_fast(const rtk_scene *s, const rtk_ray *r)
{
    return scalar_traverse(s, r, NULL, 1, NULL);
}

rtk_wide_closest_fn const rtk_wide_closest_path[RTK_SIMD_PATHS] = {
    [RTK_SIMD_SCALAR] = scalar_closest_fast,
#if RTK_HAVE_X86
    [RTK_SIMD_SSE] = sse_closest,
    [RTK_SIMD_AVX2] = avx2_closest,
    [RTK_SIMD_AVX512] = avx512_closest,
#endif
};
rtk_wide_any_fn const rtk_wide_any_path[RTK_SIMD_PATHS] = {
    [RTK_SIMD_SCALAR] = scalar_any_fast,
#if RTK_HAVE_X86
    [RTK_SIMD_SSE] = sse_any,
    [RTK_SIMD_AVX2] = avx2_any,
    [RTK_SIMD_AVX512] = avx512_any,
#endif
};

int rtk_wide_closest(const rtk_scene *s, rtk_simd_path path, const rtk_ray *ray, rtk_hit *hit, rtk_trace_work *work)
{
    switch (path) {
#if RTK_HAVE_X86
    case RTK_SIMD_AVX512:
        return work ? avx512_closest_work(s, ray, hit, work) : avx512_closest(s, ray, hit);
    case RTK_SIMD_AVX2:
        return work ? avx2_closest_work(s, ray, hit, work) : avx2_closest(s, ray, hit);
    case RTK_SIMD_SSE:
        return work ? sse_closest_work(s, ray, hit, work) : sse_closest(s, ray, hit);
#endif
    default:
        return scalar_closest(s, ray, hit, work);
    }
}

int rtk_wide_any(const rtk_scene *s, rtk_simd_path path, const rtk_ray *ray, rtk_trace_work *work)
{
    switch (path) {
#if RTK_HAVE_X86
    case RTK_SIMD_AVX512:
        return work ? avx512_any_work(s, ray, work) : avx512_any(s, ray);
    case RTK_SIMD_AVX2:
        return work ? avx2_any_work(s, ray, work) : avx2_any(s, ray);
    case RTK_SIMD_SSE:
        return work ? sse_any_work(s, ray, work) : sse_any(s, ray);
#endif
    default:
        return scalar_any(s, ray, work);
    }
}

/* The batch through this path's packets and streams (bvh_wide_isa.inc's
 * batch), or one ray at a time where the path has none. Origins of a
 * packet lie within a hundredth of the scene's diagonal of each other. */
static void batch_trace(const rtk_scene *s, rtk_simd_path path, const rtk_ray *rays, uint32_t count, rtk_hit *hits,
                        uint8_t *occluded, int any)
{
#if RTK_HAVE_X86
    if (path == RTK_SIMD_AVX2 || path == RTK_SIMD_AVX512) {
        const rtk_bounds b = s->bounds;
        const float diag = rtk_vec3_length(rtk_vec3_sub(b.upper, b.lower));
        (path == RTK_SIMD_AVX512 ? avx512_batch : avx2_batch)(s, rays, count, hits, occluded, any, 0.01f * diag);
        return;
    }
#endif
    for (uint32_t i = 0; i < count; i++) {
        if (any)
            occluded[i] = (uint8_t)(rtk_wide_any_path[path](s, &rays[i]) != 0);
        else if (!rtk_wide_closest_path[path](s, &rays[i], &hits[i]))
            hits[i].prim = RTK_INVALID_ID;
    }
}

void rtk_wide_closest_batch(const rtk_scene *s, rtk_simd_path path, const rtk_ray *rays, uint32_t count,
                            rtk_hit *hits)
{
    batch_trace(s, path, rays, count, hits, NULL, 0);
}

void rtk_wide_any_batch(const rtk_scene *s, rtk_simd_path path, const rtk_ray *rays, uint32_t count,
                        uint8_t *occluded)
{
    batch_trace(s, path, rays, count, NULL, occluded, 1);
}

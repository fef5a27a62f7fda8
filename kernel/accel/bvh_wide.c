/* The wide BVH (see bvh_wide.h): collapse of the binary tree, and its
 * traversal in plain C, SSE, AVX2 and AVX-512, the SIMD paths compiled
 * here with target attributes and chosen at run time. The AVX2 and
 * AVX-512 paths are one node loop, compiled twice: this file includes
 * itself once per target (RTK_WIDE_AVX_PASS), and each inclusion compiles
 * only the loop at its end.
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
#ifndef RTK_WIDE_AVX_PASS
#include "accel.h"
#include "slab.h"

#include <assert.h>
#include <float.h>
#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if defined(__x86_64__) || defined(__i386__)
#define RTK_HAVE_X86 1
#include <immintrin.h>
#else
#define RTK_HAVE_X86 0
#endif

#define RTK_INLINE static inline __attribute__((always_inline))

/* Deepest wide tree: the binary limit (each wide level spans at least one
 * binary level) plus levels that split oversized leaves. */
#define RTK_WIDE_MAX_DEPTH 288
/* Each node on the path from the root (depth 0 .. RTK_WIDE_MAX_DEPTH)
 * leaves at most RTK_WIDE - 1 entries on the stack. */
#define RTK_WIDE_STACK ((RTK_WIDE - 1) * (RTK_WIDE_MAX_DEPTH + 1) + 1)

uint32_t rtk_wide_node_limit = RTK_WIDE_MAX_NODES;
/* Blocks a leaf reference addresses: the first block's index takes the
 * bits above RTK_WIDE_LEAF_SHIFT. */
#define WIDE_MAX_BLOCKS (1u << (31 - RTK_WIDE_LEAF_SHIFT))

/* 1 + 2 gamma(3), as in bvh.c. */
static const float slab_slack = 1.0f + 2.0f * (3.0f * 0.5f * FLT_EPSILON) / (1.0f - 3.0f * 0.5f * FLT_EPSILON);

/* ---- collapse ---- */

typedef struct collapser {
    const rtk_scene *s;
    rtk_wide_node *nodes;
    uint32_t node_count, node_cap;
    rtk_wide_tris *tris;
    uint32_t tri_count, tri_cap;
    uint32_t *tri_total;  /* per binary node: triangles below it */
    uint32_t *plan;       /* per binary node: the collapse's choices (PLAN_*) */
    uint32_t *slots;      /* scratch: the slots of one merged subtree */
    float *corners;       /* scratch: their corners, 9 floats each */
    uint32_t bad_leaf;    /* lowest binary leaf met whose box misses its corners */
    uint32_t depth;
    int failed;
    /* The counting pass records each inner node's binary node and
     * children (their number, then the binary nodes) in the order
     * collapse makes the nodes; collapse reads them instead of choosing
     * again. */
    uint32_t *kid_seq;
    size_t kid_len, kid_cap, kid_pos;
    /* Not NULL: the binary tree's structure is unchecked, and the plan
     * checks each node before it reads the node's children. */
    const rtk_tree_check *check;
} collapser;

static uint32_t new_node(collapser *c)
{
    if (c->node_count == c->node_cap) { /* the counting pass was wrong: never */
        c->failed = 1;
        return UINT32_MAX;
    }
    rtk_wide_node *n = &c->nodes[c->node_count];
    for (int i = 0; i < RTK_WIDE; i++) {
        for (int k = 0; k < 3; k++) {
            n->bounds[2 * k][i] = INFINITY;
            n->bounds[2 * k + 1][i] = -INFINITY;
        }
        n->child[i] = RTK_WIDE_LEAF; /* never reached: the empty box is missed */
        n->pad[i] = 0;
    }
    return c->node_count++;
}

/* Child i of node: the box and the reference, an inner node as its byte
 * offset (RTK_WIDE_MAX_NODES). */
static void set_child(collapser *c, uint32_t node, int i, const float lo[3], const float hi[3], uint32_t ref)
{
    rtk_wide_node *n = &c->nodes[node];
    for (int k = 0; k < 3; k++) {
        n->bounds[2 * k][i] = lo[k];
        n->bounds[2 * k + 1][i] = hi[k];
    }
    n->child[i] = ref & RTK_WIDE_LEAF ? ref : ref * (uint32_t)sizeof(rtk_wide_node);
}

/* Bounds of the n triangles whose corners are v[0, 9n). */
static void corner_bounds(const float *v, uint32_t n, float lo[3], float hi[3])
{
    for (int k = 0; k < 3; k++)
        lo[k] = INFINITY, hi[k] = -INFINITY;
    for (size_t j = 0; j < 9 * (size_t)n; j++) {
        int k = (int)(j % 3);
        lo[k] = v[j] < lo[k] ? v[j] : lo[k]; /* positions are finite */
        hi[k] = v[j] > hi[k] ? v[j] : hi[k];
    }
}

/* Leaf reference for slots[0, n) with corners v[0, 9n), at most
 * RTK_WIDE_LEAF_BLOCKS blocks. */
static uint32_t make_blocks(collapser *c, const uint32_t *slots, const float *v, uint32_t n)
{
    uint32_t blocks = (n + RTK_WIDE_TRIS - 1) / RTK_WIDE_TRIS;
    if (blocks > c->tri_cap - c->tri_count) { /* the counting pass was wrong: never */
        c->failed = 1;
        return RTK_WIDE_LEAF;
    }
    uint32_t first = c->tri_count;
    for (uint32_t b = 0; b < blocks; b++) {
        rtk_wide_tris *t = &c->tris[c->tri_count++];
        const uint32_t base = b * RTK_WIDE_TRIS, lanes = n - base < RTK_WIDE_TRIS ? n - base : RTK_WIDE_TRIS;
        const float *src = v + 9 * (size_t)base;
        for (uint32_t lane = 0; lane < RTK_WIDE_TRIS; lane++)
            t->prim[lane] = lane < lanes ? c->s->prim_ids[slots[base + lane]] : RTK_INVALID_ID;
#if RTK_HAVE_X86
        /* Four triangles of 9 floats into 9 rows of 4: two 4x4 transposes
         * (floats 0-3 and 4-7 of each triangle), then float 8 by hand.
         * The lanes of a partial block get NaN corners: every comparison
         * of the test fails on them, a miss. (Read in place: a padded
         * copy cost a rep movs per partial block.) */
        static_assert(RTK_WIDE_TRIS == 4, "blocks of four");
        const __m128 none = _mm_set1_ps(NAN);
        __m128 a0 = _mm_loadu_ps(src), a1 = lanes > 1 ? _mm_loadu_ps(src + 9) : none,
               a2 = lanes > 2 ? _mm_loadu_ps(src + 18) : none, a3 = lanes > 3 ? _mm_loadu_ps(src + 27) : none;
        _MM_TRANSPOSE4_PS(a0, a1, a2, a3);
        _mm_storeu_ps(t->v[0], a0), _mm_storeu_ps(t->v[1], a1), _mm_storeu_ps(t->v[2], a2), _mm_storeu_ps(t->v[3], a3);
        __m128 b0 = _mm_loadu_ps(src + 4), b1 = lanes > 1 ? _mm_loadu_ps(src + 13) : none,
               b2 = lanes > 2 ? _mm_loadu_ps(src + 22) : none, b3 = lanes > 3 ? _mm_loadu_ps(src + 31) : none;
        _MM_TRANSPOSE4_PS(b0, b1, b2, b3);
        _mm_storeu_ps(t->v[4], b0), _mm_storeu_ps(t->v[5], b1), _mm_storeu_ps(t->v[6], b2), _mm_storeu_ps(t->v[7], b3);
        _mm_storeu_ps(t->v[8], _mm_setr_ps(src[8], lanes > 1 ? src[17] : NAN, lanes > 2 ? src[26] : NAN,
                                           lanes > 3 ? src[35] : NAN));
#else
        for (uint32_t lane = 0; lane < RTK_WIDE_TRIS; lane++) /* NaN lanes: see above */
            for (int j = 0; j < 9; j++)
                t->v[j][lane] = lane < lanes ? src[9 * lane + j] : NAN;
#endif
    }
    return RTK_WIDE_LEAF | first << RTK_WIDE_LEAF_SHIFT | (blocks - 1);
}

/* Reference for a leaf over slots[0, n) with corners v[0, 9n): blocks
 * directly, or a node over up to RTK_WIDE pieces when the leaf is too
 * large for one reference. */
static uint32_t make_leaf(collapser *c, const uint32_t *slots, const float *v, uint32_t n, uint32_t depth)
{
    const uint32_t per_ref = RTK_WIDE_LEAF_BLOCKS * RTK_WIDE_TRIS;
    if (n <= per_ref)
        return make_blocks(c, slots, v, n);
    if (depth > RTK_WIDE_MAX_DEPTH) {
        c->failed = 1;
        return RTK_WIDE_LEAF;
    }
    if (depth > c->depth)
        c->depth = depth;
    uint32_t node = new_node(c);
    if (c->failed)
        return RTK_WIDE_LEAF;
    uint32_t piece = (n + RTK_WIDE - 1) / RTK_WIDE;
    if (piece < per_ref)
        piece = per_ref;
    int i = 0;
    for (uint32_t b = 0; b < n; b += piece, i++) {
        uint32_t m = n - b < piece ? n - b : piece;
        float lo[3], hi[3];
        corner_bounds(v + 9 * (size_t)b, m, lo, hi);
        uint32_t ref = make_leaf(c, slots + b, v + 9 * (size_t)b, m, depth + 1);
        if (c->failed)
            return RTK_WIDE_LEAF;
        set_child(c, node, i, lo, hi, ref);
    }
    return node;
}

/* Appends the slots of binary subtree bin to c->slots and their corners
 * to c->corners from *n on. On the way each binary leaf's box is checked
 * against its triangles' corners, the check validation leaves out (every
 * binary leaf is gathered exactly once): a failing leaf lowers
 * c->bad_leaf. */
static void gather_slots(collapser *c, uint32_t bin, uint32_t *n)
{
    const rtk_bvh_node *bn = c->s->nodes;
    if (bn[bin].count > 0) {
        const rtk_bvh_node *leaf = &bn[bin];
#if RTK_HAVE_X86
        const rtk_scene *s = c->s;
        /* Each corner is one 16-byte load (a float more follows the last
         * vertex) and one store; the stores overlap, each writing the
         * lane the next one or the next triangle's first overwrites
         * (corners has a float to spare at its end). Lane 3 is ignored. */
        __m128 lo = _mm_set1_ps(INFINITY), hi = _mm_set1_ps(-INFINITY);
        for (uint32_t i = 0; i < leaf->count; i++) {
            /* The triangles are met in leaf order, their indices and
             * positions all over memory: fetch the indices of the slot 16
             * ahead and the positions of the slot 8 ahead, whose indices
             * came 8 slots ago (slots run on; a wrong guess costs a load). */
            uint32_t ahead = leaf->offset + i + 8;
            if (ahead + 8 < s->triangle_count) {
                __builtin_prefetch(s->indices + 3 * (size_t)s->prim_ids[ahead + 8]);
                const uint32_t *idx = s->indices + 3 * (size_t)s->prim_ids[ahead];
                __builtin_prefetch(s->positions + 3 * (size_t)idx[0]);
                __builtin_prefetch(s->positions + 3 * (size_t)idx[1]);
                __builtin_prefetch(s->positions + 3 * (size_t)idx[2]);
            }
            const uint32_t *idx = s->indices + 3 * (size_t)s->prim_ids[leaf->offset + i];
            const __m128 a = _mm_loadu_ps(s->positions + 3 * (size_t)idx[0]),
                         b = _mm_loadu_ps(s->positions + 3 * (size_t)idx[1]),
                         d = _mm_loadu_ps(s->positions + 3 * (size_t)idx[2]);
            float *v = c->corners + 9 * (size_t)*n;
            _mm_storeu_ps(v, a), _mm_storeu_ps(v + 3, b), _mm_storeu_ps(v + 6, d);
            lo = _mm_min_ps(lo, _mm_min_ps(a, _mm_min_ps(b, d))); /* positions are finite */
            hi = _mm_max_ps(hi, _mm_max_ps(a, _mm_max_ps(b, d)));
            c->slots[(*n)++] = leaf->offset + i;
        }
        const float *box = leaf->lower; /* lower, offset, upper, count: see node_encloses in bvh.c */
        const __m128 in = _mm_and_ps(_mm_cmple_ps(_mm_loadu_ps(box), lo), _mm_cmple_ps(hi, _mm_loadu_ps(box + 4)));
        int inside = (_mm_movemask_ps(in) & 7) == 7;
#else
        float lx = INFINITY, ly = INFINITY, lz = INFINITY, hx = -INFINITY, hy = -INFINITY, hz = -INFINITY;
        for (uint32_t i = 0; i < leaf->count; i++) {
            float *v = c->corners + 9 * (size_t)*n;
            rtk_slot_corners(c->s, leaf->offset + i, v);
            for (int corner = 0; corner < 9; corner += 3) { /* positions are finite */
                float x = v[corner], y = v[corner + 1], z = v[corner + 2];
                lx = x < lx ? x : lx, ly = y < ly ? y : ly, lz = z < lz ? z : lz;
                hx = x > hx ? x : hx, hy = y > hy ? y : hy, hz = z > hz ? z : hz;
            }
            c->slots[(*n)++] = leaf->offset + i;
        }
        int inside = leaf->lower[0] <= lx && leaf->lower[1] <= ly && leaf->lower[2] <= lz && hx <= leaf->upper[0] &&
                     hy <= leaf->upper[1] && hz <= leaf->upper[2];
#endif
        if (!inside && bin < c->bad_leaf)
            c->bad_leaf = bin;
        return;
    }
    gather_slots(c, bn[bin].offset, n);
    gather_slots(c, bn[bin].offset + 1, n);
}

/* The collapse minimises the SAH cost of the wide tree over the ways of
 * cutting the binary tree into wide nodes and leaves (Ylitie et al.
 * 2017, by dynamic programming): C(n, j), the least cost of binary
 * subtree n as at most j subtrees side by side in a wide node, is
 * C(n, 1) = min(leaf(n), area(n) WIDE_COST_NODE + D(n, RTK_WIDE)) and
 * C(n, j) = min(C(n, j - 1), D(n, j)) with
 * D(n, j) = min over k of C(left, k) + C(right, j - k). A leaf costs its
 * area times WIDE_COST_BLOCK per block of four triangles; a subtree of up
 * to WIDE_LEAF_MAX triangles may become one, a binary leaf always is one.
 * Ties go to the leaf and to more subtrees, so flat (zero-area) input
 * fills its nodes. */
#define WIDE_COST_NODE 1.0
#define WIDE_COST_BLOCK 1.0
#define WIDE_LEAF_MAX RTK_WIDE_TRIS

/* Bits of collapser.plan: for j = 2 .. RTK_WIDE, whether C(n, j) is
 * D(n, j), and the k of D(n, j); whether C(n, 1) is a leaf; the binary
 * leaves below n, at most RTK_WIDE, minus one. A subtree of L leaves
 * cannot fill more than L children: C(n, j) = C(n, L) for j > L, so only
 * j <= L and splits k that give each side at most its leaves are tried
 * (the same least costs, in a fraction of the steps near the bottom of
 * the tree, where most nodes are), and above L no split bit is set and
 * k is that of D(n, L). */
#define PLAN_K_SHIFT(j) (3 * ((j) - 2))
#define PLAN_SPLIT(j) (1u << (19 + (j)))
#define PLAN_LEAF (1u << 28)
#define PLAN_LEAVES_SHIFT 29
static_assert(RTK_WIDE == 8, "the plan packs k in 3 bits and the leaves below in 3");

static uint32_t plan_leaves(uint32_t plan)
{
    return (plan >> PLAN_LEAVES_SHIFT) + 1;
}

static double half_area(const float lo[3], const float hi[3])
{
    double dx = (double)hi[0] - lo[0], dy = (double)hi[1] - lo[1], dz = (double)hi[2] - lo[2];
    return dx * dy + dy * dz + dz * dx;
}

/* Costs out[j - 1] = C(id, j) of binary leaf id (n), and its plan and
 * triangles. */
static inline void plan_leaf_costs(collapser *c, uint32_t id, const rtk_bvh_node *n, double *out)
{
    const double leaf =
        half_area(n->lower, n->upper) * WIDE_COST_BLOCK * (double)((n->count + RTK_WIDE_TRIS - 1) / RTK_WIDE_TRIS);
    for (int j = 0; j < RTK_WIDE; j++)
        out[j] = leaf;
    c->tri_total[id] = n->count;
    c->plan[id] = PLAN_LEAF;
}

/* Costs out[j - 1] = C(id, j) of inner binary node id, from its
 * children's, and its plan. */
static void plan_costs(collapser *c, uint32_t id, const double *left, const double *right, double *out)
{
    const rtk_bvh_node *n = &c->s->nodes[id];
    double area = half_area(n->lower, n->upper);
    uint32_t tris = c->tri_total[id];
    double leaf = area * WIDE_COST_BLOCK * (double)((tris + RTK_WIDE_TRIS - 1) / RTK_WIDE_TRIS);
    const int ll = (int)plan_leaves(c->plan[n->offset]), lr = (int)plan_leaves(c->plan[n->offset + 1]);
    const int lmax = ll + lr < RTK_WIDE ? ll + lr : RTK_WIDE;
    uint32_t plan = (uint32_t)(lmax - 1) << PLAN_LEAVES_SHIFT;
    /* dist[j] = D(id, j), the least left[k - 1] + right[j - k - 1] over
     * the splits k of j the children allow, j - lr <= k <= ll, the first
     * least k taken (ties to the left child's fewer). Every k < j is
     * tried, in loops of fixed length without branches, the k below
     * j - lr made infinite: those above ll cost no less than k = ll
     * (left[] is flat from index ll - 1 on, and right[] does not increase
     * with its index), so they never win: the same plan as a loop over
     * the allowed k alone, in less time. Values
     * of j beyond lmax are computed and unused. */
    double dist[RTK_WIDE + 1];
    int kbest[RTK_WIDE + 1];
#pragma GCC unroll 8
    for (int j = 2; j <= RTK_WIDE; j++) {
        double best = INFINITY;
        int best_k = j - lr > 1 ? j - lr : 1;
#pragma GCC unroll 8
        for (int k = 1; k < j; k++) {
            const double v = k >= j - lr ? left[k - 1] + right[j - k - 1] : INFINITY;
            const int less = v < best;
            best = less ? v : best;
            best_k = less ? k : best_k;
        }
        dist[j] = best;
        kbest[j] = best_k;
    }
    for (int j = 2; j <= RTK_WIDE; j++)
        plan |= (uint32_t)kbest[j <= lmax ? j : lmax] << PLAN_K_SHIFT(j);
    double inner = area * WIDE_COST_NODE + dist[lmax];
    if (tris <= WIDE_LEAF_MAX && leaf <= inner) {
        out[0] = leaf;
        plan |= PLAN_LEAF;
    } else {
        out[0] = inner;
    }
    for (int j = 2; j <= lmax; j++) {
        int split = dist[j] <= out[j - 2];
        out[j - 1] = split ? dist[j] : out[j - 2];
        plan |= split ? PLAN_SPLIT(j) : 0u;
    }
    for (int j = lmax + 1; j <= RTK_WIDE; j++)
        out[j - 1] = out[lmax - 1];
    c->plan[id] = plan;
}

/* One plan walk's limit on depth and, when it checks the tree, its marks
 * and counts (bit set number set). */
typedef struct plan_scratch {
    uint32_t levels;
    rtk_tree_tally tally;
} plan_scratch;

static void plan_scratch_init(plan_scratch *w, const collapser *c, uint32_t set)
{
    /* An unchecked tree is as deep as the checks let it be. */
    w->levels = (c->check ? RTK_BVH_MAX_DEPTH : c->s->bvh_depth) + 2;
    if (c->check)
        rtk_tree_tally_init(c->check, set, &w->tally);
}

/* Triangles below every binary node under id (at depth, the root at 0)
 * and the plan of the collapse, into c->tri_total and c->plan; id's
 * costs into out. Post-order, left subtree first: builders lay subtrees
 * out in that order, so the walk reads memory forwards. Recursive: the
 * depth is bounded (below; about 80 KB of stack at the deepest), each
 * level's frame holds its children's costs, and the calls cost fewer
 * instructions and mispredicted branches than a loop over a stack of its
 * own. Inner nodes at depth frontier are not entered: their triangle
 * counts are known and their costs are taken from known[*next], in this
 * order. With c->check, each node is checked before its children are
 * read (depth counted from 1 at the binary root; inner nodes at frontier
 * are checked by their own walks), which bounds the depth by
 * RTK_BVH_MAX_DEPTH. 0 when a check fails, or if the tree is deeper than
 * bvh_depth said (never: it was validated). */
static int plan_walk(collapser *c, plan_scratch *w, uint32_t id, uint32_t depth, uint32_t frontier,
                     const double *known, uint32_t *next, double *out)
{
    const rtk_bvh_node *n = &c->s->nodes[id];
    if (depth + 1 >= w->levels)
        return 0;
    if (c->check && (n->count > 0 || depth != frontier) && !rtk_tree_check_node(c->check, &w->tally, id, depth + 1))
        return 0;
    if (n->count > 0) {
        plan_leaf_costs(c, id, n, out);
        return 1;
    }
    if (depth == frontier) {
        memcpy(out, &known[RTK_WIDE * (*next)++], sizeof *out * RTK_WIDE);
        return 1;
    }
    double left[RTK_WIDE], right[RTK_WIDE];
    if (!plan_walk(c, w, n->offset, depth + 1, frontier, known, next, left) ||
        !plan_walk(c, w, n->offset + 1, depth + 1, frontier, known, next, right))
        return 0;
    c->tri_total[id] = c->tri_total[n->offset] + c->tri_total[n->offset + 1];
    plan_costs(c, id, left, right, out);
    return 1;
}

/* Large trees are planned on threads: the subtrees below the inner nodes
 * at this depth each by one thread, then the levels above them. */
#define PLAN_FRONTIER 8
#define PLAN_PARALLEL_NODES 4096u

/* The inner nodes at depth PLAN_FRONTIER under id, in walk order. An
 * unchecked tree's children are only read in range (the walks check the
 * rest); 0 when one is not. */
static int collect_frontier(const rtk_scene *s, uint32_t id, uint32_t depth, uint32_t *ids, uint32_t *count)
{
    const rtk_bvh_node *n = &s->nodes[id];
    if (n->count > 0)
        return 1;
    if (depth == PLAN_FRONTIER) {
        ids[(*count)++] = id;
        return 1;
    }
    if (n->offset == 0 || n->offset >= s->node_count - 1)
        return 0;
    return collect_frontier(s, n->offset, depth + 1, ids, count) &&
           collect_frontier(s, n->offset + 1, depth + 1, ids, count);
}

typedef struct plan_job {
    collapser *c;
    const uint32_t *ids;
    double *costs;
    uint32_t count;
    atomic_uint next;
    atomic_int failed;
    uint32_t covered, reached, max_depth; /* of the checks' walks, atomic */
} plan_job;

static void plan_worker(void *ctx, uint32_t begin, uint32_t end)
{
    (void)end;
    plan_job *job = ctx;
    plan_scratch w;
    plan_scratch_init(&w, job->c, begin + 1);
    int ok = 1;
    for (;;) {
        uint32_t k = atomic_fetch_add(&job->next, 1u);
        if (k >= job->count)
            break;
        if (ok)
            ok = plan_walk(job->c, &w, job->ids[k], PLAN_FRONTIER, UINT32_MAX, NULL, NULL,
                           &job->costs[RTK_WIDE * (size_t)k]);
    }
    if (!ok)
        atomic_store(&job->failed, 1);
    if (ok && job->c->check)
        rtk_tree_tally_add(&w.tally, &job->covered, &job->reached, &job->max_depth);
}

/* tri_total and plan of every binary node, on up to threads threads;
 * the same on any number of them. With c->check, the walks check the
 * tree (walk k on its thread's bit set k + 1, the top walk on 0) and
 * *depth gets its depth; 0 when it fails. */
static int plan_tree(collapser *c, uint32_t threads, uint32_t *depth)
{
    const rtk_scene *s = c->s;
    plan_scratch w;
    double root[RTK_WIDE];
    plan_scratch_init(&w, c, 0);
    int ok = 1;
    uint32_t *ids = NULL, count = 0, next = 0;
    double *costs = NULL;
    plan_job job = {.c = c};
    if (threads > 1 && s->node_count >= PLAN_PARALLEL_NODES) {
        ids = rtk_alloc(sizeof *ids << PLAN_FRONTIER);
        ok = ids != NULL && collect_frontier(s, 0, 0, ids, &count);
        costs = count ? rtk_alloc(sizeof *costs * RTK_WIDE * count) : NULL;
        ok = ok && (count == 0 || costs);
        if (ok && count) {
            job.ids = ids, job.costs = costs, job.count = count;
            atomic_init(&job.next, 0u);
            atomic_init(&job.failed, 0);
            rtk_parallel_ranges(threads, threads, 1, plan_worker, &job);
            ok = !atomic_load(&job.failed);
        }
    }
    if (ok)
        ok = plan_walk(c, &w, 0, 0, count ? PLAN_FRONTIER : UINT32_MAX, costs, &next, root);
    if (ok && c->check) {
        rtk_tree_tally_add(&w.tally, &job.covered, &job.reached, &job.max_depth);
        ok = rtk_tree_check_whole(c->check, job.reached, job.covered);
        *depth = job.max_depth;
    }
    free(ids);
    free(costs);
    return ok && next == count;
}

/* plan_tree, and with validate the walks check s's tree as they go and
 * *depth gets its depth: RTK_OK; RTK_ERR_PLUGIN with rtk_bvh_validate's
 * message for a tree that fails; RTK_ERR_NOMEM (the structure then maybe
 * unchecked). Validation rides on the plan's walks, one pass over the
 * nodes instead of two: the same checks, quietly, and a tree that fails
 * them is walked again by rtk_bvh_validate for the message. */
static rtk_status plan_validated(collapser *c, uint32_t threads, int validate, uint32_t *depth)
{
    const rtk_scene *s = c->s;
    if (threads > RTK_TREE_CHECK_MAX_SETS - 1)
        threads = RTK_TREE_CHECK_MAX_SETS - 1;
    if (!validate)
        return plan_tree(c, threads, depth) ? RTK_OK : rtk_error(RTK_ERR_NOMEM, "wide BVH: out of memory planning");
    rtk_tree_check check;
    uint32_t seen = 0;
    int ok = rtk_tree_check_init(&check, s->nodes, s->node_count, s->prim_ids, s->triangle_count, threads + 1);
    if (ok) {
        c->check = &check;
        ok = plan_tree(c, threads, &seen);
        c->check = NULL;
        rtk_tree_check_free(&check);
    }
    if (ok) {
        *depth = seen;
        return RTK_OK;
    }
    rtk_status st = rtk_bvh_validate_scene(s, threads, depth);
    return st != RTK_OK ? st : rtk_error(RTK_ERR_NOMEM, "wide BVH: out of memory planning");
}

/* Whether binary node id ends a wide path: a leaf of the plan. */
static int is_wide_leaf(const collapser *c, uint32_t id)
{
    return (c->plan[id] & PLAN_LEAF) != 0;
}

/* Appends the subtrees of C(id, j) to kids from *n on. */
static void decompose(const collapser *c, uint32_t id, int j, uint32_t kids[RTK_WIDE], int *n)
{
    const rtk_bvh_node *bn = &c->s->nodes[id];
    while (j > 1 && bn->count == 0 && !(c->plan[id] & PLAN_SPLIT(j)))
        j--;
    if (j == 1 || bn->count > 0) {
        kids[(*n)++] = id;
        return;
    }
    int k = (int)(c->plan[id] >> PLAN_K_SHIFT(j) & 7u);
    decompose(c, bn->offset, k, kids, n);
    decompose(c, bn->offset + 1, j - k, kids, n);
}

/* The children of the wide node for binary node bin, into kids: the
 * subtrees of D(bin, RTK_WIDE), or a binary leaf alone. Returns their
 * number. */
static int choose_kids(const collapser *c, uint32_t bin, uint32_t kids[RTK_WIDE])
{
    const rtk_bvh_node *bn = &c->s->nodes[bin];
    int n = 0;
    if (bn->count > 0) {
        kids[n++] = bin;
        return n;
    }
    int k = (int)(c->plan[bin] >> PLAN_K_SHIFT(RTK_WIDE) & 7u);
    decompose(c, bn->offset, k, kids, &n);
    decompose(c, bn->offset + 1, RTK_WIDE - k, kids, &n);
    return n;
}

/* What make_leaf will allocate for a leaf of n triangles. */
static void count_leaf(collapser *c, uint32_t n, uint32_t depth)
{
    const uint32_t per_ref = RTK_WIDE_LEAF_BLOCKS * RTK_WIDE_TRIS;
    if (n <= per_ref) {
        c->tri_cap += (n + RTK_WIDE_TRIS - 1) / RTK_WIDE_TRIS;
        return;
    }
    if (depth > RTK_WIDE_MAX_DEPTH) {
        c->failed = 1;
        return;
    }
    c->node_cap++;
    uint32_t piece = (n + RTK_WIDE - 1) / RTK_WIDE;
    if (piece < per_ref)
        piece = per_ref;
    for (uint32_t b = 0; b < n && !c->failed; b += piece)
        count_leaf(c, n - b < piece ? n - b : piece, depth + 1);
}

/* What collapse will allocate below binary node bin: the counting pass,
 * so that the tree is written once into arrays of its exact size. */
static void count_collapse(collapser *c, uint32_t bin, uint32_t depth)
{
    if (depth > RTK_WIDE_MAX_DEPTH) {
        c->failed = 1;
        return;
    }
    if (c->kid_len + 2 + RTK_WIDE > c->kid_cap) {
        size_t cap = c->kid_cap ? 2 * c->kid_cap : 4096;
        uint32_t *grown = rtk_realloc_array(c->kid_seq, cap, sizeof *grown);
        if (!grown) {
            c->failed = 1;
            return;
        }
        c->kid_seq = grown, c->kid_cap = cap;
    }
    uint32_t kids[RTK_WIDE];
    int n = choose_kids(c, bin, kids);
    c->kid_seq[c->kid_len] = bin;
    c->kid_seq[c->kid_len + 1] = (uint32_t)n;
    memcpy(c->kid_seq + c->kid_len + 2, kids, sizeof *kids * (size_t)n);
    c->kid_len += 2 + (size_t)n;
    c->node_cap++;
    for (int i = 0; i < n && !c->failed; i++) {
        if (is_wide_leaf(c, kids[i]))
            count_leaf(c, c->tri_total[kids[i]], depth + 1);
        else
            count_collapse(c, kids[i], depth + 1);
    }
}

/* Wide node for binary node bin (children from choose_kids). */
static uint32_t collapse(collapser *c, uint32_t bin, uint32_t depth)
{
    const rtk_bvh_node *bn = c->s->nodes;
    if (depth > RTK_WIDE_MAX_DEPTH) {
        c->failed = 1;
        return 0;
    }
    if (depth > c->depth)
        c->depth = depth;
    /* The children the counting pass chose for bin (it recorded the nodes
     * in this order). */
    const size_t at = c->kid_pos;
    if (at > c->kid_len || c->kid_len - at < 2 || c->kid_seq[at] != bin || c->kid_seq[at + 1] > RTK_WIDE ||
        c->kid_seq[at + 1] > c->kid_len - at - 2) { /* the passes disagree: never */
        c->failed = 1;
        return 0;
    }
    const int n = (int)c->kid_seq[at + 1];
    const uint32_t *kids = c->kid_seq + at + 2;
    c->kid_pos = at + 2 + (size_t)n;
    uint32_t node = new_node(c);
    if (c->failed)
        return 0;
    for (int i = 0; i < n; i++) {
        const rtk_bvh_node *k = &bn[kids[i]];
        uint32_t ref;
        if (is_wide_leaf(c, kids[i])) {
            uint32_t count = 0;
            gather_slots(c, kids[i], &count);
            ref = make_leaf(c, c->slots, c->corners, count, depth + 1);
        } else {
            ref = collapse(c, kids[i], depth + 1);
        }
        if (c->failed)
            return 0;
        set_child(c, node, i, k->lower, k->upper, ref);
    }
    return node;
}

void rtk_wide_destroy(rtk_wide_bvh *w)
{
    if (!w)
        return;
    free(w->mem[0]);
    free(w->mem[1]);
    free(w);
}

void rtk_wide_free(rtk_scene *s)
{
    rtk_wide_destroy(s->wide);
    s->wide = NULL;
}

/* The top of the tree is planned serially and the subtrees below it are
 * collapsed as separate items, on threads when there are several: the
 * counting pass gives each item its exact ranges of nodes and blocks and
 * each planned node its index, in the order the serial collapse fills
 * them, so the tree is the same bit for bit on any number of threads.
 * A subtree is planned (split into its children) while it holds more
 * than 1/RTK_WIDE_GRAIN of the triangles, so that no item dominates. */
#define RTK_WIDE_GRAIN 32
/* Levels planned at most. */
#define RTK_WIDE_PLAN_DEPTH 8

/* Workers of the counting pass and the collapse at most. */
#define RTK_WIDE_WORKERS 64u

typedef struct wide_item {
    uint32_t kid;                    /* binary node */
    uint32_t depth;                  /* wide depth of its reference */
    uint32_t planned_before;         /* planned nodes made before it */
    uint32_t node_start, node_count; /* its range of wide nodes */
    uint32_t kid_buf;                /* the counting worker whose kid_seq holds its entries */
    size_t kid_start, kid_len;       /* its entries there */
    uint32_t tri_start, tri_count;   /* its range of blocks */
    uint32_t ref, depth_out;         /* results */
    uint32_t bad_leaf;               /* lowest failing binary leaf, or UINT32_MAX */
    int failed;
} wide_item;

/* A reference to fill once the items are done: child slot of a planned
 * node, the binary node whose bounds it gets, and either an item's
 * result or a planned node's index. */
typedef struct wide_fixup {
    uint32_t node, bin, item, ref; /* item UINT32_MAX: ref is a planned node */
    int slot;
} wide_fixup;

typedef struct wide_plan {
    wide_item *items;
    uint32_t item_count, item_cap;
    wide_fixup *fixups;
    uint32_t fixup_count, fixup_cap;
    uint32_t *items_before; /* per planned node: the items made before it */
    uint32_t planned_count, planned_cap;
    uint32_t grain; /* triangles above which a subtree is planned */
    uint32_t depth; /* deepest planned node */
    int failed;
} wide_plan;

/* Plans the wide node for binary node bin at depth, planned node number
 * pl->planned_count (its index comes once the items are counted), then
 * each child in order is planned in turn or becomes an item. Planned
 * nodes and items are numbered in the order a serial collapse makes
 * them: a planned node's index is the planned nodes and the items' nodes
 * made before it. */
static void plan_node(collapser *c, wide_plan *pl, uint32_t bin, uint32_t depth)
{
    uint32_t kids[RTK_WIDE];
    int n = choose_kids(c, bin, kids);
    if (!rtk_grow_array((void **)&pl->items_before, &pl->planned_cap, pl->planned_count, sizeof *pl->items_before)) {
        pl->failed = 1;
        return;
    }
    const uint32_t node = pl->planned_count++;
    pl->items_before[node] = pl->item_count;
    if (depth > pl->depth)
        pl->depth = depth;
    for (int i = 0; i < n && !c->failed && !pl->failed; i++) {
        if (!rtk_grow_array((void **)&pl->fixups, &pl->fixup_cap, pl->fixup_count, sizeof *pl->fixups)) {
            pl->failed = 1;
            return;
        }
        wide_fixup *f = &pl->fixups[pl->fixup_count++];
        *f = (wide_fixup){.node = node, .bin = kids[i], .item = UINT32_MAX, .slot = i};
        if (!is_wide_leaf(c, kids[i]) && c->tri_total[kids[i]] > pl->grain && depth + 1 < RTK_WIDE_PLAN_DEPTH) {
            f->ref = pl->planned_count;
            plan_node(c, pl, kids[i], depth + 1);
            continue;
        }
        if (!rtk_grow_array((void **)&pl->items, &pl->item_cap, pl->item_count, sizeof *pl->items)) {
            pl->failed = 1;
            return;
        }
        f->item = pl->item_count;
        pl->items[pl->item_count++] =
            (wide_item){.kid = kids[i], .depth = depth + 1, .planned_before = pl->planned_count};
    }
}

/* The items' passes on threads, each worker taking whole items: the
 * counting pass, each worker into a kid_seq of its own, then the
 * collapse. */
typedef struct item_job {
    const collapser *proto;
    wide_item *items;
    const uint32_t *order; /* items, largest first */
    uint32_t item_count;
    atomic_uint next;
    uint32_t *bufs[RTK_WIDE_WORKERS]; /* per counting worker: its kid_seq [job frees] */
} item_job;

static void count_worker(void *ctx, uint32_t begin, uint32_t end)
{
    (void)end;
    item_job *job = ctx;
    collapser c = *job->proto;
    c.kid_seq = NULL, c.kid_len = c.kid_cap = 0;
    for (;;) {
        uint32_t k = atomic_fetch_add(&job->next, 1u);
        if (k >= job->item_count)
            break;
        wide_item *it = &job->items[job->order[k]];
        c.node_cap = c.tri_cap = 0;
        c.failed = 0;
        it->kid_buf = begin;
        it->kid_start = c.kid_len;
        if (is_wide_leaf(&c, it->kid))
            count_leaf(&c, c.tri_total[it->kid], it->depth);
        else
            count_collapse(&c, it->kid, it->depth);
        it->kid_len = c.kid_len - it->kid_start;
        it->node_count = c.node_cap, it->tri_count = c.tri_cap;
        it->failed = c.failed;
    }
    job->bufs[begin] = c.kid_seq;
}

/* After the counting pass: each item's ranges of nodes and blocks, each
 * planned node's index (in the fixups), in the serial order; the totals
 * in c->node_cap, c->tri_cap. 0 when out of memory or an item failed. */
static int number_nodes(collapser *c, wide_plan *pl)
{
    uint32_t *nodes_before = rtk_alloc(sizeof *nodes_before * ((size_t)pl->item_count + 1));
    if (!nodes_before)
        return 0;
    uint32_t nodes = 0, tris = 0;
    int failed = 0;
    for (uint32_t k = 0; k < pl->item_count; k++) {
        wide_item *it = &pl->items[k];
        failed |= it->failed;
        nodes_before[k] = nodes;
        it->node_start = it->planned_before + nodes;
        it->tri_start = tris;
        nodes += it->node_count, tris += it->tri_count;
    }
    nodes_before[pl->item_count] = nodes;
    for (uint32_t f = 0; f < pl->fixup_count; f++) {
        wide_fixup *x = &pl->fixups[f];
        x->node += nodes_before[pl->items_before[x->node]];
        if (x->item == UINT32_MAX)
            x->ref += nodes_before[pl->items_before[x->ref]];
    }
    c->node_cap = pl->planned_count + nodes;
    c->tri_cap = tris;
    free(nodes_before);
    return !failed;
}

static void collapse_item(collapser *c, wide_item *it)
{
    c->node_count = it->node_start, c->node_cap = it->node_start + it->node_count;
    c->tri_count = it->tri_start, c->tri_cap = it->tri_start + it->tri_count;
    c->depth = 0;
    c->failed = 0;
    c->bad_leaf = UINT32_MAX;
    c->kid_pos = it->kid_start;
    c->kid_len = it->kid_start + it->kid_len;
    if (is_wide_leaf(c, it->kid)) {
        uint32_t count = 0;
        gather_slots(c, it->kid, &count);
        it->ref = make_leaf(c, c->slots, c->corners, count, it->depth);
    } else {
        it->ref = collapse(c, it->kid, it->depth);
    }
    /* the counting pass and this one disagree: never */
    if (c->node_count != c->node_cap || c->tri_count != c->tri_cap)
        c->failed = 1;
    it->depth_out = c->depth;
    it->bad_leaf = c->bad_leaf;
    it->failed = c->failed;
}

static void wide_worker(void *ctx, uint32_t begin, uint32_t end)
{
    (void)begin, (void)end;
    item_job *job = ctx;
    collapser c = *job->proto;
    c.slots = NULL;
    c.corners = NULL;
    uint32_t slot_cap = 0;
    for (;;) {
        uint32_t k = atomic_fetch_add(&job->next, 1u);
        if (k >= job->item_count)
            break;
        wide_item *it = &job->items[job->order[k]];
        c.kid_seq = job->bufs[it->kid_buf];
        uint32_t need = c.tri_total[it->kid];
        if (need > slot_cap) {
            free(c.slots);
            free(c.corners);
            c.slots = rtk_alloc(sizeof *c.slots * (size_t)need);
            c.corners = rtk_alloc(sizeof *c.corners * (9 * (size_t)need + 1)); /* + 1: see gather_slots */
            slot_cap = c.slots && c.corners ? need : 0;
        }
        if (slot_cap == 0) {
            it->failed = 1;
            continue;
        }
        collapse_item(&c, it);
    }
    free(c.slots);
    free(c.corners);
}

/* The items in order[0, n), largest first (triangles below; ties by
 * index): the longest ones start first. Insertion sort: a few hundred
 * items at most. */
static void order_items(const collapser *c, const wide_item *items, uint32_t n, uint32_t *order)
{
    for (uint32_t i = 0; i < n; i++) {
        uint32_t size = c->tri_total[items[i].kid], j = i;
        while (j > 0 && c->tri_total[items[order[j - 1]].kid] < size) {
            order[j] = order[j - 1];
            j--;
        }
        order[j] = i;
    }
}

/* Places the nodes and blocks: in spare when they fit there (nodes
 * first, whole 256-byte nodes keep the blocks 64-byte aligned), else the
 * blocks alone when they fit, else fresh memory; mem[] gets what to free
 * and spare is freed if unused. 0 when out of memory. */
static int place_arrays(collapser *c, void *spare, size_t spare_bytes, void *mem[2])
{
    const size_t node_bytes = sizeof *c->nodes * (size_t)c->node_cap;
    const size_t tri_bytes = sizeof *c->tris * (size_t)c->tri_cap;
    static_assert(sizeof(rtk_wide_node) % 64 == 0, "nodes keep what follows them aligned");
    mem[0] = mem[1] = NULL;
    if (spare && node_bytes + tri_bytes <= spare_bytes) {
        mem[0] = spare;
        c->nodes = spare;
        c->tris = (rtk_wide_tris *)(void *)((char *)spare + node_bytes);
        rtk_release_tail(spare, node_bytes + tri_bytes, spare_bytes);
        return 1;
    }
    if (spare && tri_bytes <= spare_bytes) {
        mem[0] = c->tris = spare;
        rtk_release_tail(spare, tri_bytes, spare_bytes);
    } else {
        free(spare); /* before the fresh allocation: its pages go back first */
        mem[0] = c->tris = rtk_alloc_large(tri_bytes);
    }
    mem[1] = c->nodes = rtk_alloc_large(node_bytes);
    return c->nodes && c->tris;
}

rtk_status rtk_wide_build(rtk_scene *s, uint32_t threads, void *spare, size_t spare_bytes, int validate)
{
    rtk_wide_free(s);
    if (s->node_count == 0 || !s->prim_ids) {
        free(spare);
        return RTK_OK;
    }
    collapser c;
    memset(&c, 0, sizeof c);
    c.s = s;
    c.tri_total = rtk_alloc(sizeof *c.tri_total * (size_t)s->node_count);
    c.plan = rtk_alloc(sizeof *c.plan * (size_t)s->node_count);
    wide_plan pl;
    memset(&pl, 0, sizeof pl);
    uint32_t *order = NULL;
    void *mem[2] = {NULL, NULL};
    uint32_t bad_leaf = UINT32_MAX;
    uint32_t workers = 1;
    int too_large = 0; /* more nodes or blocks than references address */
    item_job job;
    memset(&job, 0, sizeof job);
    atomic_init(&job.next, 0u);
    double times[4];
    times[0] = rtk_now();
    const rtk_status planned =
        c.tri_total && c.plan ? plan_validated(&c, threads, validate, &s->bvh_depth) : RTK_ERR_NOMEM;
    if (planned == RTK_ERR_PLUGIN) {
        free(c.tri_total);
        free(c.plan);
        free(spare);
        return planned;
    }
    if (planned != RTK_OK) {
        c.failed = 1;
    } else {
        /* The top of the collapse, serially; then the counting pass over
         * the items below it, on threads; then every range and index, in
         * the serial order. */
        times[1] = rtk_now();
        pl.grain = s->triangle_count / RTK_WIDE_GRAIN;
        plan_node(&c, &pl, 0, 0);
        c.failed |= pl.failed;
        workers = s->triangle_count >= 16384 && threads > 1 ? threads : 1;
        if (workers > RTK_WIDE_WORKERS)
            workers = RTK_WIDE_WORKERS;
        if (workers > pl.item_count)
            workers = pl.item_count ? pl.item_count : 1;
        if (!c.failed) {
            order = rtk_alloc(sizeof *order * (size_t)(pl.item_count ? pl.item_count : 1));
            c.failed = !order;
        }
        if (!c.failed) {
            order_items(&c, pl.items, pl.item_count, order);
            job.proto = &c, job.items = pl.items, job.order = order, job.item_count = pl.item_count;
            rtk_parallel_ranges(workers, workers, 1, count_worker, &job);
            c.failed = !number_nodes(&c, &pl);
        }
        /* Before anything is written: references address at most
         * rtk_wide_node_limit nodes and 2^27 blocks. */
        if (!c.failed && (c.node_cap > rtk_wide_node_limit || c.tri_cap >= WIDE_MAX_BLOCKS))
            too_large = 1, c.failed = 1;
        times[2] = rtk_now();
    }
    if (!c.failed) {
        c.failed = !place_arrays(&c, spare, spare_bytes, mem);
        spare = NULL;
    }
    free(spare);
    if (!c.failed) {
        uint32_t node_cap = c.node_cap, tri_cap = c.tri_cap;
        /* The planned nodes, empty until their references are known. */
        for (uint32_t f = 0, prev = UINT32_MAX; f < pl.fixup_count; f++) {
            if (pl.fixups[f].node == prev)
                continue;
            prev = pl.fixups[f].node;
            c.node_count = prev, c.node_cap = prev + 1;
            new_node(&c);
        }
        if (pl.fixup_count == 0) { /* never: the root has a child */
            c.failed = 1;
        } else {
            atomic_store(&job.next, 0u);
            rtk_parallel_ranges(workers, workers, 1, wide_worker, &job);
            times[3] = rtk_now();
            rtk_log(RTK_LOG_DEBUG,
                    "wide BVH: plan%s %.2f ms, counting %.2f ms, collapse %.2f ms (%u items, %u threads)",
                    validate ? " and validation" : "", 1e3 * (times[1] - times[0]), 1e3 * (times[2] - times[1]),
                    1e3 * (times[3] - times[2]), pl.item_count, workers);
            c.depth = pl.depth;
            for (uint32_t i = 0; i < pl.item_count; i++) {
                c.failed |= pl.items[i].failed;
                if (pl.items[i].bad_leaf < bad_leaf)
                    bad_leaf = pl.items[i].bad_leaf;
                if (pl.items[i].depth_out > c.depth)
                    c.depth = pl.items[i].depth_out;
            }
            for (uint32_t f = 0; f < pl.fixup_count && !c.failed; f++) {
                const wide_fixup *x = &pl.fixups[f];
                const rtk_bvh_node *k = &s->nodes[x->bin];
                set_child(&c, x->node, x->slot, k->lower, k->upper,
                          x->item == UINT32_MAX ? x->ref : pl.items[x->item].ref);
            }
        }
        c.node_count = node_cap, c.tri_count = tri_cap;
    }
    free(c.tri_total);
    free(c.plan);
    for (uint32_t w = 0; w < RTK_WIDE_WORKERS; w++)
        free(job.bufs[w]);
    free(pl.items);
    free(pl.fixups);
    free(pl.items_before);
    free(order);
    rtk_wide_bvh *w = NULL;
    if (!c.failed && bad_leaf != UINT32_MAX) {
        free(mem[0]);
        free(mem[1]);
        return rtk_bvh_leaf_error(s, bad_leaf);
    }
    if (!c.failed) {
        w = rtk_calloc(1, sizeof *w);
        if (!w) {
            c.failed = 1;
        } else {
            w->nodes = c.nodes;
            w->tris = c.tris;
            w->mem[0] = mem[0];
            w->mem[1] = mem[1];
            w->node_count = c.node_count;
            w->tri_block_count = c.tri_count;
            w->depth = c.depth;
            w->path = rtk_simd_from_env();
        }
    }
    if (c.failed) {
        free(mem[0]);
        free(mem[1]);
        if (too_large)
            return rtk_error(RTK_ERR_NOMEM,
                             "wide BVH: %u nodes and %u blocks, more than its references address (%u nodes, %u "
                             "blocks)",
                             c.node_cap, c.tri_cap, rtk_wide_node_limit, WIDE_MAX_BLOCKS - 1);
        return rtk_error(RTK_ERR_NOMEM, "wide BVH: out of memory or tree too deep");
    }
    s->wide = w;
    return RTK_OK;
}

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
    _mm_storeu_ps(p->ninv_far, _mm_mul_ps(ninv, _mm_set1_ps(slab_slack)));
    const int neg = _mm_movemask_ps(d4);
#else
    int neg = 0;
    for (int k = 0; k < 3; k++) {
        p->ninv[k] = -1.0f / d[k];
        p->ninv_far[k] = p->ninv[k] * slab_slack;
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
 *   boxes pass, never fewer; tests/wide counts the rays whose work
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
            if ((mask & (mask - 1)) == 0)
                cur = n->child[__builtin_ctz(mask)];
            else if (any)
                cur = push_unsorted(n, mask, stack, &top);
            else
                cur = push_sorted(n, mask, dist, stack, &top);
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
    const __m128 k0 = _mm_set1_ps(12.0f * (3.0f * 0.5f * FLT_EPSILON / (1.0f - 3.0f * 0.5f * FLT_EPSILON)) *
                                  (1.0f + 1.0f / 1048576.0f));
    const __m128 g25 = _mm_set1_ps((2.0f * 0.5f * FLT_EPSILON / (1.0f - 2.0f * 0.5f * FLT_EPSILON)) +
                                   2.0f * (5.0f * 0.5f * FLT_EPSILON / (1.0f - 5.0f * 0.5f * FLT_EPSILON)));
    const __m128 g5 = _mm_set1_ps(5.0f * 0.5f * FLT_EPSILON / (1.0f - 5.0f * 0.5f * FLT_EPSILON));
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
            if ((mask & (mask - 1)) == 0)
                cur = n->child[__builtin_ctz(mask)];
            else if (any)
                cur = push_unsorted(n, mask, stack, &top);
            else
                cur = push_sorted(n, mask, dist, stack, &top);
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

/* The node loop at the end of this file, once per target: RTK_AVX names
 * a function of the pass, RTK_AVX512 selects the two places where the
 * passes differ (the hit mask straight from the compare into a mask
 * register, and occlusion's push by one compress instead of the table
 * above). AVX-512VL on 256-bit vectors also gives the loop 32 vector
 * registers: its box test reads no broadcast of the ray from the stack
 * (the AVX2 loop's, eight). */
#define RTK_WIDE_AVX_PASS
#define RTK_AVX512 0
#define RTK_AVX(name) avx2_##name
#define RTK_TARGET_AVX __attribute__((target("avx2")))
#include "bvh_wide.c"
#undef RTK_TARGET_AVX
#undef RTK_AVX
#undef RTK_AVX512
#define RTK_AVX512 1
#define RTK_AVX(name) avx512_##name
#define RTK_TARGET_AVX __attribute__((target("avx2,avx512f,avx512vl")))
#include "bvh_wide.c"
#undef RTK_TARGET_AVX
#undef RTK_AVX
#undef RTK_AVX512
#undef RTK_WIDE_AVX_PASS

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

#else /* RTK_WIDE_AVX_PASS: the AVX node loop, read once per target (above) */

/* Leaves out of line: the node loop keeps its registers. One per mode,
 * so that occlusion carries none of closest hit's bookkeeping; occlusion
 * comes here only in scenes with cutouts (otherwise the node loop tests a
 * leaf's first block itself and calls leaf_any_rest for the rest). */
static __attribute__((noinline)) RTK_TARGET_AVX int RTK_AVX(leaf_any)(const rtk_scene *s, const rtk_wide_bvh *w,
                                                                      uint32_t ref, const tri_ray *r,
                                                                      const rtk_ray *ray, rtk_trace_work *work)
{
    return leaf_test(s, w, ref, r, ray, NULL, 1, work);
}

/* Occlusion's leaf after its first block, tested in the node loop,
 * found no hit: that block's lanes left to the scalar test (scalar), then
 * the leaf's other blocks. Only without cutouts. */
static __attribute__((noinline)) RTK_TARGET_AVX int RTK_AVX(leaf_any_rest)(const rtk_scene *s,
                                                                           const rtk_wide_tris *b,
                                                                           const rtk_wide_tris *end, int scalar,
                                                                           const tri_ray *r, const rtk_ray *ray,
                                                                           rtk_trace_work *work)
{
    for (; scalar; scalar &= scalar - 1) {
        float st, su, sv;
        if (lane_scalar(b, __builtin_ctz((unsigned)scalar), ray, ray->tmax, &st, &su, &sv))
            return 1;
    }
    return blocks_test(s, b + 1, end, r, ray, NULL, 1, work);
}

static __attribute__((noinline)) RTK_TARGET_AVX int RTK_AVX(leaf_closest)(const rtk_scene *s,
                                                                          const rtk_wide_bvh *w, uint32_t ref,
                                                                          const tri_ray *r, const rtk_ray *ray,
                                                                          rtk_hit *hit, rtk_trace_work *work)
{
    return leaf_test(s, w, ref, r, ray, hit, 0, work);
}

/* The box test's reductions: for occlusion integer max and min of the
 * bit patterns (box_int_note), one cycle of latency each where the float
 * ones take two or more; for closest hit the float ones (box_reduce_note:
 * the integer ones took it 1.02-1.04 times as long, measured the same
 * way). */
RTK_INLINE RTK_TARGET_AVX __m256 RTK_AVX(max8)(__m256 a, __m256 b, int in)
{
    return in ? _mm256_castsi256_ps(_mm256_max_epi32(_mm256_castps_si256(a), _mm256_castps_si256(b)))
              : _mm256_max_ps(a, b);
}
RTK_INLINE RTK_TARGET_AVX __m256 RTK_AVX(min8)(__m256 a, __m256 b, int in)
{
    return in ? _mm256_castsi256_ps(_mm256_min_epi32(_mm256_castps_si256(a), _mm256_castps_si256(b)))
              : _mm256_min_ps(a, b);
}

/* Occlusion only for rays where box_int_ok holds (the callers below; the
 * others go to the SSE path). */
RTK_INLINE RTK_TARGET_AVX int RTK_AVX(traverse)(const rtk_scene *s, const rtk_ray *ray, rtk_hit *hit, int any,
                                                rtk_trace_work *work)
{
    const rtk_wide_bvh *w = s->wide;
    if (!any)
        hit_reset(hit, ray);
    wide_ray p;
    wide_prepare(ray, &p);
    tri_ray tr;
    int tri_ready = 0;
    const __m256 ox = _mm256_set1_ps(p.org[0]), oy = _mm256_set1_ps(p.org[1]), oz = _mm256_set1_ps(p.org[2]);
    const __m256 ix = _mm256_set1_ps(p.ninv[0]), iy = _mm256_set1_ps(p.ninv[1]), iz = _mm256_set1_ps(p.ninv[2]);
    const __m256 fx = _mm256_set1_ps(p.ninv_far[0]), fy = _mm256_set1_ps(p.ninv_far[1]),
                 fz = _mm256_set1_ps(p.ninv_far[2]);
    /* + 0: -0 becomes +0 (box_int_note). */
    const __m256 tmin8 = _mm256_set1_ps(ray->tmin + 0.0f);
    /* Entry rows; the exit row of an axis is its entry row ^ 1. */
    const size_t nx = (size_t)p.near[0] * RTK_WIDE, ny = (size_t)p.near[1] * RTK_WIDE,
                 nz = (size_t)p.near[2] * RTK_WIDE;
    const rtk_wide_node *nodes = w->nodes;
    float tmax_w = widen(any ? ray->tmax : hit->t);
    __m256 tmax8 = _mm256_set1_ps(tmax_w);
    stack_entry stack[RTK_WIDE_STACK];
    /* Occlusion's stack: references only, and room for a whole store of
     * eight past the deepest push. */
    uint32_t refs[RTK_WIDE_STACK + RTK_WIDE];
#if !RTK_AVX512
    const __m256i lane_shift = _mm256_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21);
#endif
    int top = 0;
    /* Occlusion's last pushed children, pcount of them, kept in a
     * register and popped from it, highest lane first (the order of the
     * stack): a leaf that misses is mostly followed by a pop of the
     * children its parent just pushed, which from memory waits for the
     * store. */
    __m256i pend = _mm256_setzero_si256();
    int pcount = 0;
    uint32_t cur = 0;
    for (;;) {
        while (!(cur & RTK_WIDE_LEAF)) {
            const rtk_wide_node *n = wide_node_at(nodes, cur);
            const float *bb = &n->bounds[0][0];
            if (work)
                work->nodes++;
            __m256 tnx = _mm256_mul_ps(_mm256_sub_ps(ox, _mm256_load_ps(bb + nx)), ix);
            __m256 tny = _mm256_mul_ps(_mm256_sub_ps(oy, _mm256_load_ps(bb + ny)), iy);
            __m256 tnz = _mm256_mul_ps(_mm256_sub_ps(oz, _mm256_load_ps(bb + nz)), iz);
            __m256 tfx = _mm256_mul_ps(_mm256_sub_ps(ox, _mm256_load_ps(bb + (nx ^ RTK_WIDE))), fx);
            __m256 tfy = _mm256_mul_ps(_mm256_sub_ps(oy, _mm256_load_ps(bb + (ny ^ RTK_WIDE))), fy);
            __m256 tfz = _mm256_mul_ps(_mm256_sub_ps(oz, _mm256_load_ps(bb + (nz ^ RTK_WIDE))), fz);
            /* See box_reduce_note and box_int_note. */
            __m256 t0 = RTK_AVX(max8)(RTK_AVX(max8)(tny, tnz, any), RTK_AVX(max8)(tnx, tmin8, any), any);
            __m256 t1 = RTK_AVX(min8)(RTK_AVX(min8)(tfy, tfz, any), RTK_AVX(min8)(tfx, tmax8, any), any);
#if RTK_AVX512
            uint32_t mask = (uint32_t)_mm256_cmp_ps_mask(t0, t1, _CMP_LE_OQ); /* no trip through a vector */
#else
            uint32_t mask = (uint32_t)_mm256_movemask_ps(_mm256_cmp_ps(t0, t1, _CMP_LE_OQ));
#endif
            if (mask == 0)
                goto pop;
            if (any) {
                /* See pack_lanes. No prefetch of the next pop: occlusion's
                 * rays are short and end early, so a prefetch costs
                 * more than it hides. */
                const __m256i kids = _mm256_load_si256((const __m256i *)(const void *)n->child);
#if RTK_AVX512
                /* The hit children but the lowest, packed in one instruction. */
                const __m256i packed = _mm256_maskz_compress_epi32((__mmask8)(mask & (mask - 1)), kids);
#else
                const __m256i lanes = _mm256_and_si256(
                    _mm256_srlv_epi32(_mm256_set1_epi32((int)pack_lanes[mask]), lane_shift), _mm256_set1_epi32(7));
                const __m256i packed = _mm256_permutevar8x32_epi32(kids, lanes);
#endif
                /* The previous node's children go to memory, this one's
                 * stay in a register (see pend). */
                _mm256_storeu_si256((__m256i *)(void *)&refs[top], pend);
                top += pcount;
                pend = packed;
                pcount = __builtin_popcount(mask) - 1;
                cur = n->child[__builtin_ctz(mask)];
            } else if ((mask & (mask - 1)) == 0) {
                cur = n->child[__builtin_ctz(mask)];
            } else {
                float dist[RTK_WIDE];
                _mm256_storeu_ps(dist, t0);
                cur = push_sorted(n, mask, dist, stack, &top);
                /* The next pop, while the nearer child is traversed. */
                uint32_t next = stack[top - 1].ref;
                if (!(next & RTK_WIDE_LEAF)) {
                    const char *pf = (const char *)wide_node_at(nodes, next);
                    _mm_prefetch(pf, _MM_HINT_T0);
                    _mm_prefetch(pf + 64, _MM_HINT_T0);
                    _mm_prefetch(pf + 128, _MM_HINT_T0);
                    _mm_prefetch(pf + 192, _MM_HINT_T0);
                }
            }
        }
        if (!tri_ready) {
            tri_prepare(ray, &tr);
            tri_ready = 1;
        }
        if (any && !s->has_cutouts) {
            /* Most leaves are one block and most blocks miss: the first
             * block here, the rest (and lanes for the scalar test) out of
             * line. */
            const rtk_wide_tris *end;
            const rtk_wide_tris *b = leaf_blocks(w, cur, &end);
            count_block(b, work);
            __m128 t, u, v;
            int scalar;
            if (tri_test4(b, &tr, ray->tmin, ray->tmax, &t, &u, &v, &scalar, 1))
                return 1;
            if ((scalar || b + 1 < end) && RTK_AVX(leaf_any_rest)(s, b, end, scalar, &tr, ray, work))
                return 1;
        } else if (any ? RTK_AVX(leaf_any)(s, w, cur, &tr, ray, work)
                       : RTK_AVX(leaf_closest)(s, w, cur, &tr, ray, hit, work)) {
            if (any)
                return 1;
            tmax_w = widen(hit->t);
            tmax8 = _mm256_set1_ps(tmax_w);
        }
    pop:
        if (any) {
            if (pcount) {
                pcount--;
                cur = (uint32_t)_mm256_cvtsi256_si32(_mm256_permutevar8x32_epi32(pend, _mm256_set1_epi32(pcount)));
                continue;
            }
            if (top == 0)
                return 0;
            cur = refs[--top];
            continue;
        }
        do {
            if (top == 0)
                return hit->prim != RTK_INVALID_ID;
            --top;
        } while (stack[top].t > tmax_w);
        cur = stack[top].ref;
    }
}

static RTK_TARGET_AVX int RTK_AVX(closest)(const rtk_scene *s, const rtk_ray *r, rtk_hit *h)
{
    return RTK_AVX(traverse)(s, r, h, 0, NULL);
}
static RTK_TARGET_AVX int RTK_AVX(any)(const rtk_scene *s, const rtk_ray *r)
{
    return box_int_ok(r) ? RTK_AVX(traverse)(s, r, NULL, 1, NULL) : sse_any(s, r);
}
static RTK_TARGET_AVX int RTK_AVX(closest_work)(const rtk_scene *s, const rtk_ray *r, rtk_hit *h,
                                                rtk_trace_work *wk)
{
    return RTK_AVX(traverse)(s, r, h, 0, wk);
}
static RTK_TARGET_AVX int RTK_AVX(any_work)(const rtk_scene *s, const rtk_ray *r, rtk_trace_work *wk)
{
    return box_int_ok(r) ? RTK_AVX(traverse)(s, r, NULL, 1, wk) : sse_any_work(s, r, wk);
}

#endif

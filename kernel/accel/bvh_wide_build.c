/* The wide BVH's build (see bvh_wide.h): the binary tree collapsed into
 * 8-wide nodes by a cost plan over each binary subtree, triangles packed
 * four to a leaf block (structure of arrays), large trees collapsed on
 * threads with a result independent of their number, and on the way the
 * checks of the binary tree's structure and leaf boxes. The traversal of
 * what this builds is bvh_wide_trace.c. */
#include "accel.h"
#include "slab.h"

#include <assert.h>
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#if RTK_HAVE_X86
#include <immintrin.h>
#endif

uint32_t rtk_wide_node_limit = RTK_WIDE_MAX_NODES;
/* Blocks a leaf reference addresses: the first block's index takes the
 * bits above RTK_WIDE_LEAF_SHIFT. */
#define WIDE_MAX_BLOCKS (1u << (31 - RTK_WIDE_LEAF_SHIFT))

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
    uint32_t count, workers;
    uint32_t next; /* rtk_take_run's */
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
    /* Frontier subtrees lie in slot order: taken one at a time, neighbours
     * would write the same lines of the plan and the checks' marks. */
    for (uint32_t first, run; ok && (run = rtk_take_run(&job->next, job->count, job->workers, &first)) > 0;)
        for (uint32_t i = first; ok && i < first + run; i++)
            ok = plan_walk(job->c, &w, job->ids[i], PLAN_FRONTIER, UINT32_MAX, NULL, NULL,
                           &job->costs[RTK_WIDE * (size_t)i]);
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
            job.ids = ids, job.costs = costs, job.count = count, job.workers = threads, job.next = 0;
            atomic_init(&job.failed, 0);
            rtk_parallel_ranges(threads, threads, 1, plan_worker, &job);
            ok = !atomic_load(&job.failed);
        }
    }
    if (ok)
        ok = plan_walk(c, &w, 0, 0, count ? PLAN_FRONTIER : UINT32_MAX, costs, &next, root);
    if (ok && c->check) {
        rtk_tree_tally_add(&w.tally, &job.covered, &job.reached, &job.max_depth);
        ok = rtk_tree_check_whole(c->check, job.reached, job.covered, threads);
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
    int ok = rtk_tree_check_init(&check, s->nodes, s->node_count, s->prim_ids, s->triangle_count, threads + 1, threads);
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
    /* Phases as they run here: the plan's walks split below PLAN_FRONTIER
     * on large trees; the items' passes on workers threads. */
    rtk_build_log *log = s->build_log;
    rtk_build_log_mark(log, validate ? "wide: plan and validation" : "wide: plan",
                       threads > 1 && s->node_count >= PLAN_PARALLEL_NODES, 0);
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
        rtk_build_log_mark(log, "wide: top nodes", 0, 0);
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
            rtk_build_log_mark(log, "wide: counting", workers > 1, 0);
            rtk_parallel_ranges(workers, workers, 1, count_worker, &job);
            rtk_build_log_mark(log, "wide: arrays", 0, 0);
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
            rtk_build_log_mark(log, "wide: collapse and leaves", workers > 1, 0);
            rtk_parallel_ranges(workers, workers, 1, wide_worker, &job);
            rtk_build_log_mark(log, "wide: links", 0, 0);
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

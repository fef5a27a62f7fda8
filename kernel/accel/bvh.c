/* The kernel's BVH: ray/box tests (the ray/triangle test is isect.h's),
 * robust ray offsets, closest-hit and any-hit traversal, and the checked
 * hand-off to builder plugins. Builders only emit nodes; everything here
 * is shared by all. */
#include "accel.h"
#include "two_level.h"

#include <assert.h>
#include <float.h>
#include <math.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#include <stddef.h>
#include <stdlib.h>
#include <string.h>


RTK_API int rtk_intersect_triangle(const rtk_ray *ray, rtk_vec3 a, rtk_vec3 b, rtk_vec3 c, float *t_out,
                                   float *u_out, float *v_out)
{
    return rtk_isect_triangle(ray, a, b, c, t_out, u_out, v_out);
}

RTK_API rtk_vec3 rtk_offset_ray_origin(rtk_vec3 p, rtk_vec3 n)
{
    return rtk_offset_point(p, n);
}

int rtk_ray_valid(const rtk_ray *r)
{
    return rtk_ray_usable(r);
}

/* The binary traversals' leaf test: the triangle in leaf slot slot of
 * scene ctx, dropped where an alpha cut-out makes the hit transparent. */
static int leaf_hit(const void *ctx, uint32_t slot, const rtk_ray *ray, float *t, float *u, float *v)
{
    const rtk_scene *s = ctx;
    float tv[9];
    rtk_slot_corners(s, slot, tv);
    return rtk_intersect_triangle(ray, rtk_vec3_make(tv[0], tv[1], tv[2]), rtk_vec3_make(tv[3], tv[4], tv[5]),
                                  rtk_vec3_make(tv[6], tv[7], tv[8]), t, u, v) &&
           (!s->has_cutouts || rtk_alpha_opaque(s, ray, s->prim_ids[slot], *u, *v));
}

/* Closest hit on the binary tree; counts into work when not NULL. */
static inline __attribute__((always_inline)) int binary_closest(const rtk_scene *s, const rtk_ray *ray,
                                                                 rtk_hit *hit, rtk_trace_work *work)
{
    return s->node_count ? rtk_slab_closest(s->nodes, s->prim_ids, leaf_hit, s, ray, hit, work) : 0;
}

/* Any hit on the binary tree; counts into work when not NULL. */
static inline __attribute__((always_inline)) int binary_any(const rtk_scene *s, const rtk_ray *ray,
                                                             rtk_trace_work *work)
{
    return s->node_count ? rtk_slab_any(s->nodes, leaf_hit, s, ray, work) : 0;
}

/* The wide tree serves rays with tmin >= 0 (its box test widens exit
 * distances through the reciprocal, which assumes it); the binary tree
 * the rest, and everything when RTK_SIMD=binary. A plugin's own traversal
 * takes every ray. */
static int use_wide(const rtk_scene *s, const rtk_ray *ray)
{
    return s->wide && s->wide->path != RTK_SIMD_BINARY && ray->tmin >= 0.0f && !s->own_traversal;
}

int rtk_bvh_closest_own(const rtk_scene *s, const rtk_ray *ray, rtk_hit *hit, rtk_trace_work *work)
{
    if (work)
        work->nodes = work->triangles = 0;
    if (use_wide(s, ray))
        return rtk_wide_closest(s, s->wide->path, ray, hit, work);
    hit->prim = RTK_INVALID_ID;
    hit->t = ray->tmax;
    hit->u = hit->v = 0.0f;
    if (s->own_traversal)
        return s->own_traversal->closest(s->own_state, ray, hit) && hit->prim < s->triangle_count;
    return work ? binary_closest(s, ray, hit, work) : binary_closest(s, ray, hit, NULL);
}

int rtk_bvh_any_own(const rtk_scene *s, const rtk_ray *ray, rtk_trace_work *work)
{
    if (work)
        work->nodes = work->triangles = 0;
    if (s->own_traversal)
        return s->own_traversal->any(s->own_state, ray);
    if (use_wide(s, ray))
        return rtk_wide_any(s, s->wide->path, ray, work);
    return work ? binary_any(s, ray, work) : binary_any(s, ray, NULL);
}

int rtk_bvh_closest(const rtk_scene *s, const rtk_ray *ray, rtk_hit *hit)
{
    if (s->instance_count)
        return rtk_instances_closest(s, ray, hit, NULL);
    hit->inst = RTK_INVALID_ID;
    if (use_wide(s, ray))
        return rtk_wide_closest_path[s->wide->path](s, ray, hit);
    return rtk_bvh_closest_own(s, ray, hit, NULL);
}

int rtk_bvh_any(const rtk_scene *s, const rtk_ray *ray)
{
    if (s->instance_count)
        return rtk_instances_any(s, ray, NULL);
    if (use_wide(s, ray))
        return rtk_wide_any_path[s->wide->path](s, ray);
    return rtk_bvh_any_own(s, ray, NULL);
}

/* The plugin's batch functions when its table has them (ABI 3.4). */
static int own_batch(const rtk_accelerator_fns *f)
{
    return f->size >= offsetof(rtk_accelerator_fns, any_batch) + sizeof f->any_batch && f->closest_batch &&
           f->any_batch;
}

/* rtk_bvh_closest_batch (occluded NULL) or rtk_bvh_any_batch (hits
 * NULL): a device's or the plugin's batch functions, else runs of rays the wide tree
 * serves (use_wide, no instances) through its batches, the others one
 * at a time. */
static void bvh_batch(const rtk_scene *s, const rtk_ray *rays, uint32_t count, rtk_hit *hits, uint8_t *occluded)
{
    const rtk_accelerator_fns *batcher = s->device ? s->device
                                         : s->own_traversal && own_batch(s->own_traversal) ? s->own_traversal
                                                                                          : NULL;
    void *state = s->device ? s->device_state : s->own_state;
    if (batcher && (!s->instance_count || s->device)) {
        if (occluded) {
            batcher->any_batch(state, rays, count, occluded);
            for (uint32_t i = 0; i < count; i++)
                occluded[i] = occluded[i] != 0;
            return;
        }
        for (uint32_t i = 0; i < count; i++) {
            hits[i].prim = hits[i].inst = RTK_INVALID_ID;
            hits[i].t = rays[i].tmax;
            hits[i].u = hits[i].v = 0.0f;
        }
        batcher->closest_batch(state, rays, count, hits);
        /* Whatever comes back names a triangle that exists, or none. */
        for (uint32_t i = 0; i < count; i++) {
            rtk_hit *h = &hits[i];
            if (!s->device || h->inst == RTK_INVALID_ID)
                h->inst = RTK_INVALID_ID;
            else if (h->inst >= s->instance_count)
                h->prim = RTK_INVALID_ID;
            const uint32_t triangles = h->inst == RTK_INVALID_ID || h->inst >= s->instance_count
                                           ? s->triangle_count
                                           : s->meshes[s->instances[h->inst].mesh]->triangle_count;
            if (h->prim >= triangles)
                h->prim = h->inst = RTK_INVALID_ID;
        }
        return;
    }
    for (uint32_t i = 0; i < count;) {
        uint32_t end = i;
        while (end < count && !s->instance_count && use_wide(s, &rays[end]))
            end++;
        if (end == i) {
            if (occluded)
                occluded[i] = (uint8_t)(rtk_bvh_any(s, &rays[i]) != 0);
            else if (!rtk_bvh_closest(s, &rays[i], &hits[i]))
                hits[i].prim = RTK_INVALID_ID;
            i++;
        } else if (occluded) {
            rtk_wide_any_batch(s, s->wide->path, rays + i, end - i, occluded + i);
            i = end;
        } else {
            rtk_wide_closest_batch(s, s->wide->path, rays + i, end - i, hits + i);
            for (; i < end; i++)
                hits[i].inst = RTK_INVALID_ID;
        }
    }
}

void rtk_bvh_closest_batch(const rtk_scene *s, const rtk_ray *rays, uint32_t count, rtk_hit *hits)
{
    bvh_batch(s, rays, count, hits, NULL);
}

void rtk_bvh_any_batch(const rtk_scene *s, const rtk_ray *rays, uint32_t count, uint8_t *occluded)
{
    bvh_batch(s, rays, count, NULL, occluded);
}

int rtk_bvh_closest_measure(const rtk_scene *s, const rtk_ray *ray, rtk_hit *hit, rtk_trace_work *work)
{
    if (s->instance_count)
        return rtk_instances_closest(s, ray, hit, work);
    hit->inst = RTK_INVALID_ID;
    return rtk_bvh_closest_own(s, ray, hit, work);
}

int rtk_bvh_any_measure(const rtk_scene *s, const rtk_ray *ray, rtk_trace_work *work)
{
    if (s->instance_count)
        return rtk_instances_any(s, ray, work);
    return rtk_bvh_any_own(s, ray, work);
}

static int box_contains(const float lo[3], const float hi[3], const float clo[3], const float chi[3])
{
    for (int k = 0; k < 3; k++)
        if (!(lo[k] <= clo[k] && chi[k] <= hi[k]))
            return 0;
    return 1;
}

/* Node p's box encloses node c's (box_contains; any NaN fails), and
 * whether node n's bounds hold a NaN: in SSE, a node's lower corner and
 * its offset, then its upper corner and its count, each one 16-byte load
 * whose fourth lane is ignored. */
#if defined(__SSE2__)
static int node_encloses(const rtk_bvh_node *p, const rtk_bvh_node *c)
{
    const float *pf = (const float *)(const void *)p, *cf = (const float *)(const void *)c;
    __m128 ok = _mm_and_ps(_mm_cmple_ps(_mm_loadu_ps(pf), _mm_loadu_ps(cf)),
                           _mm_cmple_ps(_mm_loadu_ps(cf + 4), _mm_loadu_ps(pf + 4)));
    return (_mm_movemask_ps(ok) & 7) == 7;
}

static int node_has_nan(const rtk_bvh_node *n)
{
    const float *f = (const float *)(const void *)n;
    return (_mm_movemask_ps(_mm_cmpunord_ps(_mm_loadu_ps(f), _mm_loadu_ps(f + 4))) & 7) != 0;
}
#else
static int node_encloses(const rtk_bvh_node *p, const rtk_bvh_node *c)
{
    return box_contains(p->lower, p->upper, c->lower, c->upper);
}

static int node_has_nan(const rtk_bvh_node *n)
{
    int nan = 0;
    for (int k = 0; k < 3; k++)
        nan |= isnan(n->lower[k]) || isnan(n->upper[k]);
    return nan;
}
#endif
static_assert(offsetof(rtk_bvh_node, offset) == 12 && offsetof(rtk_bvh_node, upper) == 16 &&
                   offsetof(rtk_bvh_node, count) == 28,
               "node_encloses reads a corner and the word after it as four floats");

/* One walk of validation: from a node down, marking what it meets. Quiet
 * walks (on threads) report only that something is wrong; a loud walk
 * says what, through rtk_error. Marks of nodes and slots are relaxed
 * atomics: walks on threads meet the same byte only in a broken tree,
 * which the counts and the final scan then catch (see rtk_bvh_validate).
 * Primitives, met in no order, are marked in a bit set of the walk's own
 * (bytes shared by threads would pass cache lines back and forth). */
typedef struct tree_walk {
    const rtk_build_args *a;
    int leaf_bounds, quiet;
    rtk_tree_check check;
    rtk_tree_tally tally;
    uint32_t stop_depth;             /* inner nodes this deep are left in roots (0: none) */
    uint32_t *roots, root_count;     /* (node, depth) pairs left for the threads */
} tree_walk;

#define VALIDATION_ROOTS_DEPTH 8 /* up to 128 subtrees for the threads */

static int mark(uint8_t *seen)
{
    uint8_t was = __atomic_load_n(seen, __ATOMIC_RELAXED);
    __atomic_store_n(seen, 1, __ATOMIC_RELAXED);
    return was;
}

/* Sets bit i of bits; returns whether it was set. */
static int mark_bit(uint64_t *bits, uint32_t i)
{
    const uint64_t bit = 1ull << (i & 63);
    const int was = (bits[i >> 6] & bit) != 0;
    bits[i >> 6] |= bit;
    return was;
}

int rtk_tree_check_init(rtk_tree_check *c, const rtk_bvh_node *nodes, uint32_t node_count, const uint32_t *prim_order,
                        uint32_t prim_count, uint32_t sets, uint32_t threads)
{
    memset(c, 0, sizeof *c);
    c->nodes = nodes, c->node_count = node_count;
    c->prim_order = prim_order, c->prim_count = prim_count;
    c->words = ((size_t)prim_count + 63) / 64;
    c->sets = sets;
    /* One block (rtk_alloc_zeroed: marks are read before they are set),
     * bit sets first (8-byte words), then the byte marks. */
    const size_t words = c->words * sets + 1;
    uint8_t *block = rtk_alloc_zeroed(sizeof *c->prim_bits * words + (size_t)node_count + prim_count + 2, 1, threads);
    if (!block)
        return 0;
    c->prim_bits = (uint64_t *)(void *)block;
    c->seen_node = block + sizeof *c->prim_bits * words;
    c->seen_slot = c->seen_node + node_count + 1;
    return 1;
}

void rtk_tree_check_free(rtk_tree_check *c)
{
    free(c->prim_bits);
    c->seen_node = c->seen_slot = NULL;
    c->prim_bits = NULL;
}

void rtk_tree_tally_init(const rtk_tree_check *c, uint32_t set, rtk_tree_tally *t)
{
    memset(t, 0, sizeof *t);
    t->prim_bits = c->prim_bits + (size_t)set * c->words;
}

/* The checks of one node, in order; the first that fails is returned,
 * with the slot or child concerned in *what. */
enum {
    FAULT_NONE,
    FAULT_TWICE,    /* reached before */
    FAULT_DEPTH,    /* deeper than RTK_BVH_MAX_DEPTH */
    FAULT_NAN,      /* NaN bounds */
    FAULT_RANGE,    /* leaf slots past the primitives */
    FAULT_SLOT,     /* slot *what (or its primitive) met twice or out of range */
    FAULT_CHILDREN, /* children outside 1 .. node_count - 1 */
    FAULT_ENCLOSE,  /* child *what outside the node's box */
};

static int check_node(const rtk_tree_check *c, rtk_tree_tally *t, uint32_t id, uint32_t depth, uint32_t *what)
{
    const rtk_bvh_node *n = &c->nodes[id];
    if (mark(&c->seen_node[id]))
        return FAULT_TWICE;
    t->reached++;
    if (depth > t->max_depth)
        t->max_depth = depth;
    if (depth > RTK_BVH_MAX_DEPTH)
        return FAULT_DEPTH;
    if (node_has_nan(n))
        return FAULT_NAN;
    if (n->count > 0) {
        if (n->offset > c->prim_count || n->count > c->prim_count - n->offset)
            return FAULT_RANGE;
        for (uint32_t i = n->offset; i < n->offset + n->count; i++) {
            uint32_t prim = c->prim_order[i];
            if (mark(&c->seen_slot[i]) || prim >= c->prim_count || mark_bit(t->prim_bits, prim)) {
                *what = i;
                return FAULT_SLOT;
            }
        }
        t->covered += n->count;
        return FAULT_NONE;
    }
    if (n->offset == 0 || n->offset >= c->node_count - 1)
        return FAULT_CHILDREN;
    for (uint32_t k = n->offset; k <= n->offset + 1; k++) {
        if (!node_encloses(n, &c->nodes[k])) {
            *what = k;
            return FAULT_ENCLOSE;
        }
    }
    return FAULT_NONE;
}

int rtk_tree_check_node(const rtk_tree_check *c, rtk_tree_tally *t, uint32_t id, uint32_t depth)
{
    uint32_t what;
    return check_node(c, t, id, depth, &what) == FAULT_NONE;
}

#define WALK_FAIL(...) return w->quiet ? RTK_ERR_PLUGIN : rtk_error(RTK_ERR_PLUGIN, __VA_ARGS__)

/* stack: 2 * (RTK_BVH_MAX_DEPTH + 2) entries. */
static rtk_status walk_tree(tree_walk *w, uint32_t root, uint32_t root_depth, uint32_t *stack)
{
    const rtk_build_args *a = w->a;
    int top = 0;
    stack[top++] = root, stack[top++] = root_depth; /* pairs (node, depth) */
    while (top > 0) {
        uint32_t depth = stack[--top], id = stack[--top];
        const rtk_bvh_node *n = &a->nodes[id];
        if (depth == w->stop_depth && n->count == 0) {
            w->roots[w->root_count++] = id, w->roots[w->root_count++] = depth;
            continue;
        }
        uint32_t what = 0;
        switch (check_node(&w->check, &w->tally, id, depth, &what)) {
        case FAULT_NONE:
            break;
        case FAULT_TWICE:
            WALK_FAIL("builder output: node %u is reached twice (the tree has a cycle or shared node)", id);
        case FAULT_DEPTH:
            WALK_FAIL("builder output: tree deeper than %d levels", RTK_BVH_MAX_DEPTH);
        case FAULT_NAN:
            WALK_FAIL("builder output: node %u has NaN bounds", id);
        case FAULT_RANGE:
            WALK_FAIL("builder output: leaf %u covers slots %u..%u beyond %u primitives", id, n->offset,
                      n->offset + n->count - 1, a->prim_count);
        case FAULT_SLOT:
            WALK_FAIL("builder output: slot %u (primitive %u) is referenced twice or out of range", what,
                      a->prim_order[what]);
        case FAULT_CHILDREN:
            WALK_FAIL("builder output: inner node %u points to children %u, %u outside 1 .. %u", id, n->offset,
                      n->offset + 1, a->node_count - 1);
        default:
            WALK_FAIL("builder output: node %u does not enclose its child %u", id, what);
        }
        if (n->count > 0) {
            for (uint32_t i = n->offset; w->leaf_bounds && i < n->offset + n->count; i++) {
                const uint32_t prim = a->prim_order[i];
                const rtk_bounds *b = &a->prim_bounds[prim];
                const float plo[3] = {b->lower.x, b->lower.y, b->lower.z};
                const float phi[3] = {b->upper.x, b->upper.y, b->upper.z};
                if (!box_contains(n->lower, n->upper, plo, phi))
                    WALK_FAIL("builder output: leaf %u does not enclose primitive %u", id, prim);
            }
        } else {
            stack[top++] = n->offset, stack[top++] = depth + 1;
            stack[top++] = n->offset + 1, stack[top++] = depth + 1;
        }
    }
    return RTK_OK;
}

#undef WALK_FAIL

/* The subtrees left by the top walk, taken in runs by the threads
 * (rtk_take_run: neighbours mark neighbouring bytes). */
typedef struct walk_job {
    const tree_walk *top;
    uint32_t next, workers;               /* the next root pair, atomic; threads */
    uint32_t max_depth, covered, reached; /* sums and maximum, atomic */
    int failed;                           /* atomic */
} walk_job;

void rtk_tree_tally_add(const rtk_tree_tally *t, uint32_t *covered, uint32_t *reached, uint32_t *max_depth)
{
    __atomic_fetch_add(covered, t->covered, __ATOMIC_RELAXED);
    __atomic_fetch_add(reached, t->reached, __ATOMIC_RELAXED);
    uint32_t seen = __atomic_load_n(max_depth, __ATOMIC_RELAXED);
    while (t->max_depth > seen &&
           !__atomic_compare_exchange_n(max_depth, &seen, t->max_depth, 0, __ATOMIC_RELAXED, __ATOMIC_RELAXED))
        ;
}

static void walk_worker(void *ctx, uint32_t begin, uint32_t end)
{
    (void)end;
    walk_job *j = ctx;
    uint32_t stack[2 * (RTK_BVH_MAX_DEPTH + 2)];
    tree_walk w = *j->top;
    w.stop_depth = 0, w.roots = NULL, w.root_count = 0, w.quiet = 1;
    rtk_tree_tally_init(&w.check, begin + 1, &w.tally);
    const uint32_t pairs = j->top->root_count / 2;
    int ok = 1;
    for (uint32_t first, run; ok && !__atomic_load_n(&j->failed, __ATOMIC_RELAXED) &&
                              (run = rtk_take_run(&j->next, pairs, j->workers, &first)) > 0;)
        for (uint32_t k = first; ok && k < first + run; k++)
            ok = walk_tree(&w, j->top->roots[2 * k], j->top->roots[2 * k + 1], stack) == RTK_OK;
    if (!ok)
        __atomic_store_n(&j->failed, 1, __ATOMIC_RELAXED);
    rtk_tree_tally_add(&w.tally, &j->covered, &j->reached, &j->max_depth);
}

static int all_set(const uint8_t *seen, uint32_t n)
{
    /* Marks are 0 or 1: eight at a time (a byte loop is not vectorised
     * at -O2, 5 instructions a byte). */
    uint64_t all = 0x0101010101010101ull;
    uint32_t i = 0;
    for (; i + 8 <= n; i += 8) {
        uint64_t word;
        memcpy(&word, seen + i, sizeof word);
        all &= word;
    }
    uint8_t tail = 1;
    for (; i < n; i++)
        tail &= seen[i];
    return all == 0x0101010101010101ull && tail;
}

/* Whether words [k0, k1) of the sets of bits (count of them, words each)
 * are disjoint and together hold every one of bits 0 .. n - 1 there (and
 * none above). */
static int bits_partition(const uint64_t *bits, uint32_t count, size_t words, uint32_t n, size_t k0, size_t k1)
{
    uint64_t overlap = 0, missing = 0;
    for (size_t k = k0; k < k1; k++) {
        uint64_t all = 0;
        for (uint32_t t = 0; t < count; t++) {
            overlap |= all & bits[t * words + k];
            all |= bits[t * words + k];
        }
        const uint32_t left = n - (uint32_t)(64 * k);
        missing |= all ^ (left >= 64 ? ~0ull : (1ull << left) - 1);
    }
    return !overlap && !missing;
}

/* The end scan in pieces over threads: WHOLE_PIECE marks of the nodes,
 * then of the slots, then WHOLE_PIECE / 8 words of every bit set. */
#define WHOLE_PIECE 65536u
typedef struct whole_job {
    const rtk_tree_check *c;
    uint32_t node_pieces, slot_pieces;
    int bad; /* atomic */
} whole_job;

static void whole_range(void *ctx, uint32_t begin, uint32_t end)
{
    whole_job *j = ctx;
    const rtk_tree_check *c = j->c;
    int ok = 1;
    for (uint32_t p = begin; ok && p < end; p++) {
        if (p < j->node_pieces) {
            const uint32_t at = p * WHOLE_PIECE, left = c->node_count - at;
            ok = all_set(c->seen_node + at, left < WHOLE_PIECE ? left : WHOLE_PIECE);
        } else if (p < j->node_pieces + j->slot_pieces) {
            const uint32_t at = (p - j->node_pieces) * WHOLE_PIECE, left = c->prim_count - at;
            ok = all_set(c->seen_slot + at, left < WHOLE_PIECE ? left : WHOLE_PIECE);
        } else {
            const size_t k0 = (size_t)(p - j->node_pieces - j->slot_pieces) * (WHOLE_PIECE / 8);
            const size_t k1 = k0 + WHOLE_PIECE / 8 < c->words ? k0 + WHOLE_PIECE / 8 : c->words;
            ok = bits_partition(c->prim_bits, c->sets, c->words, c->prim_count, k0, k1);
        }
    }
    if (!ok)
        __atomic_store_n(&j->bad, 1, __ATOMIC_RELAXED);
}

int rtk_tree_check_whole(const rtk_tree_check *c, uint32_t reached, uint32_t covered, uint32_t threads)
{
    if (reached != c->node_count || covered != c->prim_count)
        return 0;
    whole_job j = {c, (c->node_count + WHOLE_PIECE - 1) / WHOLE_PIECE, (c->prim_count + WHOLE_PIECE - 1) / WHOLE_PIECE,
                   0};
    const uint32_t pieces = j.node_pieces + j.slot_pieces + (uint32_t)((c->words + WHOLE_PIECE / 8 - 1) / (WHOLE_PIECE / 8));
    rtk_parallel_ranges(pieces, threads, 4, whole_range, &j);
    return !j.bad;
}

/* Below this many nodes the walk stays on one thread. */
#define VALIDATION_PARALLEL_NODES 16384u

/* RTK_ERR_PLUGIN (error set) unless a builder's node_count is 1 .. max_nodes. */
static rtk_status check_node_count(const rtk_build_args *a)
{
    if (a->node_count == 0 || a->node_count > a->max_nodes)
        return rtk_error(RTK_ERR_PLUGIN, "builder returned %u nodes (expected 1 .. %u)", a->node_count,
                         a->max_nodes);
    return RTK_OK;
}

rtk_status rtk_bvh_validate(const rtk_build_args *a, int leaf_bounds, uint32_t *depth_out)
{
    if (check_node_count(a) != RTK_OK)
        return RTK_ERR_PLUGIN;
    tree_walk w;
    memset(&w, 0, sizeof w);
    w.a = a, w.leaf_bounds = leaf_bounds;
    int parallel = a->thread_count > 1 && a->node_count >= VALIDATION_PARALLEL_NODES;
    const uint32_t threads = a->thread_count < RTK_TREE_CHECK_MAX_SETS - 1 ? a->thread_count
                                                                           : RTK_TREE_CHECK_MAX_SETS - 1;
    uint32_t *stack = rtk_alloc(sizeof(uint32_t) * 2 * (RTK_BVH_MAX_DEPTH + 2));
    uint32_t roots[2 << VALIDATION_ROOTS_DEPTH];
    rtk_status st = RTK_OK;
    if (!stack || !rtk_tree_check_init(&w.check, a->nodes, a->node_count, a->prim_order, a->prim_count,
                                       parallel ? threads + 1 : 1, parallel ? threads : 1)) {
        st = RTK_ERR_NOMEM;
        goto done;
    }
    rtk_tree_tally_init(&w.check, 0, &w.tally);
    if (parallel) {
        /* The top levels here, quietly; the subtrees below on threads.
         * In a sound tree the walks meet no byte twice, and every node,
         * slot and primitive is marked once: the counts equal the totals
         * and no mark is missing. Anything else (a shared node or slot
         * two threads both took for new included) fails one of those, and
         * the walk is done again on one thread for the message. */
        w.quiet = 1, w.stop_depth = VALIDATION_ROOTS_DEPTH, w.roots = roots;
        int ok = walk_tree(&w, 0, 1, stack) == RTK_OK;
        if (ok) {
            walk_job job = {&w, 0, threads, w.tally.max_depth, w.tally.covered, w.tally.reached, 0};
            rtk_parallel_ranges(threads, threads, 1, walk_worker, &job);
            ok = !job.failed && rtk_tree_check_whole(&w.check, job.reached, job.covered, threads);
            w.tally.max_depth = job.max_depth;
        }
        if (ok) {
            *depth_out = w.tally.max_depth;
            goto done;
        }
        memset(w.check.seen_node, 0, a->node_count);
        memset(w.check.seen_slot, 0, a->prim_count);
        memset(w.check.prim_bits, 0, w.check.words * sizeof *w.check.prim_bits);
        rtk_tree_tally_init(&w.check, 0, &w.tally);
    }
    w.quiet = 0, w.stop_depth = 0, w.roots = NULL, w.root_count = 0;
    st = walk_tree(&w, 0, 1, stack);
    if (st != RTK_OK)
        goto done;
    if (w.tally.covered != a->prim_count) {
        st = rtk_error(RTK_ERR_PLUGIN, "builder output: leaves hold %u of %u primitives", w.tally.covered,
                       a->prim_count);
        goto done;
    }
    if (w.tally.reached != a->node_count) {
        st = rtk_error(RTK_ERR_PLUGIN, "builder output: %u of the %u nodes reported are not reachable from the root "
                       "(node_count must count the nodes of the tree only)", a->node_count - w.tally.reached,
                       a->node_count);
        goto done;
    }
    if (parallel) { /* the threads saw a fault one thread does not: never */
        st = rtk_error(RTK_ERR_PLUGIN, "builder output: the tree failed validation on threads only");
        goto done;
    }
    *depth_out = w.tally.max_depth;
done:
    rtk_tree_check_free(&w.check);
    free(stack);
    return st;
}

rtk_status rtk_bvh_validate_scene(const rtk_scene *s, uint32_t threads, uint32_t *depth)
{
    rtk_build_args a;
    memset(&a, 0, sizeof a);
    a.size = sizeof a;
    a.nodes = s->nodes;
    a.node_count = s->node_count;
    a.max_nodes = s->triangle_count ? 2 * s->triangle_count - 1 : 0;
    a.prim_order = s->prim_ids;
    a.prim_count = s->triangle_count;
    a.thread_count = threads ? threads : 1;
    return rtk_bvh_validate(&a, 0, depth);
}

void rtk_bvh_release(rtk_scene *s)
{
    rtk_device_release(s);
    rtk_wide_free(s);
    if (s->own_traversal && s->own_state)
        s->own_traversal->destroy(s->own_state);
    s->own_traversal = NULL;
    s->own_state = NULL;
}

/* Exchanges scene s's tree with slot's. */
static void swap_tree(rtk_scene *s, rtk_tree_slot *slot)
{
    const rtk_tree_slot mine = {s->nodes,        s->node_count,  s->bvh_depth,    s->prim_ids,
                                s->own_traversal, s->own_state,  s->wide,         s->device,
                                s->device_state,  s->device_data, s->device_lights, s->device_minor};
    s->nodes = slot->nodes, s->node_count = slot->node_count, s->bvh_depth = slot->bvh_depth;
    s->prim_ids = slot->prim_ids;
    s->own_traversal = slot->own_traversal, s->own_state = slot->own_state;
    s->wide = slot->wide;
    s->device = slot->device, s->device_state = slot->device_state, s->device_data = slot->device_data;
    s->device_lights = slot->device_lights, s->device_minor = slot->device_minor;
    *slot = mine;
}

rtk_status rtk_accel_set_init(rtk_accel_set *set, const rtk_scene *s)
{
    memset(set, 0, sizeof *set);
    set->trees = rtk_calloc((size_t)s->mesh_count + 1, sizeof *set->trees);
    if (!set->trees)
        return RTK_ERR_NOMEM;
    set->tree_count = s->mesh_count + 1;
    return RTK_OK;
}

void rtk_accel_swap(rtk_scene *s, rtk_accel_set *set)
{
    for (uint32_t i = 0; i < set->tree_count && i <= s->mesh_count; i++)
        swap_tree(i == 0 ? s : s->meshes[i - 1], &set->trees[i]);
    rtk_bvh_node *nodes = s->tlas_nodes;
    uint32_t count = s->tlas_node_count, depth = s->tlas_depth, *order = s->tlas_order;
    s->tlas_nodes = set->tlas_nodes, s->tlas_node_count = set->tlas_node_count, s->tlas_depth = set->tlas_depth;
    s->tlas_order = set->tlas_order;
    set->tlas_nodes = nodes, set->tlas_node_count = count, set->tlas_depth = depth, set->tlas_order = order;
}

void rtk_accel_set_free(rtk_accel_set *set)
{
    for (uint32_t i = 0; i < set->tree_count; i++) {
        rtk_tree_slot *t = &set->trees[i];
        rtk_wide_destroy(t->wide);
        if (t->own_traversal && t->own_state)
            t->own_traversal->destroy(t->own_state);
        if (t->device && t->device_state)
            t->device->destroy(t->device_state);
        free(t->device_data);
        free(t->nodes);
        free(t->prim_ids);
    }
    free(set->trees);
    free(set->tlas_nodes);
    free(set->tlas_order);
    memset(set, 0, sizeof *set);
}

/* The plugin's own traversal functions, if its table is new enough to
 * have them and sets both. */
static const rtk_accelerator_fns *own_traversal(const rtk_accelerator_fns *fns)
{
    if (fns->size < offsetof(rtk_accelerator_fns, any) + sizeof fns->any)
        return NULL;
    return fns->closest && fns->any ? fns : NULL;
}

int rtk_accelerator_traverses_itself(const rtk_plugin *accelerator)
{
    return own_traversal(accelerator->functions) != NULL;
}

uint32_t rtk_accelerator_build_flags(const rtk_plugin *accelerator)
{
    const rtk_accelerator_fns *fns = accelerator->functions;
    return fns->size >= offsetof(rtk_accelerator_fns, build_flags) + sizeof fns->build_flags ? fns->build_flags : 0;
}

/* The builder's inputs (corners, bounds, centroids of every triangle),
 * split over threads. */
typedef struct prep_job {
    const rtk_scene *s;
    rtk_bounds *bounds;
    rtk_vec3 *centroids;
    rtk_vec3 *vertices;
} prep_job;

/* Positions are finite (the scene checks them), so plain comparisons
 * give fminf / fmaxf without their calls. */
#define RTK_MINF(a, b) ((b) < (a) ? (b) : (a))
#define RTK_MAXF(a, b) ((b) > (a) ? (b) : (a))

static void prep_range(void *ctx, uint32_t begin, uint32_t end)
{
    const prep_job *j = ctx;
    const uint32_t *indices = j->s->indices;
    const float *positions = j->s->positions;
    for (uint32_t i = begin; i < end; i++) {
        const uint32_t *idx = indices + 3 * (size_t)i;
        const float *p = positions + 3 * (size_t)idx[0], *q = positions + 3 * (size_t)idx[1],
                    *r = positions + 3 * (size_t)idx[2];
        if (j->vertices) {
            memcpy(j->vertices + 3 * (size_t)i, p, 3 * sizeof(float));
            memcpy(j->vertices + 3 * (size_t)i + 1, q, 3 * sizeof(float));
            memcpy(j->vertices + 3 * (size_t)i + 2, r, 3 * sizeof(float));
        }
        if (!j->bounds)
            continue;
#if defined(__SSE2__)
        /* A corner is one 16-byte load (a float more follows the last
         * vertex); the boxes and centroid go out as 8 + 4 bytes each, so
         * that no store reaches past its own triangle's (another thread
         * may own the next). The same operations as below, lane by lane. */
        const __m128 a = _mm_loadu_ps(p), b = _mm_loadu_ps(q), c = _mm_loadu_ps(r);
        /* RTK_MINF(a, b) is _mm_min_ps(b, a), ties (+0 and -0) to a */
        const __m128 lo = _mm_min_ps(c, _mm_min_ps(b, a)), hi = _mm_max_ps(c, _mm_max_ps(b, a));
        const __m128 mid = _mm_mul_ps(_mm_add_ps(lo, hi), _mm_set1_ps(0.5f));
#define RTK_STORE3(dst, val) \
    (_mm_storel_pi((__m64 *)(void *)&(dst).x, val), _mm_store_ss(&(dst).z, _mm_movehl_ps(val, val)))
        RTK_STORE3(j->bounds[i].lower, lo);
        RTK_STORE3(j->bounds[i].upper, hi);
        RTK_STORE3(j->centroids[i], mid);
#undef RTK_STORE3
#else
        /* Scalars, not arrays filled in a loop: the boxes' 8-byte stores
         * then read registers, not two 4-byte stores on the stack, which
         * the CPU cannot forward (a stall of every triangle). */
        const float lx = RTK_MINF(RTK_MINF(p[0], q[0]), r[0]), hx = RTK_MAXF(RTK_MAXF(p[0], q[0]), r[0]);
        const float ly = RTK_MINF(RTK_MINF(p[1], q[1]), r[1]), hy = RTK_MAXF(RTK_MAXF(p[1], q[1]), r[1]);
        const float lz = RTK_MINF(RTK_MINF(p[2], q[2]), r[2]), hz = RTK_MAXF(RTK_MAXF(p[2], q[2]), r[2]);
        j->bounds[i].lower = rtk_vec3_make(lx, ly, lz);
        j->bounds[i].upper = rtk_vec3_make(hx, hy, hz);
        j->centroids[i] = rtk_vec3_make((lx + hx) * 0.5f, (ly + hy) * 0.5f, (lz + hz) * 0.5f);
#endif
    }
}

void rtk_bvh_prepare_inputs(const rtk_scene *s, uint32_t threads, rtk_bounds *bounds, rtk_vec3 *centroids,
                            rtk_vec3 *vertices)
{
    prep_job prep = {s, bounds, centroids, vertices};
    rtk_parallel_ranges(s->triangle_count, threads, 8192, prep_range, &prep);
}

/* Every leaf's box against its triangles' corners: the check validation
 * skips. */
typedef struct leaf_check {
    const rtk_scene *s;
    uint32_t bad_node; /* lowest failing node (UINT32_MAX: none) */
} leaf_check;

/* The first slot of leaf n of s whose corners leave its box, or the end. */
static uint32_t first_outside(const rtk_scene *s, const rtk_bvh_node *n)
{
    uint32_t slot = n->offset;
    for (; slot < n->offset + n->count; slot++) {
        float v[9];
        rtk_slot_corners(s, slot, v);
        int inside = 1;
        for (int k = 0; k < 9; k++)
            inside &= n->lower[k % 3] <= v[k] && v[k] <= n->upper[k % 3];
        if (!inside)
            break;
    }
    return slot;
}

static void leaf_check_range(void *ctx, uint32_t begin, uint32_t end)
{
    leaf_check *c = ctx;
    for (uint32_t id = begin; id < end; id++) {
        const rtk_bvh_node *n = &c->s->nodes[id];
        if (n->count == 0 || first_outside(c->s, n) == n->offset + n->count)
            continue;
        /* Ranges run concurrently: keep the lowest node, as one thread
         * would report. */
        uint32_t seen = __atomic_load_n(&c->bad_node, __ATOMIC_RELAXED);
        while (id < seen &&
               !__atomic_compare_exchange_n(&c->bad_node, &seen, id, 0, __ATOMIC_RELAXED, __ATOMIC_RELAXED))
            ;
        return;
    }
}

rtk_status rtk_bvh_leaf_error(const rtk_scene *s, uint32_t leaf)
{
    return rtk_error(RTK_ERR_PLUGIN, "builder output: leaf %u does not enclose primitive %u", leaf,
                     s->prim_ids[first_outside(s, &s->nodes[leaf])]);
}

rtk_status rtk_bvh_check_leaves(const rtk_scene *s, uint32_t threads)
{
    leaf_check c = {s, UINT32_MAX};
    rtk_parallel_ranges(s->node_count, threads, 65536, leaf_check_range, &c);
    return c.bad_node == UINT32_MAX ? RTK_OK : rtk_bvh_leaf_error(s, c.bad_node);
}

rtk_status rtk_bvh_finish(rtk_scene *s, uint32_t threads, void *spare, size_t spare_bytes, int validated)
{
    rtk_status st;
    if (s->own_traversal) {
        free(spare);
    } else {
        st = rtk_wide_build(s, threads, spare, spare_bytes, !validated);
        if (st == RTK_OK || st == RTK_ERR_PLUGIN)
            return st;
        rtk_warn_once("wide BVH", "%s; tracing the binary tree", rtk_error_message());
    }
    if (!validated) {
        rtk_build_log_mark(s->build_log, "kernel: validation",
                           threads > 1 && s->node_count >= VALIDATION_PARALLEL_NODES, 0);
        if ((st = rtk_bvh_validate_scene(s, threads, &s->bvh_depth)) != RTK_OK)
            return st;
    }
    rtk_build_log_mark(s->build_log, "kernel: leaf check", rtk_ranges_parallel(s->node_count, threads, 65536), 0);
    return rtk_bvh_check_leaves(s, threads);
}

/* rtk_bvh_build, its phases marked in s->build_log (opened by the caller). */
static rtk_status build_tree(rtk_scene *s, const rtk_plugin *plugin, const rtk_params *params, uint32_t threads)
{
    rtk_build_log *log = s->build_log;
    rtk_build_log_mark(log, "kernel: allocate", 0, 0);
    rtk_bvh_release(s);
    free(s->nodes);
    free(s->prim_ids);
    s->nodes = NULL, s->prim_ids = NULL;
    s->node_count = 0, s->bvh_depth = 0;
    uint32_t n = s->triangle_count;
    if (n == 0)
        return RTK_OK;
    if (n > (UINT32_MAX - 1) / 2)
        return rtk_error(RTK_ERR_NOMEM, "%u triangles are more than one BVH can index", n);
    rtk_build_args a;
    memset(&a, 0, sizeof a);
    a.size = sizeof a;
    a.prim_count = n;
    a.max_nodes = 2 * n - 1;
    a.thread_count = threads ? threads : 1;
    double t0 = rtk_now();
    /* The builder's inputs (bounds, centroids, corners: 72 bytes a
     * triangle) share one block, dead once the tree is built: the wide
     * tree is written there, in memory already faulted in rather than in
     * a fresh array (first touches are costly). Only what the builder
     * reads is computed (RTK_BUILD_NO_*: the block keeps its size, for the
     * wide tree); a builder that reads none of it gets the whole block as
     * scratch, and an accelerator that traverses itself no block at all. */
    const rtk_accelerator_fns *fns = plugin->functions;
    const uint32_t flags = rtk_accelerator_build_flags(plugin);
    const int want_bounds = !(flags & RTK_BUILD_NO_BOUNDS), want_vertices = !(flags & RTK_BUILD_NO_VERTICES);
    const size_t input_bytes = (sizeof(rtk_bounds) + sizeof(rtk_vec3) * 4) * (size_t)n;
    const int want_block = want_bounds || want_vertices || !own_traversal(fns);
    char *inputs = want_block ? rtk_alloc_large(input_bytes) : NULL;
    rtk_bounds *bounds = inputs && want_bounds ? (rtk_bounds *)(void *)inputs : NULL;
    rtk_vec3 *centroids = bounds ? (rtk_vec3 *)(void *)(inputs + sizeof(rtk_bounds) * (size_t)n) : NULL;
    rtk_vec3 *vertices =
        inputs && want_vertices ? (rtk_vec3 *)(void *)(inputs + (sizeof(rtk_bounds) + sizeof(rtk_vec3)) * (size_t)n)
                                : NULL;
    /* Not cleared: a builder writes the nodes it reports and every slot of
     * prim_order, and validation reads nothing else, so clearing would be pure cost. */
    /* Node arrays over 32 MiB, glibc's largest threshold for mapping an
     * allocation of its own, are fresh memory every build: in huge pages
     * (rtk_alloc_large), they fault 512 times less often (the showroom's
     * 141 MB: 16,000 faults a build, 1.6 us each on a virtual machine),
     * unless the builder on threads leaves most of them unwritten
     * (RTK_BUILD_SPARSE_NODES: one that fills a fifth of each subtree's
     * region would have all 141 MB faulted in). Smaller arrays come
     * back from the heap already faulted in, and aligned there they
     * faulted more (bunny, elephant). */
    const size_t node_bytes = sizeof *a.nodes * (size_t)a.max_nodes;
    const int huge_nodes =
        node_bytes >= RTK_FRESH_ALLOC_BYTES && (a.thread_count == 1 || !(flags & RTK_BUILD_SPARSE_NODES));
    a.nodes = huge_nodes ? rtk_alloc_large(node_bytes) : rtk_alloc(node_bytes);
    a.prim_order = rtk_alloc(sizeof *a.prim_order * (size_t)n);
    rtk_status st = RTK_OK;
    void *state = NULL;
    if ((want_block && !inputs) || !a.nodes || !a.prim_order) {
        st = RTK_ERR_NOMEM;
        goto fail;
    }
    if (bounds || vertices) {
        rtk_build_log_mark(log, "kernel: builder inputs", rtk_ranges_parallel(n, a.thread_count, 8192), 0);
        rtk_bvh_prepare_inputs(s, a.thread_count, bounds, centroids, vertices);
    }
    a.prim_bounds = bounds;
    double t1 = rtk_now();
    a.centroids = centroids;
    a.vertices = vertices;
    a.indices = s->indices;
    a.positions = s->positions;
    a.vertex_count = s->vertex_count;
    if (inputs && !vertices) {
        /* The block's unused part (the corners', or all of it): the
         * builder's scratch, faulted in once for it and the wide tree after. */
        const size_t at = bounds ? ((sizeof(rtk_bounds) + sizeof(rtk_vec3)) * (size_t)n + 63) / 64 * 64 : 0;
        if (at < input_bytes)
            a.scratch = inputs + at, a.scratch_bytes = input_bytes - at;
    }
    a.phase_log = log;
    rtk_build_log_mark(log, "builder: create", 0, 0);
    st = fns->create(params, &state);
    if (st != RTK_OK) {
        char msg[2048];
        snprintf(msg, sizeof msg, "%s", rtk_error_message());
        st = rtk_error(st, "accelerator '%s' failed to start: %s", plugin->name, msg);
        goto fail;
    }
    /* Until the builder's first mark (all of a builder that marks none):
     * on how many threads is its own affair. */
    rtk_build_log_mark(log, "builder: unmarked", a.thread_count > 1 ? -1 : 0, 0);
    st = fns->build(state, &a);
    rtk_build_log_mark(log, own_traversal(fns) && a.node_count == 0 ? "kernel: free inputs" : "kernel: trim nodes",
                       0, 0);
    const rtk_accelerator_fns *own = own_traversal(fns);
    if (st != RTK_OK || !own)
        fns->destroy(state);
    if (st != RTK_OK) {
        char msg[2048];
        snprintf(msg, sizeof msg, "%s", rtk_error_message());
        st = rtk_error(st, "accelerator '%s' failed: %s", plugin->name, msg);
        goto fail;
    }
    if (own && s->has_cutouts)
        rtk_warn_once("own traversal cutouts", "accelerator '%s' traverses with its own code, which does not test "
                      "alpha: cutout materials (foliage, fences) render as solid; pick median, sah or lbvh to see "
                      "through them", plugin->name);
    if (own) {
        /* The plugin answers every trace; a tree it also emitted is checked
         * and kept for statistics only. */
        s->own_traversal = own;
        s->own_state = state;
        if (a.node_count == 0) {
            free(inputs);
            free(a.nodes);
            free(a.prim_order);
            rtk_log(RTK_LOG_DEBUG, "BVH build (%s, %u threads): %u triangles, own traversal (inputs %.2f ms, builder %.2f ms)",
                    plugin->name, a.thread_count, n, 1e3 * (t1 - t0), 1e3 * (rtk_now() - t1));
            return RTK_OK;
        }
    }
    double t2 = rtk_now();
    /* The structure is validated as the wide tree plans its collapse, the
     * leaves' boxes against the corners as it gathers them. */
    st = check_node_count(&a);
    if (st == RTK_OK) {
        /* The capacity past the tree, in huge pages a builder on threads
         * may have touched (its gaps, closed): back to the system. */
        if (huge_nodes)
            rtk_release_tail(a.nodes, sizeof *a.nodes * (size_t)a.node_count, node_bytes);
        s->nodes = a.nodes;
        s->node_count = a.node_count;
        s->prim_ids = a.prim_order;
        st = rtk_bvh_finish(s, a.thread_count, inputs, input_bytes, 0);
        inputs = NULL; /* taken */
        if (st != RTK_OK) {
            s->nodes = NULL, s->prim_ids = NULL;
            s->node_count = 0, s->bvh_depth = 0;
        }
    }
    if (st == RTK_ERR_PLUGIN) {
        char msg[2048];
        snprintf(msg, sizeof msg, "%s", rtk_error_message());
        st = rtk_error(st, "accelerator '%s' produced an invalid tree: %s", plugin->name, msg);
    }
    if (st != RTK_OK)
        goto fail;
    rtk_log(RTK_LOG_DEBUG,
            "BVH build (%s, %u threads): %u triangles, %u nodes (inputs %.2f ms, builder %.2f ms, "
            "wide tree with validation and leaf check %.2f ms)",
            plugin->name, a.thread_count, n, s->node_count, 1e3 * (t1 - t0), 1e3 * (t2 - t1), 1e3 * (rtk_now() - t2));
    return RTK_OK;
fail:
    rtk_bvh_release(s);
    free(inputs);
    free(a.nodes);
    free(a.prim_order);
    return st;
}

rtk_status rtk_bvh_build(rtk_scene *s, const rtk_plugin *plugin, const rtk_params *params, uint32_t threads)
{
    if (rtk_accelerator_is_device(plugin))
        return rtk_device_build(s, plugin, params, threads, NULL, NULL);
    rtk_build_log_begin(s->build_log);
    rtk_status st = build_tree(s, plugin, params, threads);
    rtk_build_log_end(s->build_log);
    return st;
}

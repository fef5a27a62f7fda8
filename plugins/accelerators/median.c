/* median: top-down BVH build splitting each node at the median, either of
 * the primitives (object median: equal counts) or of the centroid bounds
 * (spatial median: equal extents), along the widest centroid axis.
 *
 * Parameters:
 *   mode      string object|spatial  object  where to split
 *   max_leaf  int [1, 64]            4       primitives per leaf at most
 *
 * Example: accelerator = { plugin = "median"; mode = "spatial"; max_leaf = 2; };
 *
 * The top levels are split level by level, each level's ranges on the
 * build's threads, down to subtrees of at most TASK_PRIMS primitives,
 * which the threads then take in turn, each into the worst-case span of
 * nodes it may need; the spans are then closed up in order. The cut does
 * not depend on the thread count, so neither does the tree.
 */
#include <rtk/rtk.h>

#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

/* Subtrees of at most this many primitives are built as tasks. */
#define TASK_PRIMS 8192u

typedef struct median {
    int spatial;
    uint32_t max_leaf;
} median;

/* A pending node: its index and the slots [begin, end) it covers. */
typedef struct range {
    uint32_t node, begin, end;
} range;

/* A primitive as the build moves it: its centroid and id side by side, so
 * that each pass streams through memory instead of chasing ids. */
typedef struct item {
    float c[3];
    uint32_t id;
} item;

static rtk_status median_create(const rtk_params *params, void **state)
{
    median *m = malloc(sizeof *m);
    if (!m)
        return rtk_error(RTK_ERR_NOMEM, "median: out of memory");
    m->spatial = strcmp(rtk_params_string(params, "mode"), "spatial") == 0;
    m->max_leaf = (uint32_t)rtk_params_int(params, "max_leaf");
    *state = m;
    return RTK_OK;
}

static void swap_items(item *a, item *b)
{
    item t = *a;
    *a = *b;
    *b = t;
}

/* Reorders it[begin, end) so that the k-th smallest centroid along axis
 * sits at k, smaller ones before it (quickselect; ties by id keep the
 * result deterministic). */
static void select_kth(item *it, uint32_t begin, uint32_t end, uint32_t k, int axis)
{
    while (end - begin > 1) {
        uint32_t mid = begin + (end - begin) / 2;
        item pivot = it[mid];
        float pv = pivot.c[axis];
        it[mid] = it[end - 1];
        it[end - 1] = pivot;
        uint32_t store = begin;
        for (uint32_t i = begin; i < end - 1; i++) {
            float v = it[i].c[axis];
            if (v < pv || (v == pv && it[i].id < pivot.id))
                swap_items(&it[i], &it[store++]);
        }
        it[end - 1] = it[store];
        it[store] = pivot;
        if (store == k)
            return;
        if (k < store)
            end = store;
        else
            begin = store + 1;
    }
}

/* The boxes of nodes [from, to), children before parents (they come
 * after them in nodes, or were set already): a leaf's from its
 * primitives, an inner node's the union of its two children's, which is
 * the same box. */
static void set_bounds(const rtk_build_args *a, uint32_t from, uint32_t to)
{
    for (uint32_t k = to; k-- > from;) {
        rtk_bvh_node *n = &a->nodes[k];
        float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        if (n->count > 0) {
            for (uint32_t i = n->offset; i < n->offset + n->count; i++) {
                const rtk_bounds *b = &a->prim_bounds[a->prim_order[i]];
                lo[0] = fminf(lo[0], b->lower.x), lo[1] = fminf(lo[1], b->lower.y), lo[2] = fminf(lo[2], b->lower.z);
                hi[0] = fmaxf(hi[0], b->upper.x), hi[1] = fmaxf(hi[1], b->upper.y), hi[2] = fmaxf(hi[2], b->upper.z);
            }
        } else {
            const rtk_bvh_node *l = &a->nodes[n->offset], *r = &a->nodes[n->offset + 1];
            for (int j = 0; j < 3; j++) {
                lo[j] = fminf(l->lower[j], r->lower[j]);
                hi[j] = fmaxf(l->upper[j], r->upper[j]);
            }
        }
        memcpy(n->lower, lo, sizeof lo);
        memcpy(n->upper, hi, sizeof hi);
    }
}

/* Where r splits: at the median slot along the widest centroid axis
 * (object), or at the middle of the centroid bounds (spatial, unless every
 * centroid is on one side of it); reorders it[r.begin, r.end) to match. */
static uint32_t split_at(const median *m, item *it, range r)
{
    float clo[3] = {INFINITY, INFINITY, INFINITY}, chi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t i = r.begin; i < r.end; i++)
        for (int k = 0; k < 3; k++) {
            clo[k] = fminf(clo[k], it[i].c[k]);
            chi[k] = fmaxf(chi[k], it[i].c[k]);
        }
    int axis = 0;
    for (int k = 1; k < 3; k++)
        if (chi[k] - clo[k] > chi[axis] - clo[axis])
            axis = k;
    uint32_t split = r.begin + (r.end - r.begin) / 2;
    if (m->spatial && chi[axis] > clo[axis]) {
        float mid = 0.5f * (clo[axis] + chi[axis]);
        uint32_t i = r.begin, j = r.end;
        while (i < j) {
            if (it[i].c[axis] < mid)
                i++;
            else
                swap_items(&it[i], &it[--j]);
        }
        if (i > r.begin && i < r.end)
            return i;
    }
    select_kth(it, r.begin, r.end, split, axis);
    return split;
}

/* Splits root's range depth-first down to leaves, children pairs taken
 * from *used on. */
static void grow(const median *m, item *it, rtk_bvh_node *nodes, uint32_t *used, range root)
{
    /* The stack never exceeds the tree depth, which object-median splits
     * keep at log2(n) + 1; a deeper spatial split ends in a leaf. */
    range stack[128];
    uint32_t top = 0;
    stack[top++] = root;
    while (top > 0) {
        range r = stack[--top];
        rtk_bvh_node *n = &nodes[r.node];
        uint32_t count = r.end - r.begin;
        if (count <= m->max_leaf || top + 2 > 128) {
            n->offset = r.begin;
            n->count = count;
            continue;
        }
        uint32_t split = split_at(m, it, r), left = *used;
        *used += 2;
        n->offset = left;
        n->count = 0;
        stack[top++] = (range){left + 1, split, r.end};
        stack[top++] = (range){left, r.begin, split};
    }
}

/* One level of the top: ranges that split, shared by the threads. */
typedef struct level {
    const median *m;
    item *it;
    const range *ranges;
    uint32_t *splits;
    uint32_t count;
    atomic_uint next;
} level;

static void split_level(void *ctx, rtk_team *team, uint32_t index, uint32_t size)
{
    (void)team, (void)index, (void)size;
    level *l = ctx;
    for (uint32_t i; (i = atomic_fetch_add(&l->next, 1)) < l->count;)
        l->splits[i] = split_at(l->m, l->it, l->ranges[i]);
}

/* The tasks, shared by the build's threads. */
typedef struct crew {
    const median *m;
    rtk_build_args *a;
    item *it;
    const range *tasks;
    uint32_t *span;  /* task i's nodes start at span[i], at most 2 x its primitives - 2 */
    uint32_t *built; /* nodes task i used */
    atomic_uint next;
    uint32_t count;
} crew;

/* Builds tasks until none is left: the subtree, its slots of prim_order
 * and the boxes of the nodes below its root. */
static void work(void *ctx, rtk_team *team, uint32_t index, uint32_t size)
{
    (void)team, (void)index, (void)size;
    crew *c = ctx;
    for (uint32_t i; (i = atomic_fetch_add(&c->next, 1)) < c->count;) {
        range r = c->tasks[i];
        uint32_t used = c->span[i];
        grow(c->m, c->it, c->a->nodes, &used, r);
        c->built[i] = used - c->span[i];
        for (uint32_t k = r.begin; k < r.end; k++)
            c->a->prim_order[k] = c->it[k].id;
        set_bounds(c->a, c->span[i], used);
    }
}

/* Moves task i's nodes down from its span to base, its inner nodes' (and
 * its root's) child offsets with them. */
static void close_up(rtk_build_args *a, const range *task, uint32_t span, uint32_t built, uint32_t base)
{
    uint32_t shift = span - base;
    if (shift == 0)
        return;
    memmove(&a->nodes[base], &a->nodes[span], sizeof *a->nodes * built);
    for (uint32_t k = base; k < base + built; k++)
        if (a->nodes[k].count == 0)
            a->nodes[k].offset -= shift;
    if (a->nodes[task->node].count == 0)
        a->nodes[task->node].offset -= shift;
}

/* The top levels end at depth TOP_DEPTH, where a range becomes a leaf;
 * a task's own depth-first build adds at most 128 more. */
#define TOP_DEPTH 120u

static rtk_status median_build(void *state, rtk_build_args *a)
{
    const median *m = state;
    rtk_build_phase(a, "median: root split", 0);
    uint32_t n = a->prim_count, threads = a->thread_count < 1 ? 1 : a->thread_count;
    size_t bytes = sizeof(item) * (size_t)n, wide = 2 * (size_t)(n / TASK_PRIMS) + 2;
    item *it = rtk_build_scratch(a, bytes), *own = NULL;
    if (!it)
        it = own = malloc(bytes);
    /* Ranges of more than TASK_PRIMS at one level: fewer than n / TASK_PRIMS. */
    range *cur = malloc(sizeof *cur * wide), *nxt = malloc(sizeof *nxt * wide), *tasks = NULL;
    uint32_t *splits = malloc(sizeof *splits * wide), *span = NULL, *built = NULL, task_count = 0, task_cap = 0;
    int ok = it && cur && nxt && splits;
    if (ok)
        for (uint32_t i = 0; i < n; i++)
            it[i] = (item){{a->centroids[i].x, a->centroids[i].y, a->centroids[i].z}, i};

    /* The top, level by level: each level's ranges split on the threads,
     * their children numbered in order after. */
    uint32_t ncur = 1, used = 1;
    if (ok)
        cur[0] = (range){0, 0, n};
    for (uint32_t depth = 0; ok && ncur > 0; depth++) {
        uint32_t nsplit = 0;
        for (uint32_t i = 0; i < ncur && ok; i++) {
            range r = cur[i];
            uint32_t count = r.end - r.begin;
            if (count <= m->max_leaf || depth >= TOP_DEPTH) {
                a->nodes[r.node].offset = r.begin;
                a->nodes[r.node].count = count;
            } else if (count <= TASK_PRIMS) {
                if (task_count == task_cap) {
                    uint32_t cap = task_cap ? 2 * task_cap : 64;
                    range *t = realloc(tasks, sizeof *t * cap);
                    ok = t != NULL;
                    if (t)
                        tasks = t, task_cap = cap;
                }
                if (ok)
                    tasks[task_count++] = r;
            } else {
                cur[nsplit++] = r;
            }
        }
        level l = {.m = m, .it = it, .ranges = cur, .splits = splits, .count = nsplit};
        atomic_init(&l.next, 0);
        rtk_team_run(threads < nsplit ? threads : nsplit, split_level, &l);
        if (depth == 0)
            rtk_build_phase(a, "median: top levels", threads > 1);
        uint32_t nnext = 0;
        for (uint32_t i = 0; i < nsplit; i++) {
            range r = cur[i];
            a->nodes[r.node].offset = used;
            a->nodes[r.node].count = 0;
            nxt[nnext++] = (range){used, r.begin, splits[i]};
            nxt[nnext++] = (range){used + 1, splits[i], r.end};
            used += 2;
        }
        range *t = cur;
        cur = nxt, nxt = t, ncur = nnext;
    }
    if (ok && task_count) {
        span = malloc(sizeof *span * task_count);
        built = malloc(sizeof *built * task_count);
        ok = span && built;
    }
    if (!ok) {
        free(own), free(cur), free(nxt), free(splits), free(tasks), free(span), free(built);
        return rtk_error(RTK_ERR_NOMEM, "median: out of memory");
    }
    uint32_t top_used = used, next = used;
    for (uint32_t i = 0; i < task_count; i++) {
        span[i] = next;
        next += 2 * (tasks[i].end - tasks[i].begin) - 2;
    }

    rtk_build_phase(a, "median: subtrees", threads > 1 && task_count > 1);
    crew c = {.m = m, .a = a, .it = it, .tasks = tasks, .span = span, .built = built, .count = task_count};
    atomic_init(&c.next, 0);
    rtk_team_run(threads < task_count ? threads : task_count, work, &c);

    rtk_build_phase(a, "median: close gaps", 0);
    for (uint32_t i = 0; i < task_count; i++) {
        close_up(a, &tasks[i], span[i], built[i], used);
        used += built[i];
    }
    /* The top levels' own leaves, then their boxes over the tasks' roots. */
    for (uint32_t k = 0; k < top_used; k++) {
        const rtk_bvh_node *node = &a->nodes[k];
        for (uint32_t i = node->offset; node->count > 0 && i < node->offset + node->count; i++)
            a->prim_order[i] = it[i].id;
    }
    set_bounds(a, 0, top_used);
    free(own), free(cur), free(nxt), free(splits), free(tasks), free(span), free(built);
    a->node_count = used;
    return RTK_OK;
}

static void median_destroy(void *state)
{
    free(state);
}

static const rtk_param_desc median_params[] = {
    {.name = "mode", .type = RTK_PARAM_STRING, .def_string = "object", .choices = "object|spatial",
     .doc = "object: split at the median primitive; spatial: at the middle of the centroid bounds"},
    {.name = "max_leaf", .type = RTK_PARAM_INT, .def = 4, .min = 1, .max = 64,
     .doc = "largest number of primitives in a leaf"},
};

static const rtk_accelerator_fns median_fns = {
    .size = sizeof(rtk_accelerator_fns),
    .create = median_create,
    .build = median_build,
    .destroy = median_destroy,
    .build_flags = RTK_BUILD_NO_VERTICES,
};

static const rtk_plugin median_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_ACCELERATOR,
    .name = "median",
    .version = "1.0",
    .summary = "median-split BVH (object or spatial median of centroids)",
    .params = median_params,
    .param_count = RTK_COUNTOF(median_params),
    .functions = &median_fns,
};

RTK_PLUGIN_ENTRY(median_plugin)

/* median: top-down BVH build splitting each node at the median, either of
 * the primitives (object median: equal counts) or of the centroid bounds
 * (spatial median: equal extents), along the widest centroid axis.
 *
 * Parameters:
 *   mode      string object|spatial  object  where to split
 *   max_leaf  int [1, 64]            4       primitives per leaf at most
 *
 * Example: accelerator = { plugin = "median"; mode = "spatial"; max_leaf = 2; };
 */
#include <rtk/rtk.h>

#include <math.h>
#include <stdlib.h>
#include <string.h>

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

/* Every node's box, children before parents (they come after them in
 * nodes): a leaf's from its primitives, an inner node's the union of its
 * two children's, which is the same box. */
static void set_bounds(const rtk_build_args *a, uint32_t used)
{
    for (uint32_t k = used; k-- > 0;) {
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

static rtk_status median_build(void *state, rtk_build_args *a)
{
    const median *m = state;
    rtk_build_phase(a, "median: tree", 0);
    size_t bytes = sizeof(item) * (size_t)a->prim_count;
    item *it = rtk_build_scratch(a, bytes), *own = NULL;
    if (!it)
        it = own = malloc(bytes);
    /* Depth-first with an explicit stack; it never exceeds the tree depth,
     * which object-median splits keep at log2(n) + 1. */
    range *stack = malloc(sizeof *stack * 128);
    if (!it || !stack) {
        free(own), free(stack);
        return rtk_error(RTK_ERR_NOMEM, "median: out of memory");
    }
    for (uint32_t i = 0; i < a->prim_count; i++)
        it[i] = (item){{a->centroids[i].x, a->centroids[i].y, a->centroids[i].z}, i};
    uint32_t top = 0, used = 1;
    stack[top++] = (range){0, 0, a->prim_count};
    while (top > 0) {
        range r = stack[--top];
        rtk_bvh_node *n = &a->nodes[r.node];
        uint32_t count = r.end - r.begin;
        if (count <= m->max_leaf || top + 2 > 128) {
            n->offset = r.begin;
            n->count = count;
            continue;
        }
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
        uint32_t split = r.begin + count / 2;
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
                split = i;
            else /* all centroids on one side of the middle: object median */
                select_kth(it, r.begin, r.end, split, axis);
        } else {
            select_kth(it, r.begin, r.end, split, axis);
        }
        uint32_t left = used;
        used += 2;
        n->offset = left;
        n->count = 0;
        stack[top++] = (range){left + 1, split, r.end};
        stack[top++] = (range){left, r.begin, split};
    }
    free(stack);
    for (uint32_t i = 0; i < a->prim_count; i++)
        a->prim_order[i] = it[i].id;
    free(own);
    set_bounds(a, used);
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

/* The kernel's checks of a builder's output (rtk_bvh_build): a plugin that
 * emits a broken tree is refused with RTK_ERR_PLUGIN and a message naming
 * the plugin and the fault, never traced, and the scene builds again with
 * a good builder afterwards. The builder here halves a Morton order
 * (one triangle per leaf) whose output is then damaged one way at a time:
 * a leaf that misses its triangle (the check runs on threads: the lowest
 * such leaf must be named whatever the thread count), a node reported but
 * unreachable, a shared child, a cycle, a child index out of range, a
 * primitive twice, a slot shared by leaves far apart, NaN bounds, an inner box missing its child, a chain
 * deeper than the kernel allows. The good tree must answer every ray as a
 * one-leaf tree does (same triangle, same t). A builder that declares
 * RTK_BUILD_NO_VERTICES is given no corners, one that also declares
 * RTK_BUILD_NO_BOUNDS no bounds either (every builder gets the scene's
 * indexed mesh); one that declares neither, or whose table predates
 * build_flags, is given every triangle's corners. */
#include "conform/conform.h"
#include "config/config.h"
#include "render/render.h"
#include "image/image.h"

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"

enum damage {
    NONE,
    LAST_LEAF_MISSES,  /* the last leaf's box shrunk to a point */
    TWO_LEAVES_MISS,   /* a leaf near the start and the last leaf */
    EXTRA_NODE,        /* node_count counts two nodes the tree lost */
    SHARED_CHILD,      /* two inner nodes point to the same children */
    CYCLE,             /* an inner node points back to the root's children */
    CHILD_OUT_OF_RANGE,
    PRIM_TWICE,        /* prim_order holds one primitive twice */
    SLOT_TWICE,        /* the first leaf takes the last leaf's slot: deep in
                          both halves, where threads walk */
    NAN_BOUNDS,
    INNER_MISSES_CHILD,
    TOO_DEEP,          /* a chain of 300 levels */
    DAMAGE_COUNT
};

static const struct {
    const char *name, *expect;
} damages[DAMAGE_COUNT] = {
    [NONE] = {"none", ""},
    [LAST_LEAF_MISSES] = {"last leaf misses its triangle", "does not enclose primitive"},
    [TWO_LEAVES_MISS] = {"two leaves miss their triangles", "does not enclose primitive"},
    [EXTRA_NODE] = {"a node reported but unreachable", "not reachable from the root"},
    [SHARED_CHILD] = {"two nodes share children", "reached twice"},
    [CYCLE] = {"a cycle", "reached twice"},
    [CHILD_OUT_OF_RANGE] = {"a child index past the last node", "points to children"},
    [PRIM_TWICE] = {"a primitive twice in prim_order", "referenced twice"},
    [SLOT_TWICE] = {"two leaves far apart share a slot", "referenced twice"},
    [NAN_BOUNDS] = {"NaN bounds", "NaN bounds"},
    [INNER_MISSES_CHILD] = {"an inner box missing its child", "does not enclose its child"},
    [TOO_DEEP] = {"a chain of 300 levels", "deeper than"},
};

static enum damage damage;
/* What the damaged build leads the kernel to report, set by the build. */
static uint32_t expect_leaf, expect_prim;

typedef struct median_build {
    const rtk_build_args *a;
    rtk_bvh_node *nodes;
    uint32_t next;
} median_build;

/* Node id over prim_order[begin, end), already in Morton order: halved
 * by count, children adjacent, one triangle a leaf. */
static void median_node(median_build *m, uint32_t id, uint32_t begin, uint32_t end)
{
    rtk_bvh_node *n = &m->nodes[id];
    if (end - begin == 1) {
        const rtk_bounds *b = &m->a->prim_bounds[m->a->prim_order[begin]];
        const float lo[3] = {b->lower.x, b->lower.y, b->lower.z}, hi[3] = {b->upper.x, b->upper.y, b->upper.z};
        memcpy(n->lower, lo, sizeof lo);
        memcpy(n->upper, hi, sizeof hi);
        n->offset = begin, n->count = 1;
        return;
    }
    uint32_t left = m->next;
    m->next += 2;
    median_node(m, left, begin, begin + (end - begin) / 2);
    median_node(m, left + 1, begin + (end - begin) / 2, end);
    for (int k = 0; k < 3; k++) {
        n->lower[k] = fminf(m->nodes[left].lower[k], m->nodes[left + 1].lower[k]);
        n->upper[k] = fmaxf(m->nodes[left].upper[k], m->nodes[left + 1].upper[k]);
    }
    n->offset = left, n->count = 0;
}

/* 10 bits of x in every third bit. */
static uint64_t spread(uint32_t x)
{
    uint64_t r = 0;
    for (int b = 0; b < 10; b++)
        r |= (uint64_t)(x >> b & 1) << (3 * b);
    return r;
}

static int by_key(const void *x, const void *y)
{
    uint64_t a = *(const uint64_t *)x, b = *(const uint64_t *)y;
    return (a > b) - (a < b);
}

/* prim_order sorted by the Morton code of the centroids in the unit cube
 * [-1, 1]^3 of the soup (key: code above, index below). */
static void morton_order(rtk_build_args *a)
{
    uint64_t *keys = malloc(sizeof *keys * a->prim_count);
    for (uint32_t i = 0; i < a->prim_count; i++) {
        const rtk_vec3 c = a->centroids[i];
        const float f[3] = {c.x, c.y, c.z};
        uint64_t code = 0;
        for (int k = 0; k < 3; k++) {
            float q = (f[k] + 1.5f) / 3.0f * 1023.0f;
            uint32_t b = q < 0.0f ? 0 : q > 1023.0f ? 1023 : (uint32_t)q;
            code |= spread(b) << k;
        }
        keys[i] = code << 32 | i;
    }
    qsort(keys, a->prim_count, sizeof *keys, by_key);
    for (uint32_t i = 0; i < a->prim_count; i++)
        a->prim_order[i] = (uint32_t)keys[i];
    free(keys);
}

static rtk_status damaging_build(void *state, rtk_build_args *a)
{
    (void)state;
    median_build m = {a, a->nodes, 1};
    morton_order(a);
    median_node(&m, 0, 0, a->prim_count);
    a->node_count = m.next;
    rtk_bvh_node *nodes = a->nodes;
    uint32_t last = a->node_count - 1; /* a leaf: the right child of the last split */
    switch (damage) {
    case NONE:
    case DAMAGE_COUNT:
        break;
    case TWO_LEAVES_MISS:
    case LAST_LEAF_MISSES: {
        uint32_t first = last;
        if (damage == TWO_LEAVES_MISS) /* the first leaf in node order */
            for (first = 0; nodes[first].count == 0; first++)
                ;
        for (int k = 0; k < 3; k++) {
            nodes[first].upper[k] = nodes[first].lower[k];
            nodes[last].upper[k] = nodes[last].lower[k];
        }
        expect_leaf = first;
        expect_prim = a->prim_order[nodes[first].offset];
        break;
    }
    case EXTRA_NODE: {
        /* The last split becomes a leaf over its two children's slots
         * (adjacent), which stay counted in node_count. */
        uint32_t parent = 0;
        while (nodes[parent].count != 0 || nodes[parent].offset != last - 1)
            parent++;
        nodes[parent].offset = nodes[last - 1].offset;
        nodes[parent].count = 2;
        break;
    }
    case SHARED_CHILD: {
        /* Boxes made large enough that only the sharing is wrong. */
        rtk_bvh_node *right = &nodes[nodes[0].offset + 1];
        memcpy(right->lower, nodes[0].lower, sizeof right->lower);
        memcpy(right->upper, nodes[0].upper, sizeof right->upper);
        right->offset = nodes[nodes[0].offset].offset;
        break;
    }
    case CYCLE: {
        rtk_bvh_node *left = &nodes[nodes[0].offset], *grandchild = &nodes[left->offset];
        rtk_bvh_node *boxes[3] = {left, left + 1, grandchild};
        for (int i = 0; i < 3; i++) {
            memcpy(boxes[i]->lower, nodes[0].lower, sizeof boxes[i]->lower);
            memcpy(boxes[i]->upper, nodes[0].upper, sizeof boxes[i]->upper);
        }
        grandchild->offset = nodes[0].offset, grandchild->count = 0;
        break;
    }
    case CHILD_OUT_OF_RANGE:
        nodes[nodes[0].offset].offset = a->node_count - 1;
        break;
    case PRIM_TWICE:
        a->prim_order[a->prim_count - 1] = a->prim_order[0];
        break;
    case SLOT_TWICE: {
        uint32_t first = 0;
        while (nodes[first].count == 0)
            first++;
        nodes[first].offset = nodes[last].offset;
        break;
    }
    case NAN_BOUNDS:
        nodes[0].lower[1] = NAN;
        break;
    case INNER_MISSES_CHILD:
        nodes[0].upper[0] = nodes[0].lower[0];
        break;
    case TOO_DEEP: {
        /* A valid-looking chain: every inner node's right child a leaf of
         * one triangle, each box the scene's. */
        for (uint32_t i = 0; i < a->prim_count; i++)
            a->prim_order[i] = i;
        uint32_t id = 0, next = 1;
        for (uint32_t i = 0; i + 1 < a->prim_count && i < 300; i++) {
            nodes[id] = nodes[0];
            nodes[id].offset = next, nodes[id].count = 0;
            nodes[next + 1] = nodes[0];
            nodes[next + 1].offset = i, nodes[next + 1].count = 1;
            id = next;
            next += 2;
        }
        nodes[id] = nodes[0];
        nodes[id].offset = 300, nodes[id].count = a->prim_count - 300;
        a->node_count = next;
        break;
    }
    }
    return RTK_OK;
}

static const rtk_accelerator_fns damaging_fns = {
    .size = sizeof(rtk_accelerator_fns), .create = stateless_create, .build = damaging_build, .destroy = stateless_destroy};
static const rtk_plugin damaging = {RTK_PLUGIN_HEADER,
                                    .kind = RTK_KIND_ACCELERATOR,
                                    .name = "damaging",
                                    .version = "1",
                                    .summary = "",
                                    .functions = &damaging_fns};

/* What the last probe build was given: whether it had the corners and
 * whether each primitive's three corners were its triangle's. */
static struct {
    const rtk_scene *scene;
    int had_vertices, corners_right, had_bounds, mesh_right;
    int had_scratch, scratch_right; /* scratch given; aligned, large enough and writable */
} probe;

/* One leaf over every primitive, its box from indices and positions. */
static rtk_status one_leaf_from_mesh(rtk_build_args *a)
{
    rtk_bvh_node *n = &a->nodes[0];
    for (int k = 0; k < 3; k++)
        n->lower[k] = INFINITY, n->upper[k] = -INFINITY;
    for (uint32_t i = 0; i < a->prim_count; i++) {
        for (int c = 0; c < 3; c++) {
            const float *p = a->positions + 3 * (size_t)a->indices[3 * (size_t)i + (size_t)c];
            for (int k = 0; k < 3; k++)
                n->lower[k] = fminf(n->lower[k], p[k]), n->upper[k] = fmaxf(n->upper[k], p[k]);
        }
        a->prim_order[i] = i;
    }
    n->offset = 0;
    n->count = a->prim_count;
    a->node_count = 1;
    return RTK_OK;
}

/* The damaging builder's good tree, noting what args->vertices held. */
static rtk_status probe_build(void *state, rtk_build_args *a)
{
    probe.had_vertices = a->vertices != NULL;
    probe.had_bounds = a->prim_bounds != NULL || a->centroids != NULL;
    probe.mesh_right = a->indices == probe.scene->indices && a->positions == probe.scene->positions &&
                       a->vertex_count == probe.scene->vertex_count;
    probe.had_scratch = a->scratch != NULL;
    probe.scratch_right = a->scratch && (uintptr_t)a->scratch % 64 == 0 &&
                          a->scratch_bytes + 64 >= (size_t)36 * a->prim_count;
    if (a->scratch) /* all of it the builder's: sanitizers and valgrind see any overrun */
        memset(a->scratch, 0xa5, a->scratch_bytes);
    probe.corners_right = a->vertices != NULL;
    for (uint32_t i = 0; a->vertices && i < a->prim_count; i++) {
        float v[9];
        rtk_triangle_corners(probe.scene, i, v);
        for (int k = 0; k < 3; k++) {
            const rtk_vec3 *c = &a->vertices[3 * (size_t)i + (size_t)k];
            probe.corners_right &= c->x == v[3 * k] && c->y == v[3 * k + 1] && c->z == v[3 * k + 2];
        }
    }
    return probe.had_bounds ? damaging_build(state, a) : one_leaf_from_mesh(a);
}

/* Four tables: one that declares RTK_BUILD_NO_VERTICES, one that does
 * not, one of ABI 3.1's size (it ends before build_flags), and one that
 * declares RTK_BUILD_NO_VERTICES and RTK_BUILD_NO_BOUNDS. */
static const rtk_accelerator_fns probe_no_vertices_fns = {.size = sizeof(rtk_accelerator_fns),
                                                          .create = stateless_create,
                                                          .build = probe_build,
                                                          .destroy = stateless_destroy,
                                                          .build_flags = RTK_BUILD_NO_VERTICES};
static const rtk_accelerator_fns probe_vertices_fns = {.size = sizeof(rtk_accelerator_fns),
                                                       .create = stateless_create,
                                                       .build = probe_build,
                                                       .destroy = stateless_destroy};
static const rtk_accelerator_fns probe_old_fns = {.size = offsetof(rtk_accelerator_fns, build_flags),
                                                  .create = stateless_create,
                                                  .build = probe_build,
                                                  .destroy = stateless_destroy,
                                                  .build_flags = RTK_BUILD_NO_VERTICES};
static const rtk_accelerator_fns probe_mesh_fns = {.size = sizeof(rtk_accelerator_fns),
                                                   .create = stateless_create,
                                                   .build = probe_build,
                                                   .destroy = stateless_destroy,
                                                   .build_flags = RTK_BUILD_NO_VERTICES | RTK_BUILD_NO_BOUNDS};

#define PROBE(fns) {RTK_PLUGIN_HEADER, .kind = RTK_KIND_ACCELERATOR, .name = "probe", .version = "1", .summary = "", \
                    .functions = &(fns)}
static const rtk_plugin probes[4] = {PROBE(probe_no_vertices_fns), PROBE(probe_vertices_fns), PROBE(probe_old_fns),
                                     PROBE(probe_mesh_fns)};
#undef PROBE

static float frand(rtk_pcg32 *rng, float lo, float hi)
{
    return lo + (hi - lo) * rtk_pcg32_float(rng);
}

/* n random small triangles in the unit cube. */
static rtk_scene *soup(uint32_t n)
{
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 5u, 11u);
    rtk_scene *s = rtk_scene_new("soup", 0);
    for (uint32_t i = 0; s && i < n; i++) {
        rtk_vec3 c = rtk_vec3_make(frand(&rng, -1, 1), frand(&rng, -1, 1), frand(&rng, -1, 1));
        uint32_t id[3];
        for (int k = 0; k < 3; k++)
            rtk_scene_add_vertex(s, c.x + frand(&rng, -.05f, .05f), c.y + frand(&rng, -.05f, .05f),
                                 c.z + frand(&rng, -.05f, .05f), &id[k]);
        rtk_scene_add_triangle(s, id[0], id[1], id[2], NULL, NULL, RTK_INVALID_ID);
    }
    return s;
}

/* Rays from outside the cube towards random points inside; hits of the
 * scene as built now. */
static void trace(const rtk_scene *s, uint32_t rays, rtk_hit *hits, int *found)
{
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 9u, 1u);
    for (uint32_t i = 0; i < rays; i++) {
        rtk_vec3 from = rtk_vec3_make(frand(&rng, -3, 3), frand(&rng, -3, 3), 3.0f);
        rtk_vec3 to = rtk_vec3_make(frand(&rng, -1, 1), frand(&rng, -1, 1), frand(&rng, -1, 1));
        rtk_ray r;
        memset(&r, 0, sizeof r);
        r.org = from;
        r.dir = rtk_vec3_sub(to, from);
        r.tmin = 0.0f;
        r.tmax = INFINITY;
        memset(&hits[i], 0, sizeof hits[i]);
        found[i] = rtk_bvh_closest(s, &r, &hits[i]);
    }
}

int main(void)
{
    /* 150,000 triangles: 300k nodes, so that with two threads the tree
     * walk runs on both and the leaf check on two ranges; a fault is then
     * reported as on one thread. */
    const uint32_t n = 150000, rays = 1000;
    rtk_scene *s = soup(n);
    if (!s || rtk_scene_finish(s) != RTK_OK) {
        printf("FAIL  scene: %s\n", rtk_error_message());
        return 1;
    }
    rtk_hit *want = calloc(rays, sizeof *want), *got = calloc(rays, sizeof *got);
    int *want_found = calloc(rays, sizeof *want_found), *got_found = calloc(rays, sizeof *got_found);
    if (!want || !got || !want_found || !got_found)
        return 1;
    rtk_status st = rtk_bvh_build(s, &rtk_conform_one_leaf, NULL, 1);
    check(st == RTK_OK, "one-leaf reference builds");
    trace(s, rays, want, want_found);
    uint32_t hit_count = 0;
    for (uint32_t i = 0; i < rays; i++)
        hit_count += (uint32_t)want_found[i];
    check(hit_count > rays / 4, "reference rays hit the soup (%u of %u)", hit_count, rays);

    /* The corners reach the builders that do not decline them, old ones
     * included; the tree is checked and traced either way. */
    static const char *const probe_names[4] = {"RTK_BUILD_NO_VERTICES", "no build_flags",
                                               "a table of ABI 3.1's size",
                                               "RTK_BUILD_NO_VERTICES | RTK_BUILD_NO_BOUNDS"};
    for (int p = 0; p < 4; p++) {
        probe.scene = s;
        st = rtk_bvh_build(s, &probes[p], NULL, 2);
        trace(s, rays, got, got_found);
        int same = 1;
        for (uint32_t i = 0; i < rays; i++)
            same &= got_found[i] == want_found[i] &&
                    (!want_found[i] || (got[i].prim == want[i].prim && got[i].t == want[i].t));
        if (p == 0)
            check(st == RTK_OK && !probe.had_vertices && probe.had_bounds && probe.mesh_right && probe.scratch_right &&
                      same,
                  "a builder declaring %s gets no corners (vertices NULL), the bounds, the scene's indexed "
                  "mesh and the corners' 36 bytes a primitive as scratch (64-byte aligned), and its tree answers "
                  "as the reference",
                  probe_names[p]);
        else if (p == 3)
            check(st == RTK_OK && !probe.had_vertices && !probe.had_bounds && probe.mesh_right && same,
                  "a builder declaring %s gets neither corners nor bounds nor centroids, only the scene's "
                  "indexed mesh, and its tree (boxes from that mesh) answers as the reference",
                  probe_names[p]);
        else
            check(st == RTK_OK && probe.had_vertices && probe.corners_right && !probe.had_scratch && same,
                  "a builder with %s gets every triangle's corners (and no scratch), and its tree answers as the "
                  "reference",
                  probe_names[p]);
    }

    static char one_thread[DAMAGE_COUNT][512];
    for (uint32_t threads = 1; threads <= 2; threads++) {
        for (int d = 0; d < DAMAGE_COUNT; d++) {
            damage = (enum damage)d;
            st = rtk_bvh_build(s, &damaging, NULL, threads);
            const char *msg = rtk_error_message();
            if (damage == NONE) {
                check(st == RTK_OK, "[%u threads] the undamaged median tree is accepted (%s)", threads,
                      st == RTK_OK ? "ok" : msg);
                trace(s, rays, got, got_found);
                uint32_t same = 0;
                for (uint32_t i = 0; i < rays; i++)
                    same += got_found[i] == want_found[i] &&
                            (!got_found[i] || (got[i].prim == want[i].prim && got[i].t == want[i].t));
                check(same == rays, "[%u threads] it answers %u of %u rays as the one-leaf tree", threads, same,
                      rays);
                continue;
            }
            int named = strstr(msg, "accelerator 'damaging' produced an invalid tree") != NULL;
            int says = strstr(msg, damages[d].expect) != NULL;
            check(st == RTK_ERR_PLUGIN && named && says, "[%u threads] %s: refused (%s)", threads, damages[d].name,
                  msg);
            if (threads == 1)
                snprintf(one_thread[d], sizeof one_thread[d], "%s", msg);
            else
                check(strcmp(msg, one_thread[d]) == 0, "[%u threads] %s: the same message as on one thread", threads,
                      damages[d].name);
            if (damage == LAST_LEAF_MISSES || damage == TWO_LEAVES_MISS) {
                char want_msg[128];
                snprintf(want_msg, sizeof want_msg, "leaf %u does not enclose primitive %u", expect_leaf,
                         expect_prim);
                check(strstr(msg, want_msg) != NULL, "[%u threads] %s: the lowest such leaf is named (\"%s\")",
                      threads, damages[d].name, want_msg);
            }
            /* Nothing of the refused tree is traced; a good build works. */
            damage = NONE;
            st = rtk_bvh_build(s, &damaging, NULL, threads);
            trace(s, rays, got, got_found);
            uint32_t same = 0;
            for (uint32_t i = 0; i < rays; i++)
                same += got_found[i] == want_found[i] &&
                        (!got_found[i] || (got[i].prim == want[i].prim && got[i].t == want[i].t));
            check(st == RTK_OK && same == rays, "[%u threads] %s: the scene builds and traces again after", threads,
                  damages[d].name);
            if (st == RTK_OK && (d == LAST_LEAF_MISSES || d == TWO_LEAVES_MISS)) {
                /* The standalone leaf check (no wide tree: a plugin's own
                 * traversal, a failed collapse) names the same leaf. */
                uint32_t last = s->node_count - 1, first = last;
                if (d == TWO_LEAVES_MISS)
                    for (first = 0; s->nodes[first].count == 0; first++)
                        ;
                rtk_bvh_node keep_first = s->nodes[first], keep_last = s->nodes[last];
                for (int k = 0; k < 3; k++) {
                    s->nodes[first].upper[k] = s->nodes[first].lower[k];
                    s->nodes[last].upper[k] = s->nodes[last].lower[k];
                }
                char want_msg[128];
                snprintf(want_msg, sizeof want_msg, "leaf %u does not enclose primitive %u", expect_leaf, expect_prim);
                st = rtk_bvh_check_leaves(s, threads);
                check(st == RTK_ERR_PLUGIN && strstr(rtk_error_message(), want_msg) != NULL,
                      "[%u threads] %s: rtk_bvh_check_leaves names the lowest such leaf (%s)", threads,
                      damages[d].name, rtk_error_message());
                s->nodes[first] = keep_first, s->nodes[last] = keep_last;
                check(rtk_bvh_check_leaves(s, threads) == RTK_OK, "[%u threads] %s: and passes the sound tree",
                      threads, damages[d].name);
            }
        }
    }
    rtk_scene_free(s);
    free(want);
    free(got);
    free(want_found);
    free(got_found);
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}

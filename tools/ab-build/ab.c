/* A/B of two builds of an accelerator plugin in one process (see ab.sh).
 *
 * Both files are loaded with dlopen and checked as the kernel's loader
 * checks a plugin; each gets its defaults (and AB_SET's parameter). The
 * inputs are the kernel's for the mesh (rtk_bvh_prepare_inputs): each
 * triangle's bounds and centroid, its corners for a builder that reads
 * them, and for one that does not (RTK_BUILD_NO_VERTICES) the scratch the
 * kernel hands it (36 bytes a triangle; 72 with RTK_BUILD_NO_BOUNDS too),
 * touched once beforehand as the kernel's are. A build's time includes
 * the kernel's preparation of what it reads, as rtk_bvh_build's does
 * (its inputs and builder phases), so that builders reading different
 * inputs compare fairly. Round 0
 * builds with both and compares the trees (node count, nodes, primitive
 * order) byte for byte: they must match unless AB_DIFFERENT=1. Each
 * later round times one build of each, in alternating order, on the same
 * output arrays (faulted in by round 0, so the figures are the builders'
 * own work without first touches), in wall-clock time (builds may use
 * threads); the ratios B/A of the rounds are sorted and their median and
 * quartiles printed. Slow drifts of a shared host hit both sides of a
 * round alike: the median resolves differences of a few percent where
 * separate processes vary by 10%. */
#include "bench/bench.h"

#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct side {
    const char *path;
    const rtk_plugin *plugin;
    const rtk_accelerator_fns *fns;
    void *state;
    uint32_t flags;
    rtk_bvh_node *nodes;
    uint32_t *prim_order;
    uint32_t node_count;
} side;

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* Loads, checks and starts the plugin at s->path; 0 on failure (said). */
static int open_side(side *s, const char *set)
{
    void *h = dlopen(s->path, RTLD_NOW | RTLD_LOCAL);
    if (!h) {
        fprintf(stderr, "ab: cannot load %s: %s\n", s->path, dlerror());
        return 0;
    }
    rtk_plugin_entry_fn entry = (rtk_plugin_entry_fn)dlsym(h, RTK_PLUGIN_ENTRY_NAME);
    if (!entry) {
        fprintf(stderr, "ab: %s has no %s: not an rtk plugin\n", s->path, RTK_PLUGIN_ENTRY_NAME);
        return 0;
    }
    s->plugin = entry();
    if (rtk_plugin_check(s->plugin, s->path, RTK_KIND_ACCELERATOR) != RTK_OK) {
        fprintf(stderr, "ab: %s\n", rtk_error_message());
        return 0;
    }
    s->fns = s->plugin->functions;
    if (rtk_accelerator_traverses_itself(s->plugin)) {
        fprintf(stderr, "ab: %s traverses with its own code; this compares builders of the kernel's trees\n",
                s->path);
        return 0;
    }
    s->flags = rtk_accelerator_build_flags(s->plugin);
    rtk_params *params = rtk_params_defaults(s->plugin);
    if (!params) {
        fprintf(stderr, "ab: %s: %s\n", s->path, rtk_error_message());
        return 0;
    }
    if (set) {
        char key[64], value[64];
        if (sscanf(set, "%63[^=]=%63s", key, value) != 2) {
            fprintf(stderr, "ab: AB_SET must be KEY=VALUE, not '%s'\n", set);
            rtk_params_destroy(params);
            return 0;
        }
        if (rtk_params_set_text(params, key, value) != RTK_OK) {
            fprintf(stderr, "ab: AB_SET for %s: %s\n", s->path, rtk_error_message());
            rtk_params_destroy(params);
            return 0;
        }
    }
    rtk_status st = s->fns->create(params, &s->state);
    rtk_params_destroy(params);
    if (st != RTK_OK) {
        fprintf(stderr, "ab: %s failed to start: %s\n", s->path, rtk_error_message());
        return 0;
    }
    return 1;
}

int main(int argc, char **argv)
{
    if (argc != 6) {
        fprintf(stderr, "usage: ab MESH.obj A.so B.so ROUNDS THREADS (run through ab.sh)\n");
        return 2;
    }
    const int rounds = atoi(argv[4]), threads = atoi(argv[5]);
    if (rounds < 4 || threads < 1) {
        fprintf(stderr, "ab: at least 4 rounds and 1 thread\n");
        return 2;
    }
    rtk_scene *scene = NULL;
    if (rtk_bench_read_obj(argv[1], &scene) != RTK_OK) {
        fprintf(stderr, "ab: reading the mesh: %s\n", rtk_error_message());
        return 2;
    }
    side sides[2] = {{.path = argv[2]}, {.path = argv[3]}};
    for (int v = 0; v < 2; v++)
        if (!open_side(&sides[v], getenv("AB_SET")))
            return 2;
    const uint32_t n = scene->triangle_count;
    if (n < 2) {
        fprintf(stderr, "ab: %s has fewer than two triangles\n", argv[1]);
        return 2;
    }
    /* The kernel's inputs: bounds and centroids, corners, and the scratch
     * that takes the corners' place for a builder that does not read them. */
    rtk_bounds *bounds = malloc(sizeof *bounds * n);
    rtk_vec3 *centroids = malloc(sizeof *centroids * n), *corners = malloc(sizeof *corners * 3 * (size_t)n);
    const size_t scratch_bytes = (sizeof(rtk_vec3) * 3 * (size_t)n - 64) / 64 * 64 + 64;
    const size_t whole_bytes = (sizeof(rtk_bounds) + sizeof(rtk_vec3) * 4) * (size_t)n / 64 * 64;
    void *scratch = aligned_alloc(64, whole_bytes);
    for (int v = 0; v < 2; v++) {
        sides[v].nodes = malloc(sizeof *sides[v].nodes * (2 * (size_t)n - 1));
        sides[v].prim_order = malloc(sizeof *sides[v].prim_order * n);
    }
    double *ratio = malloc(sizeof *ratio * (size_t)rounds);
    if (!bounds || !centroids || !corners || !scratch || !sides[0].nodes || !sides[1].nodes ||
        !sides[0].prim_order || !sides[1].prim_order || !ratio) {
        fprintf(stderr, "ab: out of memory\n");
        return 2;
    }
    memset(scratch, 0, whole_bytes);
    rtk_bvh_prepare_inputs(scene, (uint32_t)threads, bounds, centroids, corners);
    double total[2] = {0.0, 0.0};
    for (int round = 0; round <= rounds; round++) {
        double t[2];
        for (int q = 0; q < 2; q++) {
            side *s = &sides[(round & 1) ? 1 - q : q];
            const int no_vertices = (s->flags & RTK_BUILD_NO_VERTICES) != 0;
            const int no_bounds = (s->flags & RTK_BUILD_NO_BOUNDS) != 0;
            rtk_build_args a = {.size = sizeof a,
                                .prim_count = n,
                                .prim_bounds = (s->flags & RTK_BUILD_NO_BOUNDS) ? NULL : bounds,
                                .centroids = (s->flags & RTK_BUILD_NO_BOUNDS) ? NULL : centroids,
                                .max_nodes = 2 * n - 1,
                                .nodes = s->nodes,
                                .prim_order = s->prim_order,
                                .thread_count = (uint32_t)threads,
                                .vertices = no_vertices ? NULL : corners,
                                .indices = scene->indices,
                                .positions = scene->positions,
                                .vertex_count = scene->vertex_count,
                                .scratch = no_vertices ? scratch : NULL,
                                .scratch_bytes = no_vertices ? (no_bounds ? whole_bytes : scratch_bytes) : 0};
            const double t0 = rtk_now();
            if (!no_bounds || !no_vertices)
                rtk_bvh_prepare_inputs(scene, (uint32_t)threads, no_bounds ? NULL : bounds,
                                       no_bounds ? NULL : centroids, no_vertices ? NULL : corners);
            if (s->fns->build(s->state, &a) != RTK_OK) {
                fprintf(stderr, "ab: %s failed: %s\n", s->path, rtk_error_message());
                return 2;
            }
            t[s == &sides[1]] = rtk_now() - t0;
            s->node_count = a.node_count;
        }
        if (round == 0) {
            const side *x = &sides[0], *y = &sides[1];
            const int same = x->node_count == y->node_count &&
                             memcmp(x->nodes, y->nodes, sizeof *x->nodes * x->node_count) == 0 &&
                             memcmp(x->prim_order, y->prim_order, sizeof *x->prim_order * n) == 0;
            if (!same) {
                fprintf(stderr, "ab: the two builds give different trees (%u and %u nodes)%s\n", x->node_count,
                        y->node_count, getenv("AB_DIFFERENT") ? "; timed anyway (AB_DIFFERENT)" : "; not timing them");
                if (!getenv("AB_DIFFERENT"))
                    return 1;
            }
            continue;
        }
        ratio[round - 1] = t[1] / t[0];
        total[0] += t[0], total[1] += t[1];
    }
    qsort(ratio, (size_t)rounds, sizeof *ratio, cmp_double);
    printf("%s, %u triangles, %d thread(s), %d rounds\n", argv[1], n, threads, rounds);
    printf("build B/A time: median %.4f (quartiles %.4f-%.4f), totals %.4f\n", ratio[rounds / 2], ratio[rounds / 4],
           ratio[3 * rounds / 4], total[1] / total[0]);
    printf("A: %.3f ms a build, B: %.3f ms\n", 1e3 * total[0] / rounds, 1e3 * total[1] / rounds);
    for (int v = 0; v < 2; v++) {
        sides[v].fns->destroy(sides[v].state);
        free(sides[v].nodes);
        free(sides[v].prim_order);
    }
    free(bounds), free(centroids), free(corners), free(scratch), free(ratio);
    rtk_scene_free(scene);
    return 0;
}

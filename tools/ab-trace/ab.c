/* A/B of two tracers over the same rays in one process (see ab.sh).
 *
 * A is the build tree's kernel: rtk_wide_any / rtk_wide_closest on the
 * best path this CPU runs (or RTK_SIMD's), over the tree ACCEL built. B
 * is either a variant of the wide BVH (kernel/accel/bvh_wide_trace.c and
 * bvh_wide_build.c, one of them modified) linked beside it (its
 * functions renamed B_*, on the same path, tracing the same tree, or with
 * AB_REBUILD=1 a wide tree its own code built on a second copy of the
 * scene), or, for "embree", the embree plugin through
 * rtk_bvh_any / rtk_bvh_closest (A then goes through them too).
 *
 * The rays are the standard bench recipe's (rtk bench's own functions): primary
 * rays at 512x384, 8 AO rays per hit. Each round times A and B, in
 * alternating order, on one eighth of the AO rays and one quarter of the
 * primary rays, in thread CPU time; the ratios B/A of the rounds are
 * sorted and their median and quartiles printed. Slow drifts of a shared
 * host hit both sides of a round alike, so the median resolves
 * differences of about 1% where runs of separate processes vary by 10%.
 *
 * With AB_BUILD=1 the rounds time the wide builds instead: A's
 * rtk_wide_build and B's on their own copies of the binary tree (one
 * thread, with validation, fresh arrays each time), after a check that
 * the two give the same wide tree byte for byte (AB_DIFFERENT=1: timed
 * even when they do not; for tracing, timed even when the two answer
 * differently, as a variant with other arithmetic may).
 *
 * Two knobs for finding where a difference lies: AB_AO_SCALE=F
 * multiplies the AO rays' tfar by F (1e-4: little more than the per-ray
 * set-up and the boxes around the origin; 10: far past the recipe's
 * length), AB_REPEAT=K traces each ray K times in a row (caches and
 * branch history warm after the first).
 *
 * AB_BATCH=N has B trace its chunks N rays to a call through its batch
 * functions (rtk_wide_any_batch / rtk_wide_closest_batch), AB_BATCH_A=N
 * the same for A; the batches' answers are checked against A's single
 * rays first. The AO rays keep bench's order: one hit's rays together. */
#include "bench/bench.h"
#include "accel/accel.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

int B_wide_any(const rtk_scene *s, rtk_simd_path path, const rtk_ray *ray, rtk_trace_work *work);
int B_wide_closest(const rtk_scene *s, rtk_simd_path path, const rtk_ray *ray, rtk_hit *hit, rtk_trace_work *work);
void B_wide_any_batch(const rtk_scene *s, rtk_simd_path path, const rtk_ray *rays, uint32_t count, uint8_t *occluded);
void B_wide_closest_batch(const rtk_scene *s, rtk_simd_path path, const rtk_ray *rays, uint32_t count, rtk_hit *hits);
void B_wide_free(rtk_scene *s);
rtk_status B_wide_build(rtk_scene *s, uint32_t threads, void *spare, size_t spare_bytes, int validate);

enum { WIDTH = 512, HEIGHT = 384, AO_PER_HIT = 8 };

static int embree_mode;
static int repeat = 1;         /* AB_REPEAT */
static double ao_scale = 1.0;  /* AB_AO_SCALE */
static size_t batch[2];        /* AB_BATCH_A, AB_BATCH: rays per batch call (0: one at a time) */
static uint8_t *batch_occ;     /* room for one batch's answers */
static rtk_hit *batch_hits;

/* A number from the environment variable name in [lo, hi], def when it
 * is not set; 0 (after a message) when it is not such a number. */
static int env_number(const char *name, double lo, double hi, double def, double *out)
{
    const char *e = getenv(name);
    *out = def;
    if (!e || !*e)
        return 1;
    char *end;
    double v = strtod(e, &end);
    if (*end || !(v >= lo && v <= hi)) {
        fprintf(stderr, "ab: %s=%s: give a number from %g to %g\n", name, e, lo, hi);
        return 0;
    }
    *out = v;
    return 1;
}
static rtk_simd_path path; /* A's and B's */
static rtk_scene *scene_a, *scene_b;

static int any_a(const rtk_ray *r, rtk_trace_work *w)
{
    return embree_mode ? rtk_bvh_any(scene_a, r) : rtk_wide_any(scene_a, path, r, w);
}

static int any_b(const rtk_ray *r, rtk_trace_work *w)
{
    return embree_mode ? rtk_bvh_any(scene_b, r) : B_wide_any(scene_b, path, r, w);
}

static int closest_a(const rtk_ray *r, rtk_hit *h)
{
    return embree_mode ? rtk_bvh_closest(scene_a, r, h) : rtk_wide_closest(scene_a, path, r, h, NULL);
}

static int closest_b(const rtk_ray *r, rtk_hit *h)
{
    return embree_mode ? rtk_bvh_closest(scene_b, r, h) : B_wide_closest(scene_b, path, r, h, NULL);
}

static double cpu_now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* Reports what failed with the kernel's message; main's exit status. */
static int fail(const char *what)
{
    fprintf(stderr, "ab: %s: %s\n", what, rtk_error_message());
    return 2;
}

/* The mesh built by p (with set, KEY=VALUE, applied to its defaults), or
 * NULL after a message. */
static rtk_scene *load_and_build(const char *mesh, const rtk_plugin *p, const char *set)
{
    rtk_scene *s = NULL;
    if (rtk_bench_read_obj(mesh, &s) != RTK_OK) {
        fail("reading the mesh");
        return NULL;
    }
    rtk_params *params = rtk_params_defaults(p);
    const char *failed = params ? NULL : "parameters";
    if (set && !failed) {
        char key[64], value[64];
        if (sscanf(set, "%63[^=]=%63s", key, value) != 2 || rtk_params_set_text(params, key, value) != RTK_OK)
            failed = "AB_SET (KEY=VALUE)";
    }
    if (!failed && rtk_bvh_build(s, p, params, 1) != RTK_OK)
        failed = "build";
    rtk_params_destroy(params);
    if (failed) {
        fail(failed);
        rtk_scene_free(s);
        return NULL;
    }
    return s;
}

/* Rays [begin, end) through side b's batch functions, batch[b] rays a
 * call; the answers into occluded (occlusion) or hits. */
static void batch_run(int b, int occlusion, const rtk_ray *rays, size_t begin, size_t end, uint8_t *occluded,
                      rtk_hit *hits)
{
    const rtk_scene *s = b ? scene_b : scene_a;
    for (size_t i = begin; i < end; i += batch[b]) {
        const uint32_t n = (uint32_t)(end - i < batch[b] ? end - i : batch[b]);
        if (occlusion)
            (b ? B_wide_any_batch : rtk_wide_any_batch)(s, path, rays + i, n, occluded + (i - begin));
        else
            (b ? B_wide_closest_batch : rtk_wide_closest_batch)(s, path, rays + i, n, hits + (i - begin));
    }
}

/* One timed chunk: rays [begin, end) through any (occlusion) or closest. */
static double time_chunk(int b, int occlusion, const rtk_ray *rays, size_t begin, size_t end, size_t *sink)
{
    double t0 = cpu_now();
    size_t count = 0;
    rtk_hit h;
    if (batch[b]) {
        for (int k = 0; k < repeat; k++) {
            batch_run(b, occlusion, rays, begin, end, batch_occ, batch_hits);
            for (size_t i = 0; i < end - begin; i++)
                count += occlusion ? batch_occ[i] != 0 : batch_hits[i].prim != RTK_INVALID_ID;
        }
        *sink += count;
        return cpu_now() - t0;
    }
    for (size_t i = begin; i < end; i++)
        for (int k = 0; k < repeat; k++)
            count += occlusion ? (b ? any_b(&rays[i], NULL) : any_a(&rays[i], NULL))
                               : (b ? closest_b(&rays[i], &h) : closest_a(&rays[i], &h));
    *sink += count;
    return cpu_now() - t0;
}

static void report(const char *what, double *ratio, int rounds, double total_a, double total_b)
{
    qsort(ratio, (size_t)rounds, sizeof *ratio, cmp_double);
    printf("%s B/A time: median %.4f (quartiles %.4f-%.4f), totals %.4f\n", what, ratio[rounds / 2],
           ratio[rounds / 4], ratio[3 * rounds / 4], total_b / total_a);
}

/* Whether A's and B's wide trees are the same bytes. */
static int same_wide(const rtk_scene *a, const rtk_scene *b)
{
    const rtk_wide_bvh *x = a->wide, *y = b->wide;
    return x && y && x->node_count == y->node_count && x->tri_block_count == y->tri_block_count &&
           x->depth == y->depth && memcmp(x->nodes, y->nodes, sizeof *x->nodes * x->node_count) == 0 &&
           memcmp(x->tris, y->tris, sizeof *x->tris * x->tri_block_count) == 0;
}

/* AB_BUILD: rounds of A's and B's wide build, in alternating order. */
static int time_builds(int rounds)
{
    double *ratio = malloc(sizeof(double) * rounds), ta = 0, tb = 0;
    if (!ratio) {
        fprintf(stderr, "ab: out of memory\n");
        return 2;
    }
    if (!same_wide(scene_a, scene_b)) {
        printf("wide trees differ: A %u nodes, %u blocks, depth %u; B %u nodes, %u blocks, depth %u\n",
               scene_a->wide->node_count, scene_a->wide->tri_block_count, scene_a->wide->depth,
               scene_b->wide->node_count, scene_b->wide->tri_block_count, scene_b->wide->depth);
        if (!getenv("AB_DIFFERENT")) {
            fprintf(stderr, "ab: not timing them (AB_DIFFERENT=1 times them anyway)\n");
            free(ratio);
            return 1;
        }
    } else {
        printf("wide trees identical: %u nodes, %u blocks, depth %u\n", scene_a->wide->node_count,
               scene_a->wide->tri_block_count, scene_a->wide->depth);
    }
    for (int r = 0; r < rounds; r++) {
        double t[2];
        for (int o = 0; o < 2; o++) {
            int b = o ^ (r & 1);
            rtk_scene *s = b ? scene_b : scene_a;
            double t0 = cpu_now();
            if (b)
                B_wide_free(s);
            else
                rtk_wide_free(s);
            rtk_status st = b ? B_wide_build(s, 1, NULL, 0, 1) : rtk_wide_build(s, 1, NULL, 0, 1);
            t[b] = cpu_now() - t0;
            if (st != RTK_OK) {
                free(ratio);
                return fail(b ? "B's wide build" : "A's wide build");
            }
        }
        ratio[r] = t[1] / t[0];
        ta += t[0], tb += t[1];
    }
    report("build  ", ratio, rounds, ta, tb);
    printf("A: %.3f ms a build\n", 1e3 * ta / rounds);
    free(ratio);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: ab MESH.obj variant|embree [ACCEL] [ROUNDS]\n");
        return 2;
    }
    const char *mesh = argv[1], *accel = argc > 3 ? argv[3] : "sah";
    embree_mode = strcmp(argv[2], "embree") == 0;
    const int rounds = argc > 4 ? atoi(argv[4]) : 400;
    if (rounds < 4) {
        fprintf(stderr, "ab: at least 4 rounds\n");
        return 2;
    }
    double rep;
    double nb[2];
    if (!env_number("AB_BATCH_A", 0, 1 << 20, 0, &nb[0]) || !env_number("AB_BATCH", 0, 1 << 20, 0, &nb[1]))
        return 2;
    batch[0] = (size_t)nb[0], batch[1] = (size_t)nb[1];
    if ((double)batch[0] != nb[0] || (double)batch[1] != nb[1]) {
        fprintf(stderr, "ab: AB_BATCH and AB_BATCH_A: give whole numbers of rays\n");
        return 2;
    }
    if ((batch[0] || batch[1]) && strcmp(argv[2], "embree") == 0) {
        fprintf(stderr, "ab: AB_BATCH compares the wide tree's batches, not embree's\n");
        return 2;
    }
    if (!env_number("AB_REPEAT", 1, 64, 1, &rep) || !env_number("AB_AO_SCALE", 1e-9, 1e9, 1, &ao_scale))
        return 2;
    repeat = (int)rep;
    if (repeat != rep) {
        fprintf(stderr, "ab: AB_REPEAT=%g: give a whole number\n", rep);
        return 2;
    }
    path = rtk_simd_from_env();
    if (path == RTK_SIMD_BINARY) {
        fprintf(stderr, "ab: RTK_SIMD=binary has no wide tree to compare\n");
        return 2;
    }
    rtk_log_set_level(RTK_LOG_WARN);
    rtk_registry *reg = NULL;
    const rtk_plugin *p = NULL, *pe = NULL;
    if (rtk_registry_create(&reg) != RTK_OK || rtk_registry_find(reg, RTK_KIND_ACCELERATOR, accel, &p) != RTK_OK)
        return fail(accel);
    scene_a = scene_b = load_and_build(mesh, p, NULL);
    if (!scene_a)
        return 2;
    if (embree_mode) {
        if (rtk_registry_find(reg, RTK_KIND_ACCELERATOR, "embree", &pe) != RTK_OK)
            return fail("embree");
        scene_b = load_and_build(mesh, pe, NULL);
    } else if (getenv("AB_REBUILD") || getenv("AB_BUILD")) {
        scene_b = load_and_build(mesh, p, getenv("AB_SET"));
        if (scene_b) {
            B_wide_free(scene_b);
            if (B_wide_build(scene_b, 1, NULL, 0, 1) != RTK_OK)
                return fail("variant's wide tree");
        }
    }
    if (!scene_b)
        return 2;
    if (!embree_mode && getenv("AB_BUILD"))
        return time_builds(rounds);
    rtk_bench_camera cam;
    rtk_bench_camera_recipe(scene_a->bounds, &cam);
    const char *c = getenv("AB_CAMERA");
    if (c) {
        double e[3], l[3], up[3] = {0, 1, 0}, fov;
        if (sscanf(c, "%lf,%lf,%lf,%lf,%lf,%lf,%lf", &e[0], &e[1], &e[2], &l[0], &l[1], &l[2], &fov) != 7 ||
            rtk_bench_camera_look(e, l, up, fov, &cam) != RTK_OK) {
            fprintf(stderr, "ab: AB_CAMERA=%s: give EX,EY,EZ,LX,LY,LZ,FOV (a view not along +-y, 0 < FOV < 180)\n", c);
            return 2;
        }
    }
    const size_t pixels = (size_t)WIDTH * HEIGHT;
    /* In huge pages, as rtk bench keeps its rays (docs/bench-vs-embree.md). */
    rtk_ray *primary = rtk_alloc_large(sizeof *primary * pixels);
    rtk_ray *ao = rtk_alloc_large(sizeof *ao * pixels * AO_PER_HIT);
    rtk_hit *hits = rtk_alloc_large(sizeof *hits * pixels);
    double *ratio_ao = malloc(sizeof(double) * rounds), *ratio_pr = malloc(sizeof(double) * rounds);
    if (!primary || !ao || !hits || !ratio_ao || !ratio_pr) {
        fprintf(stderr, "ab: out of memory\n");
        return 2;
    }
    rtk_bench_primary_rays(&cam, WIDTH, HEIGHT, primary);
    const double diag = rtk_bench_diag(scene_a->bounds);
    size_t n_ao = 0, primary_diff = 0, ao_diff = 0, occluded = 0;
    for (size_t i = 0; i < pixels; i++) {
        rtk_hit hb;
        int ha = closest_a(&primary[i], &hits[i]), hit_b = closest_b(&primary[i], &hb);
        primary_diff += ha != hit_b || (ha && (hits[i].prim != hb.prim || hits[i].t != hb.t));
        if (!ha)
            continue;
        hits[i].inst = RTK_INVALID_ID;
        rtk_bench_ao_rays(scene_a, &primary[i], &hits[i], i, diag, AO_PER_HIT, &ao[n_ao]);
        for (int k = 0; k < AO_PER_HIT; k++)
            ao[n_ao + k].tmax *= (float)ao_scale;
        n_ao += AO_PER_HIT;
    }
    double nodes[2] = {0, 0}, tris[2] = {0, 0};
    for (size_t i = 0; i < n_ao; i++) {
        rtk_trace_work wa = {0, 0}, wb = {0, 0};
        int oa = any_a(&ao[i], &wa), ob = any_b(&ao[i], &wb);
        ao_diff += oa != ob;
        occluded += oa;
        nodes[0] += wa.nodes, tris[0] += wa.triangles, nodes[1] += wb.nodes, tris[1] += wb.triangles;
    }
    batch_occ = malloc(n_ao ? n_ao : 1);
    batch_hits = malloc(sizeof *batch_hits * (n_ao > pixels ? n_ao : pixels));
    if (!batch_occ || !batch_hits) {
        fprintf(stderr, "ab: out of memory\n");
        return 2;
    }
    for (int b = 0; b < 2; b++) {
        if (!batch[b])
            continue;
        /* The batches against A's single rays, ray by ray. */
        batch_run(b, 1, ao, 0, n_ao, batch_occ, NULL);
        for (size_t i = 0; i < n_ao; i++)
            ao_diff += (batch_occ[i] != 0) != (any_a(&ao[i], NULL) != 0);
        batch_run(b, 0, primary, 0, pixels, NULL, batch_hits);
        for (size_t i = 0; i < pixels; i++) {
            rtk_hit ha;
            int hit_a = closest_a(&primary[i], &ha), hit_b = batch_hits[i].prim != RTK_INVALID_ID;
            primary_diff += hit_a != hit_b || (hit_a && (ha.prim != batch_hits[i].prim || ha.t != batch_hits[i].t));
        }
    }
    printf("%s, %s: %zu primary rays, %zu AO rays (%zu occluded); answers differing: %zu primary, %zu AO\n", mesh,
           accel, pixels, n_ao, occluded, primary_diff, ao_diff);
    if (!embree_mode)
        printf("AO work per ray: A %.3f nodes, %.3f triangles; B %.3f nodes, %.3f triangles\n", nodes[0] / n_ao,
               tris[0] / n_ao, nodes[1] / n_ao, tris[1] / n_ao);
    /* Embree's t differs in the last bits and its non-watertight test
     * may pick the other triangle of a shared edge: counted, not fatal. */
    if (!embree_mode && (primary_diff || ao_diff) && !getenv("AB_DIFFERENT")) {
        fprintf(stderr, "ab: the two tracers answer differently; not timing them\n");
        return 1;
    }
    const size_t ao_chunk = n_ao / 8 / AO_PER_HIT * AO_PER_HIT, pr_chunk = pixels / 4; /* whole hits */
    double ta = 0, tb = 0, pa = 0, pb = 0;
    size_t sink = 0;
    for (int r = 0; r < rounds; r++) {
        double t[2], u[2];
        size_t ao_at = (size_t)(r % 8) * ao_chunk, pr_at = (size_t)(r % 4) * pr_chunk;
        for (int o = 0; o < 2; o++) {
            int b = o ^ (r & 1);
            t[b] = time_chunk(b, 1, ao, ao_at, ao_at + ao_chunk, &sink);
        }
        for (int o = 0; o < 2; o++) {
            int b = o ^ (r & 1);
            u[b] = time_chunk(b, 0, primary, pr_at, pr_at + pr_chunk, &sink);
        }
        ratio_ao[r] = t[1] / t[0], ratio_pr[r] = u[1] / u[0];
        ta += t[0], tb += t[1], pa += u[0], pb += u[1];
    }
    report("AO     ", ratio_ao, rounds, ta, tb);
    report("primary", ratio_pr, rounds, pa, pb);
    printf("A (%s): %.2f AO, %.2f primary Mrays per CPU-second (checksum %zu)\n", rtk_simd_name(path),
           (double)ao_chunk * rounds / ta / 1e6, (double)pr_chunk * rounds / pa / 1e6, sink);
    return 0;
}

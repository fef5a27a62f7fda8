/* testdevice: a device accelerator (ABI 3.5) whose "device" is the CPU,
 * built only for tests: it traces the tree it is given with the code the
 * cuda plugin runs on a GPU (kernel/accel/device_tree.h), so that the
 * kernel's side of device accelerators (the builder, the cache, batches,
 * reports, refusals) and `rtk conform` are tested on machines without a
 * GPU.
 *
 * It runs device programs (plugins/integrators/device_programs.h) on the CPU as
 * the cuda plugin's fallback does, so renders through them must equal the
 * kernel's own, bit for bit.
 *
 * Parameters:
 *   builder   string  sah   the accelerator that builds its trees
 *   programs  bool    true  run integrators' device programs (false: trace batches only)
 *   wavefront bool    false run path's program as a wavefront (rtk_program_path_wavefront)
 * With RTK_TESTDEVICE_FAIL=create or attach in the environment it fails
 * there, with a message (tests of the kernel's errors). */
#include "accel/device_tree.h"
#include "../../../plugins/integrators/device_programs.h"

#include <rtk/rtk.h>

#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef struct testdevice {
    int fail_attach;
    int programs, wavefront;
    rtk_flat_scene scene;
    rtk_flat_tree *meshes;
    rtk_program_scene program_scene;
    void *program_block; /* rtk_program_scene_of's */
    uint64_t bytes;
    _Atomic uint64_t rays, batches, samples;
    pthread_mutex_t lock;
    double trace_seconds; /* the batch loops' wall-clock time, as a device times its kernels */
    double shade_seconds; /* the same for programs */
} testdevice;

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Counts a batch of count rays that took seconds. */
static void count_batch(testdevice *d, uint32_t count, double seconds)
{
    atomic_fetch_add(&d->rays, count);
    atomic_fetch_add(&d->batches, 1);
    pthread_mutex_lock(&d->lock);
    d->trace_seconds += seconds;
    pthread_mutex_unlock(&d->lock);
}

static rtk_status testdevice_create(const rtk_params *params, void **state)
{
    const char *fail = getenv("RTK_TESTDEVICE_FAIL");
    fail = fail ? fail : "";
    if (strcmp(fail, "create") == 0)
        return rtk_error(RTK_ERR_UNSUPPORTED, "testdevice: no device (RTK_TESTDEVICE_FAIL=create)");
    testdevice *d = calloc(1, sizeof *d);
    if (!d)
        return rtk_error(RTK_ERR_NOMEM, "testdevice: out of memory");
    d->fail_attach = strcmp(fail, "attach") == 0;
    d->programs = rtk_params_bool(params, "programs");
    d->wavefront = rtk_params_bool(params, "wavefront");
    pthread_mutex_init(&d->lock, NULL);
    *state = d;
    return RTK_OK;
}

static rtk_status testdevice_attach(void *state, const rtk_device_tree *tree)
{
    testdevice *d = state;
    if (d->fail_attach)
        return rtk_error(RTK_ERR_NOMEM, "testdevice: out of device memory (RTK_TESTDEVICE_FAIL=attach)");
    d->meshes = calloc(tree->mesh_count ? tree->mesh_count : 1, sizeof *d->meshes);
    if (!d->meshes)
        return rtk_error(RTK_ERR_NOMEM, "testdevice: out of memory");
    rtk_flat_scene_of(tree, d->meshes, &d->scene);
    if (rtk_program_scene_of(tree, &d->scene, &d->program_block, &d->program_scene) != 0)
        return rtk_error(RTK_ERR_NOMEM, "testdevice: out of memory");
    d->bytes = (uint64_t)tree->node_count * sizeof(rtk_bvh_node) + (uint64_t)tree->slot_count * (4 + 36) +
               (uint64_t)tree->tlas_node_count * sizeof(rtk_bvh_node) +
               (uint64_t)tree->instance_count * (4 + sizeof(rtk_device_instance)) +
               (uint64_t)tree->slot_count * (4 + (tree->normals ? 36 : 0)); /* programs' slots and normals */
    for (uint32_t i = 0; i < tree->mesh_count; i++)
        d->bytes += (uint64_t)tree->meshes[i].node_count * sizeof(rtk_bvh_node) +
                    (uint64_t)tree->meshes[i].slot_count * (4 + 36);
    return RTK_OK;
}

static void testdevice_closest_batch(const void *state, const rtk_ray *rays, uint32_t count, rtk_hit *hits)
{
    testdevice *d = (testdevice *)state;
    const double t0 = now();
    for (uint32_t i = 0; i < count; i++)
        rtk_flat_scene_closest(&d->scene, &rays[i], &hits[i]);
    count_batch(d, count, now() - t0);
}

static void testdevice_any_batch(const void *state, const rtk_ray *rays, uint32_t count, uint8_t *occluded)
{
    testdevice *d = (testdevice *)state;
    const double t0 = now();
    for (uint32_t i = 0; i < count; i++)
        occluded[i] = (uint8_t)rtk_flat_scene_any(&d->scene, &rays[i]);
    count_batch(d, count, now() - t0);
}

static rtk_status testdevice_shade(const void *state, rtk_shade_batch *b)
{
    testdevice *d = (testdevice *)state;
    const rtk_program p = rtk_program_of(b->program);
    if (!d->programs || p.kind == RTK_PROGRAM_NONE)
        return rtk_error(RTK_ERR_UNSUPPORTED, "testdevice: %s", d->programs ? "unknown program" : "programs = false");
    const double t0 = now();
    rtk_program_scene scene = d->program_scene;
    scene.albedo = b->albedo;
    uint64_t traced = 0, invalid = 0;
    if (d->wavefront && p.kind == RTK_PROGRAM_PATH && b->count) {
        rtk_path_walk *walks = malloc(sizeof *walks * b->count);
        uint32_t *live = malloc(sizeof *live * b->count);
        rtk_program_count *counts = malloc(sizeof *counts * b->count);
        if (!walks || !live || !counts) {
            free(walks), free(live), free(counts);
            return rtk_error(RTK_ERR_NOMEM, "testdevice: out of memory for a wavefront of %u samples", b->count);
        }
        rtk_program_path_wavefront(&p, &scene, b->gen, b->count, b->rays, b->diffs, b->pos, b->out, counts, walks,
                                   live);
        for (uint32_t i = 0; i < b->count; i++)
            traced += counts[i].traced, invalid += counts[i].invalid;
        free(walks), free(live), free(counts);
    } else {
        for (uint32_t i = 0; i < b->count; i++) {
            rtk_program_count c;
            rtk_program_run(&p, &scene, b->gen, &b->pos[i], &b->rays[i], b->diffs ? &b->diffs[i] : NULL, &b->out[i],
                            &c);
            traced += c.traced, invalid += c.invalid;
        }
    }
    b->rays_traced = traced;
    b->invalid_rays = invalid;
    if (b->count) {
        atomic_fetch_add(&d->rays, traced);
        atomic_fetch_add(&d->batches, 1);
        atomic_fetch_add(&d->samples, b->count);
        pthread_mutex_lock(&d->lock);
        d->shade_seconds += now() - t0;
        pthread_mutex_unlock(&d->lock);
    }
    return RTK_OK;
}

static void testdevice_report(const void *state, rtk_device_report *out)
{
    testdevice *d = (testdevice *)state;
    strcpy(out->device, "CPU (rtk's test device)");
    out->rays = atomic_load(&d->rays);
    out->batches = atomic_load(&d->batches);
    pthread_mutex_lock(&d->lock);
    out->trace_seconds = d->trace_seconds;
    out->shade_seconds = d->shade_seconds;
    pthread_mutex_unlock(&d->lock);
    out->samples = atomic_load(&d->samples);
    out->device_bytes = d->bytes;
}

static void testdevice_destroy(void *state)
{
    testdevice *d = state;
    pthread_mutex_destroy(&d->lock);
    free(d->meshes);
    free(d->program_block);
    free(d);
}

static const rtk_param_desc testdevice_params[] = {
    {.name = "builder", .type = RTK_PARAM_STRING, .def_string = "sah",
     .doc = "the accelerator that builds the trees this device traces"},
    {.name = "programs", .type = RTK_PARAM_BOOL, .def = 1,
     .doc = "run integrators' device programs (false: trace their batches only)"},
    {.name = "wavefront", .type = RTK_PARAM_BOOL, .def = 0,
     .doc = "run path's program as a wavefront, step by step over all samples (false: one sample at a time)"},
};

static const rtk_accelerator_fns testdevice_fns = {
    .size = sizeof(rtk_accelerator_fns),
    .create = testdevice_create,
    .destroy = testdevice_destroy,
    .closest_batch = testdevice_closest_batch,
    .any_batch = testdevice_any_batch,
    .attach = testdevice_attach,
    .report = testdevice_report,
    .shade = testdevice_shade,
};

/* Built a second time as a plugin of an older ABI minor, for the kernel's
 * fallbacks (tests/plugins/device/meson.build). */
#ifndef TESTDEVICE_ABI_MINOR
#define TESTDEVICE_ABI_MINOR RTK_ABI_MINOR
#define TESTDEVICE_NAME "testdevice"
#endif

static const rtk_plugin testdevice_plugin = {
    .size = sizeof(rtk_plugin),
    .abi_major = RTK_ABI_MAJOR,
    .abi_minor = TESTDEVICE_ABI_MINOR,
    .kind = RTK_KIND_ACCELERATOR,
    .name = TESTDEVICE_NAME,
    .version = "1.0",
    .summary = "a device accelerator on the CPU, for tests of the kernel's device support",
    .params = testdevice_params,
    .param_count = RTK_COUNTOF(testdevice_params),
    .functions = &testdevice_fns,
};

RTK_PLUGIN_ENTRY(testdevice_plugin)

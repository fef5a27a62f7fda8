/* Fuzz target: the BVH cache reader. The target builds a small sphere's
 * tree once and saves it as the seed (into the first corpus directory on
 * the command line, when there is one). Each input then gets the hashes
 * and the plugin stamp the reader expects, and a checksum recomputed over
 * its header, nodes and leaf ids whenever the header's counts fit the
 * input: so the fuzzer reaches the structural validation behind the
 * checksum instead of stopping at it. */
#include "fuzz_common.h"

#include "config/config.h"
#include "render/render.h"

#include <math.h>
#include <sys/stat.h>

static rtk_registry *registry; /* held for the process: the plugin lives in it */
static rtk_scene *probe;
static const rtk_plugin *median;
static rtk_params *params;
static uint64_t geometry, builder;
static unsigned char stamp_fields[RTK_BVH_CACHE_AT_NODE_COUNT - RTK_BVH_CACHE_AT_GEOMETRY];

/* A UV sphere of 2 * slices * (stacks - 1) triangles. [caller frees] */
static rtk_scene *make_sphere(uint32_t stacks, uint32_t slices)
{
    rtk_scene *s = rtk_scene_new("sphere", 0);
    uint32_t top, bottom, idx;
    if (!s || rtk_scene_add_vertex(s, 0.0, 1.0, 0.0, &top) != RTK_OK ||
        rtk_scene_add_vertex(s, 0.0, -1.0, 0.0, &bottom) != RTK_OK)
        abort();
    for (uint32_t i = 1; i < stacks; i++)
        for (uint32_t j = 0; j < slices; j++) {
            double theta = M_PI * i / stacks, phi = 2.0 * M_PI * j / slices;
            if (rtk_scene_add_vertex(s, sin(theta) * cos(phi), cos(theta), sin(theta) * sin(phi), &idx) != RTK_OK)
                abort();
        }
#define RING(i, j) (2 + ((i) - 1) * slices + ((j) % slices))
    for (uint32_t j = 0; j < slices; j++) {
        rtk_scene_add_triangle(s, top, RING(1, j + 1), RING(1, j), NULL, NULL, RTK_INVALID_ID);
        rtk_scene_add_triangle(s, bottom, RING(stacks - 1, j), RING(stacks - 1, j + 1), NULL, NULL, RTK_INVALID_ID);
    }
    for (uint32_t i = 1; i + 1 < stacks; i++)
        for (uint32_t j = 0; j < slices; j++) {
            rtk_scene_add_triangle(s, RING(i, j), RING(i, j + 1), RING(i + 1, j), NULL, NULL, RTK_INVALID_ID);
            rtk_scene_add_triangle(s, RING(i, j + 1), RING(i + 1, j + 1), RING(i + 1, j), NULL, NULL, RTK_INVALID_ID);
        }
#undef RING
    if (rtk_scene_finish(s) != RTK_OK)
        abort();
    return s;
}

static uint32_t read_u32(const unsigned char *b, size_t at)
{
    uint32_t v;
    memcpy(&v, b + at, sizeof v);
    return v;
}

int LLVMFuzzerInitialize(int *argc, char ***argv);
int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    fuzz_quiet();
    if (rtk_registry_create(&registry) != RTK_OK ||
        rtk_registry_find(registry, RTK_KIND_ACCELERATOR, "median", &median) != RTK_OK) {
        fprintf(stderr, "rtk fuzz: no median plugin: %s\n", rtk_error_message());
        abort();
    }
    params = rtk_params_defaults(median);
    rtk_scene *ref = make_sphere(6, 8);
    probe = make_sphere(6, 8);
    if (!params || rtk_bvh_build(ref, median, params, 1) != RTK_OK)
        abort();
    geometry = rtk_bvh_cache_geometry_hash(ref);
    builder = rtk_bvh_cache_builder_hash(median, params);
    char seed[512];
    snprintf(seed, sizeof seed, "%s/seed.bvh", fuzz_workdir());
    if (rtk_bvh_cache_save(ref, seed, geometry, builder, median) != RTK_OK)
        abort();
    FILE *f = fopen(seed, "rb");
    unsigned char header[RTK_BVH_CACHE_HEADER_SIZE];
    if (!f || fread(header, 1, sizeof header, f) != sizeof header)
        abort();
    memcpy(stamp_fields, header + RTK_BVH_CACHE_AT_GEOMETRY, sizeof stamp_fields);
    rewind(f);
    /* The seed goes into the first corpus directory named (not a flag). */
    for (int i = 1; i < *argc; i++) {
        struct stat st;
        const char *a = (*argv)[i];
        if (a[0] == '-' || stat(a, &st) != 0 || !S_ISDIR(st.st_mode))
            continue;
        char out[4096];
        snprintf(out, sizeof out, "%s/rtk-seed-sphere.bvh", a);
        FILE *o = fopen(out, "wb");
        unsigned char buf[4096];
        size_t n;
        while (o && (n = fread(buf, 1, sizeof buf, f)) > 0)
            fwrite(buf, 1, n, o);
        if (o)
            fclose(o);
        break;
    }
    fclose(f);
    rtk_scene_free(ref);
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    unsigned char *b = malloc(size ? size : 1);
    if (!b)
        return 0;
    memcpy(b, data, size);
    const size_t header = RTK_BVH_CACHE_HEADER_SIZE;
    if (size >= header) {
        memcpy(b + RTK_BVH_CACHE_AT_GEOMETRY, stamp_fields, sizeof stamp_fields);
        uint64_t nodes = read_u32(b, RTK_BVH_CACHE_AT_NODE_COUNT), prims = read_u32(b, RTK_BVH_CACHE_AT_PRIM_COUNT);
        if (header + 32 * nodes + 4 * prims + 8 == size) {
            uint64_t h = rtk_hash64(b, header, RTK_BVH_CACHE_SEED);
            h = rtk_hash64(b + header, 32 * nodes, h);
            h = rtk_hash64(b + header + 32 * nodes, 4 * prims, h);
            memcpy(b + size - 8, &h, sizeof h);
        }
    }
    const char *path = fuzz_write("fuzz.bvh", b, size);
    free(b);
    rtk_bvh_cache_load(probe, path, geometry, builder, median, 1);
    return 0;
}

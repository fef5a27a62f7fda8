/* Tests for kernel/accel/bvh_cache.c: a saved BVH loads back bit for bit and
 * traces the same; every kind of damaged, stale or hostile cache file is
 * refused with exactly one warning naming the file and the reason, the
 * build falls back to the plugin, and the rewritten file loads next time. */
#include "render/render.h"
#include "config/config.h"
#include "image/image.h"

#include <dirent.h>
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <ftw.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "check.h"

/* Runs many checks quietly; prints one line for the group. */
static void group_done(const char *name, int before_failed, int before_passed)
{
    printf("%s  %s (%d checks)\n", failed == before_failed ? "ok  " : "FAIL", name,
           passed + failed - before_failed - before_passed);
}

/* ---- stderr capture: warnings are counted, not just printed ---- */

typedef struct capture {
    int saved;
    FILE *file;
} capture;

static void capture_begin(capture *c)
{
    fflush(stderr);
    c->file = tmpfile();
    c->saved = dup(STDERR_FILENO);
    if (c->file)
        dup2(fileno(c->file), STDERR_FILENO);
}

/* Restores stderr and returns what was written. [caller frees] */
static char *capture_end(capture *c)
{
    fflush(stderr);
    dup2(c->saved, STDERR_FILENO);
    close(c->saved);
    char *text = calloc(1, 65536);
    if (!text) {
        printf("FAIL  out of memory\n");
        exit(1);
    }
    if (c->file) {
        rewind(c->file);
        size_t n = fread(text, 1, 65535, c->file);
        text[n] = '\0';
    }
    if (c->file)
        fclose(c->file);
    return text;
}

/* text for a "%s", never NULL (sanitizer builds cannot prove it). */
static const char *shown(const char *text)
{
    return text ? text : "";
}

static int count_of(const char *text, const char *needle)
{
    int n = 0;
    for (const char *p = text; (p = strstr(p, needle)); p += strlen(needle))
        n++;
    return n;
}

/* ---- files ---- */

static unsigned char *read_file(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    rewind(f);
    unsigned char *buf = malloc(n > 0 ? (size_t)n : 1);
    if (buf && fread(buf, 1, (size_t)n, f) != (size_t)n) {
        free(buf);
        buf = NULL;
    }
    fclose(f);
    *size = (size_t)n;
    return buf;
}

static int write_file(const char *path, const void *data, size_t size)
{
    unlink(path);
    FILE *f = fopen(path, "wb");
    if (!f)
        return 0;
    int ok = fwrite(data, 1, size, f) == size;
    return fclose(f) == 0 && ok;
}

static int remove_entry(const char *path, const struct stat *st, int flag, struct FTW *ftw)
{
    (void)st, (void)flag, (void)ftw;
    return remove(path);
}

/* Number of entries of dir whose name contains part. */
static int dir_count(const char *dir, const char *part)
{
    DIR *d = opendir(dir);
    int n = 0;
    if (!d)
        return -1;
    for (struct dirent *e; (e = readdir(d));)
        n += strstr(e->d_name, part) != NULL;
    closedir(d);
    return n;
}

/* ---- scenes ---- */

/* A UV sphere of 2 * slices * (stacks - 1) triangles; bump moves one
 * vertex by one ulp. [caller frees] */
static rtk_scene *make_sphere(uint32_t stacks, uint32_t slices, int bump)
{
    rtk_scene *s = rtk_scene_new("sphere", 0);
    uint32_t top, bottom, idx;
    rtk_scene_add_vertex(s, 0.0, 1.0, 0.0, &top);
    rtk_scene_add_vertex(s, 0.0, -1.0, 0.0, &bottom);
    uint32_t first = 2;
    for (uint32_t i = 1; i < stacks; i++) {
        double theta = M_PI * i / stacks;
        for (uint32_t j = 0; j < slices; j++) {
            double phi = 2.0 * M_PI * j / slices;
            double x = sin(theta) * cos(phi), y = cos(theta), z = sin(theta) * sin(phi);
            if (bump && i == stacks / 2 && j == 3)
                x = nextafterf((float)x, 2.0f);
            rtk_scene_add_vertex(s, x, y, z, &idx);
        }
    }
#define RING(i, j) (first + ((i) - 1) * slices + ((j) % slices))
    for (uint32_t j = 0; j < slices; j++) {
        rtk_scene_add_triangle(s, top, RING(1, j + 1), RING(1, j), NULL, NULL, RTK_INVALID_ID);
        rtk_scene_add_triangle(s, bottom, RING(stacks - 1, j), RING(stacks - 1, j + 1), NULL, NULL, RTK_INVALID_ID);
    }
    for (uint32_t i = 1; i + 1 < stacks; i++) {
        for (uint32_t j = 0; j < slices; j++) {
            rtk_scene_add_triangle(s, RING(i, j), RING(i, j + 1), RING(i + 1, j), NULL, NULL, RTK_INVALID_ID);
            rtk_scene_add_triangle(s, RING(i, j + 1), RING(i + 1, j + 1), RING(i + 1, j), NULL, NULL, RTK_INVALID_ID);
        }
    }
#undef RING
    if (rtk_scene_finish(s) != RTK_OK) {
        printf("FAIL  sphere: %s\n", rtk_error_message());
        exit(1);
    }
    return s;
}

/* ---- rays ---- */

#define RAY_COUNT 1500

static rtk_ray rays[RAY_COUNT];

static void make_rays(void)
{
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 42, 7);
    for (int i = 0; i < RAY_COUNT; i++) {
        rtk_vec3 o = rtk_vec3_make(4.0f * rtk_pcg32_float(&rng) - 2.0f, 4.0f * rtk_pcg32_float(&rng) - 2.0f,
                                   4.0f * rtk_pcg32_float(&rng) - 2.0f);
        rtk_vec3 t = rtk_vec3_make(1.6f * rtk_pcg32_float(&rng) - 0.8f, 1.6f * rtk_pcg32_float(&rng) - 0.8f,
                                   1.6f * rtk_pcg32_float(&rng) - 0.8f);
        rays[i].org = o;
        rays[i].dir = rtk_vec3_sub(t, o);
        rays[i].tmin = 0.0f;
        rays[i].tmax = (i % 5 == 0) ? 0.5f : INFINITY;
    }
}

/* Number of rays on which a and b disagree (closest hit or any hit). */
static int trace_differences(const rtk_scene *a, const rtk_scene *b)
{
    int diff = 0;
    for (int i = 0; i < RAY_COUNT; i++) {
        rtk_hit ha, hb;
        int ra = rtk_bvh_closest(a, &rays[i], &ha), rb = rtk_bvh_closest(b, &rays[i], &hb);
        if (ra != rb || ha.prim != hb.prim || ha.t != hb.t || ha.u != hb.u || ha.v != hb.v)
            diff++;
        else if (rtk_bvh_any(a, &rays[i]) != rtk_bvh_any(b, &rays[i]))
            diff++;
    }
    return diff;
}

/* Rays on which s's closest hit differs from brute force. */
static int brute_differences(const rtk_scene *s, int stride)
{
    int diff = 0;
    for (int i = 0; i < RAY_COUNT; i += stride) {
        uint32_t best = RTK_INVALID_ID;
        float best_t = rays[i].tmax;
        for (uint32_t p = 0; p < s->triangle_count; p++) {
            rtk_vec3 a, b, c;
            float t, u, v;
            rtk_scene_triangle(s, p, &a, &b, &c);
            if (rtk_intersect_triangle(&rays[i], a, b, c, &t, &u, &v) && (t < best_t || best == RTK_INVALID_ID)) {
                best = p;
                best_t = t;
            }
        }
        rtk_hit h;
        rtk_bvh_closest(s, &rays[i], &h);
        if (h.prim != best || (best != RTK_INVALID_ID && h.t != best_t))
            diff++;
    }
    return diff;
}

/* The wide trees, byte for byte (the corners live in their blocks). */
static int same_wide(const rtk_scene *a, const rtk_scene *b)
{
    const rtk_wide_bvh *x = a->wide, *y = b->wide;
    return x && y && x->node_count == y->node_count && x->tri_block_count == y->tri_block_count &&
           memcmp(x->nodes, y->nodes, sizeof *x->nodes * x->node_count) == 0 &&
           memcmp(x->tris, y->tris, sizeof *x->tris * x->tri_block_count) == 0;
}

static int same_bvh(const rtk_scene *a, const rtk_scene *b)
{
    return a->node_count == b->node_count && a->bvh_depth == b->bvh_depth && a->nodes && b->nodes &&
           memcmp(a->nodes, b->nodes, sizeof *a->nodes * a->node_count) == 0 &&
           memcmp(a->prim_ids, b->prim_ids, sizeof *a->prim_ids * a->triangle_count) == 0 && same_wide(a, b);
}

/* ---- the fixture ---- */

static const rtk_plugin *median;
static rtk_params *params;
static rtk_scene *ref;        /* built by the plugin */
static rtk_scene *probe;      /* the same geometry, loads go here */
static uint64_t ghash, bhash;
static char dir[256], path[512];
static unsigned char *good;   /* the good cache file */
static size_t good_size;

#define AT_NODES RTK_BVH_CACHE_AT_NODE_COUNT
#define AT_PRIMS RTK_BVH_CACHE_AT_PRIM_COUNT
#define AT_DEPTH RTK_BVH_CACHE_AT_DEPTH

static uint32_t get32(const unsigned char *b, size_t off)
{
    uint32_t v;
    memcpy(&v, b + off, 4);
    return v;
}

static void put32(unsigned char *b, size_t off, uint32_t v)
{
    memcpy(b + off, &v, 4);
}

/* Recomputes the checksum of a file image after a deliberate edit, so
 * that only the structural validation stands between it and the scene. */
static void fix_checksum(unsigned char *b, size_t size)
{
    uint32_t nodes = get32(b, AT_NODES), prims = get32(b, AT_PRIMS);
    size_t node_bytes = 32 * (size_t)nodes, prim_bytes = 4 * (size_t)prims;
    if (size != RTK_BVH_CACHE_HEADER_SIZE + node_bytes + prim_bytes + 8)
        return;
    uint64_t h = rtk_hash64(b, RTK_BVH_CACHE_HEADER_SIZE, RTK_BVH_CACHE_SEED);
    h = rtk_hash64(b + RTK_BVH_CACHE_HEADER_SIZE, node_bytes, h);
    h = rtk_hash64(b + RTK_BVH_CACHE_HEADER_SIZE + node_bytes, prim_bytes, h);
    memcpy(b + size - 8, &h, 8);
}

/* Loads path into probe; expects refusal with one warning naming the
 * file and containing reason (NULL: any reason). */
static void expect_refused_as_is(const char *name, const char *reason)
{
    capture c;
    capture_begin(&c);
    int used = rtk_bvh_cache_load(probe, path, ghash, bhash, median, 1);
    char *err = capture_end(&c);
    check(!used, "%s: refused", name);
    check(probe->node_count == 0 && !probe->nodes && !probe->prim_ids,
          "%s: scene left without a BVH", name);
    check(count_of(err, "warning") == 1, "%s: one warning (got: %s)", name, shown(err));
    check(strstr(err, path) != NULL, "%s: the warning names the file (got: %s)", name, shown(err));
    if (reason)
        check(strstr(err, reason) != NULL, "%s: the warning says '%s' (got: %s)", name, reason, shown(err));
    free(err);
}

/* Writes data at path, then expect_refused_as_is. */
static void expect_refused(const char *name, const void *data, size_t size, const char *reason)
{
    if (!write_file(path, data, size)) {
        check(0, "%s: cannot write the damaged file", name);
        return;
    }
    expect_refused_as_is(name, reason);
}

/* Writes data at path, then builds through the cache: one warning, the
 * plugin's tree, the good file rewritten, and it loads next time. */
static void expect_rebuilt(const char *name, const void *data, size_t size)
{
    if (!write_file(path, data, size)) {
        check(0, "%s: cannot write the damaged file", name);
        return;
    }
    rtk_bvh_cache_use use;
    capture c;
    capture_begin(&c);
    rtk_status st = rtk_bvh_build_cached(probe, median, params, 1, dir, &use);
    char *err = capture_end(&c);
    check(st == RTK_OK && !use.from_cache, "%s: rebuilt by the plugin", name);
    check(count_of(err, "warning") == 1 && strstr(err, path), "%s: one warning naming the file (got: %s)", name,
          shown(err));
    check(same_bvh(ref, probe), "%s: rebuilt tree equals the plugin's", name);
    check(strcmp(use.file, path) == 0, "%s: report names the file rewritten", name);
    free(err);
    size_t n = 0;
    unsigned char *now = read_file(path, &n);
    check(now && n == good_size && memcmp(now, good, n) == 0, "%s: good file written back", name);
    free(now);
    capture_begin(&c);
    st = rtk_bvh_build_cached(probe, median, params, 1, dir, &use);
    err = capture_end(&c);
    check(st == RTK_OK && use.from_cache && count_of(err, "warning") == 0, "%s: loads next time (got: %s)", name,
          shown(err));
    check(same_bvh(ref, probe), "%s: loaded tree equals the plugin's", name);
    free(err);
}

static void test_hash(void)
{
    uint32_t one = 1;
    unsigned char little;
    memcpy(&little, &one, 1);
    if (little) {
        /* XXH64 reference values. */
        check(rtk_hash64("", 0, 0) == 0xEF46DB3751D8E999ull, "hash of \"\" is XXH64's");
        check(rtk_hash64("abc", 3, 0) == 0x44BC2CF5AD770999ull, "hash of \"abc\" is XXH64's");
        const char *s = "Nobody inspects the spammish repetition";
        check(rtk_hash64(s, strlen(s), 0) == 0xFBCEA83C8A378BF1ull, "hash of a 39-byte text is XXH64's");
    }
    check(rtk_hash64(NULL, 0, 5) == rtk_hash64("", 0, 5), "hash of nothing takes NULL");
    printf("ok    hash: XXH64 reference values\n");
}

static void test_hashes(void)
{
    int f0 = failed, p0 = passed;
    rtk_scene *same = make_sphere(40, 48, 0), *moved = make_sphere(40, 48, 1);
    check(rtk_bvh_cache_geometry_hash(same) == ghash, "geometry hash: same for the same geometry");
    check(rtk_bvh_cache_geometry_hash(moved) != ghash, "geometry hash: one vertex one ulp away differs");
    rtk_params *other = rtk_params_defaults(median);
    check(rtk_bvh_cache_builder_hash(median, other) == bhash, "builder hash: same for the same params");
    rtk_params_set_text(other, "max_leaf", "2");
    uint64_t leaf2 = rtk_bvh_cache_builder_hash(median, other);
    check(leaf2 != bhash, "builder hash: max_leaf changes it");
    rtk_params_set_text(other, "max_leaf", "4");
    rtk_params_set_text(other, "mode", "spatial");
    check(rtk_bvh_cache_builder_hash(median, other) != bhash && rtk_bvh_cache_builder_hash(median, other) != leaf2,
          "builder hash: mode changes it");
    rtk_params_destroy(other);
    rtk_scene_free(same);
    rtk_scene_free(moved);
    group_done("hashes of geometry and builder", f0, p0);
}

static void test_round_trip(void)
{
    int f0 = failed, p0 = passed;
    check(rtk_bvh_cache_save(ref, path, ghash, bhash, median) == RTK_OK, "save: %s", rtk_error_message());
    good = read_file(path, &good_size);
    check(good && good_size == RTK_BVH_CACHE_HEADER_SIZE + 32 * (size_t)ref->node_count +
                                  4 * (size_t)ref->triangle_count + 8,
          "save: file size is header + nodes + prim ids + checksum");
    check(good && memcmp(good, "RTKBVH\0\0", 8) == 0 && get32(good, RTK_BVH_CACHE_AT_VERSION) == 1, "save: magic and version");
    check(dir_count(dir, ".tmp") == 0, "save: no temporary file left");
    capture c;
    capture_begin(&c);
    int used = rtk_bvh_cache_load(probe, path, ghash, bhash, median, 1);
    char *err = capture_end(&c);
    check(used && err[0] == '\0', "load: used without a word (got: %s)", shown(err));
    free(err);
    check(same_bvh(ref, probe), "load: identical nodes, prim ids, triangle layout and depth");
    check((ref->wide != NULL) == (probe->wide != NULL), "load: the wide tree is made as after a plugin build");
    check(trace_differences(ref, probe) == 0, "load: identical closest and any hits on %d random rays", RAY_COUNT);
    check(brute_differences(probe, 7) == 0, "load: closest hits agree with brute force");
    /* A missing file is no reason to warn. */
    char missing[600];
    snprintf(missing, sizeof missing, "%s/none.bvh", dir);
    capture_begin(&c);
    used = rtk_bvh_cache_load(probe, missing, ghash, bhash, median, 1);
    err = capture_end(&c);
    check(!used && err[0] == '\0', "load: a missing file is silent (got: %s)", shown(err));
    free(err);
    group_done("save, load: the same tree and the same hits", f0, p0);
}

static void test_truncation(void)
{
    int f0 = failed, p0 = passed;
    const size_t header = RTK_BVH_CACHE_HEADER_SIZE;
    const size_t lengths[] = {0, 7, 8, header - 1, header, header + 5, header + 32 * 10,
                              good_size / 2, good_size - 9, good_size - 8, good_size - 1};
    for (size_t i = 0; i < RTK_COUNTOF(lengths); i++) {
        char name[64];
        snprintf(name, sizeof name, "truncated to %zu bytes", lengths[i]);
        expect_refused(name, good, lengths[i], "truncated");
    }
    unsigned char *longer = malloc(good_size + 1);
    memcpy(longer, good, good_size);
    longer[good_size] = 0;
    expect_refused("one byte appended", longer, good_size + 1, "trailing");
    free(longer);
    expect_rebuilt("truncated to 0 bytes", good, 0);
    expect_rebuilt("truncated mid-payload", good, good_size / 2);
    expect_rebuilt("truncated by one byte", good, good_size - 1);
    group_done("truncated files: refused and rebuilt", f0, p0);
}

static void test_header_fields(void)
{
    int f0 = failed, p0 = passed;
    unsigned char *b = malloc(good_size);
    struct {
        const char *name;
        size_t offset;
        uint32_t value;
        const char *reason;
    } cases[] = {
        {"format version 3", RTK_BVH_CACHE_AT_VERSION, 3, "format version 3, expected 1"},
        {"format version 0", RTK_BVH_CACHE_AT_VERSION, 0, "format version 0, expected 1"},
        {"other byte order", RTK_BVH_CACHE_AT_ENDIAN, 0x04030201u, "other byte order"},
        {"garbage byte-order marker", RTK_BVH_CACHE_AT_ENDIAN, 0xdeadbeefu, "byte-order marker"},
        {"header size 2^32-1", RTK_BVH_CACHE_AT_HEADER_SIZE, 0xffffffffu, "header size"},
        {"node size 64", RTK_BVH_CACHE_AT_NODE_SIZE, 64, "node size"},
        {"reserved field set", RTK_BVH_CACHE_AT_ZERO, 1, "reserved"},
        {"node count 2^32-1", AT_NODES, 0xffffffffu, "node count"},
        {"node count 0", AT_NODES, 0, "node count"},
        {"node count one less (file too long)", AT_NODES, 0, "trailing"}, /* values set below */
        {"node count one more (file too short)", AT_NODES, 0, "truncated"},
        {"prim count 2^32-1", AT_PRIMS, 0xffffffffu, "built for other geometry"},
        {"prim count 0", AT_PRIMS, 0, "built for other geometry"},
        {"depth 2^32-1", AT_DEPTH, 0xffffffffu, "checksum mismatch"},
    };
    cases[9].value = get32(good, AT_NODES) - 1;
    cases[10].value = get32(good, AT_NODES) + 1;
    for (size_t i = 0; i < RTK_COUNTOF(cases); i++) {
        memcpy(b, good, good_size);
        put32(b, cases[i].offset, cases[i].value);
        expect_refused(cases[i].name, b, good_size, cases[i].reason);
    }
    memcpy(b, good, good_size);
    memcpy(b, "RTKBVX\0\0", 8);
    expect_refused("wrong magic", b, good_size, "bad magic");
    expect_rebuilt("wrong magic", b, good_size);
    memcpy(b, good, good_size);
    put32(b, RTK_BVH_CACHE_AT_VERSION, 3);
    expect_rebuilt("format version 3", b, good_size);
    memcpy(b, good, good_size);
    put32(b, AT_NODES, 0xffffffffu);
    expect_rebuilt("node count 2^32-1", b, good_size);
    /* Huge counts with a checksum that matches: refused before allocating. */
    memcpy(b, good, good_size);
    put32(b, AT_NODES, 0xfffffff0u);
    put32(b, AT_PRIMS, 0xfffffff0u);
    fix_checksum(b, good_size);
    expect_refused("huge counts, checksum fixed", b, good_size, NULL);
    /* The builder text is printed: control characters must not be. */
    memcpy(b, good, good_size);
    memcpy(b + RTK_BVH_CACHE_AT_BUILDER_TEXT, "\x1b[31mevil\x07", 11);
    uint64_t other = bhash ^ 1;
    memcpy(b + RTK_BVH_CACHE_AT_BUILDER, &other, 8);
    if (write_file(path, b, good_size)) {
        capture c;
        capture_begin(&c);
        int used = rtk_bvh_cache_load(probe, path, ghash, bhash, median, 1);
        char *err = capture_end(&c);
        check(!used && strchr(err, 0x1b) == NULL && strchr(err, 0x07) == NULL,
              "builder text from the file is printed without control characters (got: %s)", shown(err));
        free(err);
    }
    /* Another build of the same plugin (same name, version, parameters). */
    memcpy(b, good, good_size);
    uint64_t stamp;
    memcpy(&stamp, b + RTK_BVH_CACHE_AT_PLUGIN_FILE, 8);
    check(stamp != 0 && stamp == rtk_bvh_cache_plugin_stamp(median), "the header carries the plugin file's stamp");
    stamp ^= 0x100;
    memcpy(b + RTK_BVH_CACHE_AT_PLUGIN_FILE, &stamp, 8);
    fix_checksum(b, good_size);
    expect_refused("plugin file rebuilt", b, good_size, "plugin file changed");
    expect_rebuilt("plugin file rebuilt", b, good_size);
    free(b);
    group_done("damaged header fields: each refused with its reason", f0, p0);
}

static void test_bit_flips(void)
{
    int f0 = failed, p0 = passed;
    unsigned char *b = malloc(good_size);
    const size_t header = RTK_BVH_CACHE_HEADER_SIZE;
    const size_t nodes_end = header + 32 * (size_t)ref->node_count;
    int flips = 0;
    /* Every bit of the header and of the checksum. */
    for (size_t bit = 0; bit < 8 * header; bit++) {
        memcpy(b, good, good_size);
        b[bit / 8] ^= (unsigned char)(1u << (bit % 8));
        char name[64];
        snprintf(name, sizeof name, "header bit %zu flipped", bit);
        expect_refused(name, b, good_size, NULL);
        flips++;
    }
    for (size_t bit = 0; bit < 64; bit++) {
        memcpy(b, good, good_size);
        b[good_size - 8 + bit / 8] ^= (unsigned char)(1u << (bit % 8));
        char name[64];
        snprintf(name, sizeof name, "checksum bit %zu flipped", bit);
        expect_refused(name, b, good_size, "checksum mismatch");
        flips++;
    }
    /* Every bit of the first nodes (bounds, child index, count) and of
     * the first prim ids, then bits spread over the whole payload. Many
     * leave a valid tree (a box grown a little, a leaf order swapped):
     * only the checksum can tell. */
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 99, 3);
    for (int k = 0; k < 2 * 32 * 8 + 64 * 8 + 600; k++) {
        size_t bit;
        if (k < 2 * 32 * 8)
            bit = 8 * header + (size_t)k;
        else if (k < 2 * 32 * 8 + 64 * 8)
            bit = 8 * nodes_end + (size_t)(k - 2 * 32 * 8);
        else
            bit = 8 * header + rtk_pcg32_next(&rng) % (uint32_t)(8 * (good_size - 8 - header));
        memcpy(b, good, good_size);
        b[bit / 8] ^= (unsigned char)(1u << (bit % 8));
        char name[96];
        snprintf(name, sizeof name, "payload bit %zu (%s) flipped", bit,
                 bit / 8 < nodes_end ? "node" : "prim id");
        expect_refused(name, b, good_size, "checksum mismatch");
        flips++;
    }
    /* Through the build path: refused, rebuilt, loads next time. */
    const size_t samples[] = {3,  8 * 8 + 1,  8 * 24 + 5, 8 * 40 + 2, 8 * 60, 8 * header + 33, 8 * header + 8 * 12 + 4,
                              8 * nodes_end + 9, 8 * (good_size - 8) + 17};
    for (size_t i = 0; i < RTK_COUNTOF(samples); i++) {
        memcpy(b, good, good_size);
        b[samples[i] / 8] ^= (unsigned char)(1u << (samples[i] % 8));
        char name[64];
        snprintf(name, sizeof name, "bit %zu flipped", samples[i]);
        expect_rebuilt(name, b, good_size);
    }
    free(b);
    char title[96];
    snprintf(title, sizeof title, "%d single-bit flips: every one refused", flips);
    group_done(title, f0, p0);
}

/* Finds a node of the good image satisfying leaf/inner; returns its index. */
static uint32_t find_node(const unsigned char *b, int leaf, uint32_t skip)
{
    uint32_t n = get32(b, AT_NODES);
    for (uint32_t i = 1; i < n; i++) {
        uint32_t count = get32(b, RTK_BVH_CACHE_HEADER_SIZE + 32 * (size_t)i + 28);
        if ((count > 0) == (leaf != 0) && skip-- == 0)
            return i;
    }
    return 0;
}

static void test_structure(void)
{
    int f0 = failed, p0 = passed;
    unsigned char *b = malloc(good_size);
    const size_t H = RTK_BVH_CACHE_HEADER_SIZE;
    const size_t prims_at = H + 32 * (size_t)ref->node_count;
    uint32_t inner = find_node(good, 0, 2), leaf = find_node(good, 1, 5), leaf2 = find_node(good, 1, 9);
    check(inner && leaf && leaf2, "structure: the tree has inner nodes and leaves to damage");
    /* Each edit keeps the checksum right: the kernel's validation decides. */
    memcpy(b, good, good_size);
    put32(b, H + 32 * inner + 12, get32(b, AT_NODES) - 1);
    fix_checksum(b, good_size);
    expect_refused("child index past the last node", b, good_size, "invalid tree");
    memcpy(b, good, good_size);
    put32(b, H + 32 * inner + 12, 0);
    fix_checksum(b, good_size);
    expect_refused("child index 0 (a cycle to the root)", b, good_size, "invalid tree");
    memcpy(b, good, good_size);
    put32(b, H + 32 * inner + 12, get32(good, H + 32 * 0 + 12));
    fix_checksum(b, good_size);
    expect_refused("children shared by two nodes", b, good_size, "invalid tree");
    memcpy(b, good, good_size);
    put32(b, H + 32 * leaf + 12, 0xfffffff0u);
    fix_checksum(b, good_size);
    expect_refused("leaf offset past the prim ids", b, good_size, "invalid tree");
    memcpy(b, good, good_size);
    put32(b, H + 32 * leaf + 28, 0xffffffffu);
    fix_checksum(b, good_size);
    expect_refused("leaf count 2^32-1", b, good_size, "invalid tree");
    memcpy(b, good, good_size);
    put32(b, prims_at + 4, get32(b, prims_at));
    fix_checksum(b, good_size);
    expect_refused("a primitive twice in the permutation", b, good_size, "invalid tree");
    memcpy(b, good, good_size);
    put32(b, prims_at + 8, ref->triangle_count);
    fix_checksum(b, good_size);
    expect_refused("a primitive id out of range", b, good_size, "invalid tree");
    memcpy(b, good, good_size);
    float shrunk = 0.5f;
    memcpy(b + H + 32 * leaf + 16, &shrunk, 4); /* upper.x of a leaf */
    memcpy(b + H + 32 * leaf + 0, &shrunk, 4);  /* and lower.x */
    fix_checksum(b, good_size);
    expect_refused("leaf box not enclosing its triangles", b, good_size, "invalid tree");
    memcpy(b, good, good_size);
    float nan = NAN;
    memcpy(b + H + 32 * inner + 4, &nan, 4);
    fix_checksum(b, good_size);
    expect_refused("NaN bounds", b, good_size, "invalid tree");
    memcpy(b, good, good_size);
    put32(b, AT_DEPTH, get32(b, AT_DEPTH) + 1);
    fix_checksum(b, good_size);
    expect_refused("depth in the header differs from the tree", b, good_size, "depth");
    memcpy(b, good, good_size);
    put32(b, H + 32 * leaf + 28, 0); /* leaf turned into an inner node */
    fix_checksum(b, good_size);
    expect_refused("leaf turned inner", b, good_size, "invalid tree");
    expect_rebuilt("leaf turned inner", b, good_size);
    /* A root that is a single leaf over everything is a valid tree: it
     * loads (slow to trace, but right). */
    const size_t one_leaf = H + 32 + 4 * (size_t)ref->triangle_count + 8;
    unsigned char *c = calloc(1, one_leaf);
    memcpy(c, good, H);
    put32(c, AT_NODES, 1);
    put32(c, AT_DEPTH, 1);
    memcpy(c + H, good + H, 12);      /* root bounds */
    memcpy(c + H + 16, good + H + 16, 12);
    put32(c, H + 12, 0);
    put32(c, H + 28, ref->triangle_count);
    memcpy(c + H + 32, good + prims_at, 4 * (size_t)ref->triangle_count);
    fix_checksum(c, one_leaf);
    write_file(path, c, one_leaf);
    capture cap;
    capture_begin(&cap);
    int used = rtk_bvh_cache_load(probe, path, ghash, bhash, median, 1);
    char *err = capture_end(&cap);
    check(used && err[0] == '\0', "a valid one-leaf tree with a good checksum loads (got: %s)", shown(err));
    check(used && brute_differences(probe, 5) == 0, "and traces like brute force");
    free(err);
    free(c);
    free(b);
    group_done("structurally broken trees with good checksums: refused by validation", f0, p0);
}

static void test_stale(void)
{
    int f0 = failed, p0 = passed;
    write_file(path, good, good_size);
    /* Other geometry: one vertex moved, the file made for the sphere. */
    rtk_scene *moved = make_sphere(40, 48, 1);
    uint64_t mg = rtk_bvh_cache_geometry_hash(moved);
    capture c;
    capture_begin(&c);
    int used = rtk_bvh_cache_load(moved, path, mg, bhash, median, 1);
    char *err = capture_end(&c);
    check(!used && count_of(err, "warning") == 1 && strstr(err, "stale") && strstr(err, "other geometry") &&
              strstr(err, path),
          "one vertex moved: stale, built for other geometry (got: %s)", shown(err));
    free(err);
    /* Through the build path the moved sphere has its own file. */
    rtk_bvh_cache_use use;
    capture_begin(&c);
    rtk_status st = rtk_bvh_build_cached(moved, median, params, 1, dir, &use);
    err = capture_end(&c);
    check(st == RTK_OK && !use.from_cache && err[0] == '\0' && strcmp(use.file, path) != 0 && use.file[0],
          "moved sphere: built and saved under its own name (got: %s)", shown(err));
    free(err);
    capture_begin(&c);
    st = rtk_bvh_build_cached(moved, median, params, 1, dir, &use);
    err = capture_end(&c);
    check(st == RTK_OK && use.from_cache && err[0] == '\0', "moved sphere: its own file loads next time");
    check(brute_differences(moved, 5) == 0, "moved sphere: loaded tree traces like brute force");
    free(err);
    rtk_scene_free(moved);
    /* Other builder parameters. */
    rtk_params *leaf2 = rtk_params_defaults(median);
    rtk_params_set_text(leaf2, "max_leaf", "2");
    capture_begin(&c);
    used = rtk_bvh_cache_load(probe, path, ghash, rtk_bvh_cache_builder_hash(median, leaf2), median, 1);
    err = capture_end(&c);
    check(!used && count_of(err, "warning") == 1 && strstr(err, "stale") && strstr(err, "other parameters"),
          "max_leaf = 2: stale, other parameters (got: %s)", shown(err));
    free(err);
    capture_begin(&c);
    st = rtk_bvh_build_cached(probe, median, leaf2, 1, dir, &use);
    err = capture_end(&c);
    check(st == RTK_OK && !use.from_cache && err[0] == '\0' && strcmp(use.file, path) != 0,
          "max_leaf = 2: built and saved under its own name (got: %s)", shown(err));
    free(err);
    rtk_params_destroy(leaf2);
    /* Another builder's file under this builder's name. */
    rtk_plugin fake = *median;
    fake.name = "sah";
    capture_begin(&c);
    used = rtk_bvh_cache_load(probe, path, ghash, rtk_bvh_cache_builder_hash(&fake, params), &fake, 1);
    err = capture_end(&c);
    check(!used && count_of(err, "warning") == 1 && strstr(err, "built by 'median"),
          "other builder: stale, names the builder that made it (got: %s)", shown(err));
    free(err);
    group_done("stale caches: other geometry, other parameters, other builder", f0, p0);
}

static void test_odd_files(void)
{
    int f0 = failed, p0 = passed;
    unlink(path);
    mkdir(path, 0755);
    expect_refused_as_is("a directory at the cache path", "not a regular file");
    rmdir(path);
    /* A FIFO must not block the load. */
    if (mkfifo(path, 0644) == 0) {
        capture c;
        capture_begin(&c);
        int used = rtk_bvh_cache_load(probe, path, ghash, bhash, median, 1);
        char *err = capture_end(&c);
        check(!used && strstr(err, "not a regular file"), "a FIFO at the cache path: refused at once (got: %s)",
              shown(err));
        free(err);
        unlink(path);
    }
    /* Save into a path that is a directory: one warning, no litter. */
    mkdir(path, 0755);
    capture c;
    capture_begin(&c);
    rtk_status st = rtk_bvh_cache_save(ref, path, ghash, bhash, median);
    char *err = capture_end(&c);
    check(st != RTK_OK && count_of(err, "warning") == 1 && strstr(err, path),
          "save over a directory: fails with one warning (got: %s)", shown(err));
    check(dir_count(dir, ".tmp") == 0, "save over a directory: no temporary file left");
    free(err);
    rmdir(path);
    /* A cache directory that cannot be created: one warning, the build
     * still works, and a second build does not warn again. */
    char blocked[600], file[600];
    snprintf(file, sizeof file, "%s/plainfile", dir);
    snprintf(blocked, sizeof blocked, "%s/plainfile/sub", dir);
    write_file(file, "x", 1);
    rtk_bvh_cache_use use;
    capture_begin(&c);
    st = rtk_bvh_build_cached(probe, median, params, 1, blocked, &use);
    err = capture_end(&c);
    check(st == RTK_OK && !use.from_cache && !use.file[0] && count_of(err, "warning") == 1 && strstr(err, blocked),
          "uncreatable cache dir: one warning, build works (got: %s)", shown(err));
    check(same_bvh(ref, probe), "uncreatable cache dir: the plugin's tree");
    free(err);
    capture_begin(&c);
    st = rtk_bvh_build_cached(probe, median, params, 1, blocked, &use);
    err = capture_end(&c);
    check(st == RTK_OK && err[0] == '\0', "uncreatable cache dir: warned once per process (got: %s)", shown(err));
    free(err);
    /* A nested directory that does not exist yet is created. */
    char nested[600];
    snprintf(nested, sizeof nested, "%s/a/b/c", dir);
    capture_begin(&c);
    st = rtk_bvh_build_cached(probe, median, params, 1, nested, &use);
    err = capture_end(&c);
    check(st == RTK_OK && use.file[0] && access(use.file, R_OK) == 0 && err[0] == '\0',
          "missing nested cache dir: created, file saved (got: %s)", shown(err));
    free(err);
    /* Caching off: no file, no load. */
    st = rtk_bvh_build_cached(probe, median, params, 1, NULL, &use);
    check(st == RTK_OK && !use.from_cache && !use.file[0] && same_bvh(ref, probe), "cache off: plain build");
    group_done("odd files and directories", f0, p0);
}

/* Random damage: byte edits, lengths, sometimes a fixed checksum. A file
 * that loads must still trace exactly like brute force. */
static void test_fuzz(int rounds)
{
    int f0 = failed, p0 = passed;
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 1234, 5);
    size_t cap = good_size + 256;
    unsigned char *b = malloc(cap);
    int loaded = 0;
    for (int r = 0; r < rounds; r++) {
        memcpy(b, good, good_size);
        for (size_t i = good_size; i < cap; i++)
            b[i] = (unsigned char)rtk_pcg32_next(&rng);
        size_t size = good_size;
        uint32_t edits = 1 + rtk_pcg32_next(&rng) % 8;
        for (uint32_t e = 0; e < edits; e++) {
            uint32_t where = rtk_pcg32_next(&rng) % 4;
            size_t at = where == 0 ? rtk_pcg32_next(&rng) % RTK_BVH_CACHE_HEADER_SIZE
                                   : rtk_pcg32_next(&rng) % (uint32_t)good_size;
            b[at] = (unsigned char)rtk_pcg32_next(&rng);
        }
        uint32_t shape = rtk_pcg32_next(&rng) % 8;
        if (shape == 0)
            size = rtk_pcg32_next(&rng) % (uint32_t)good_size;
        else if (shape == 1)
            size = good_size + 1 + rtk_pcg32_next(&rng) % 255;
        if (shape >= 4)
            fix_checksum(b, size);
        write_file(path, b, size);
        capture c;
        capture_begin(&c);
        int used = rtk_bvh_cache_load(probe, path, ghash, bhash, median, 1);
        char *err = capture_end(&c);
        if (used) {
            loaded++;
            check(brute_differences(probe, 50) == 0, "fuzz round %d: a file that loads traces right", r);
        } else {
            check(count_of(err, "warning") == 1, "fuzz round %d: one warning (got: %s)", r, shown(err));
        }
        free(err);
    }
    free(b);
    char title[96];
    snprintf(title, sizeof title, "%d randomly damaged files: refused, or valid and tracing right (%d loaded)",
             rounds, loaded);
    group_done(title, f0, p0);
}

/* A file of size bytes in d, last modified age seconds before now. */
static void make_aged(const char *d, const char *name, size_t size, long age, struct timespec now)
{
    char full[1024];
    snprintf(full, sizeof full, "%s/%s", d, name);
    char *data = calloc(1, size);
    write_file(full, data, size);
    free(data);
    const struct timespec times[2] = {{now.tv_sec - age, 0}, {now.tv_sec - age, 0}};
    utimensat(AT_FDCWD, full, times, 0);
}

static int exists_in(const char *d, const char *name)
{
    char full[1024];
    snprintf(full, sizeof full, "%s/%s", d, name);
    struct stat st;
    return lstat(full, &st) == 0;
}

/* cache_limit: least recently used trees go first, the render's own and
 * other files never; dead temporary files go whatever the limit; a load
 * marks its file used. */
static void test_prune(void)
{
    int f0 = failed, p0 = passed;
    char d[512];
    snprintf(d, sizeof d, "%s/prune", dir);
    mkdir(d, 0755);
    struct timespec now;
    clock_gettime(CLOCK_REALTIME, &now);
    const char *a = "00000000000000a1-00000000000000b1-00000000000000c1.bvh",
               *b = "00000000000000a2-00000000000000b2.bvh",
               *c = "00000000000000a3-00000000000000b3-00000000000000c3.bvh",
               *own = "00000000000000a4-00000000000000b4-00000000000000c4.bvh",
               *keyless = "00000000000000a0-00000000000000b0.bvh";
    make_aged(d, keyless, 500, 400, now);
    make_aged(d, a, 1000, 300, now);
    make_aged(d, b, 2000, 200, now);
    make_aged(d, c, 3000, 100, now);
    make_aged(d, own, 4000, 0, now);
    make_aged(d, "notes.txt", 5000, 1000, now);
    make_aged(d, "00000000000000A1-00000000000000B1.bvh", 5000, 1000, now); /* not a name the cache makes */
    make_aged(d, "00000000000000a1-00000000000000b1-00000000000000C1.bvh", 5000, 1000, now); /* nor this */
    make_aged(d, "00000000000000a1-00000000000000b1-00000000000000c1.bvh.tmp76-0", 10, 7200, now);
    make_aged(d, "00000000000000a1-00000000000000b1.bvh.tmp77-0", 10, 7200, now);
    make_aged(d, "00000000000000a2-00000000000000b2.bvh.tmp78-0", 10, 60, now);
    make_aged(d, "00000000000000a1-00000000000000b1.bvh.old", 10, 7200, now);
    char sub[1024];
    snprintf(sub, sizeof sub, "%s/00000000000000a5-00000000000000b5.bvh", d);
    mkdir(sub, 0755);
    struct timespec since = {now.tv_sec - 50, 0};
    uint64_t freed = 0;
    uint32_t removed = rtk_bvh_cache_prune(d, 0, since, &freed);
    check(removed == 2 && freed == 20 && !exists_in(d, "00000000000000a1-00000000000000b1.bvh.tmp77-0") &&
              !exists_in(d, "00000000000000a1-00000000000000b1-00000000000000c1.bvh.tmp76-0") &&
              exists_in(d, "00000000000000a2-00000000000000b2.bvh.tmp78-0") && exists_in(d, a),
          "no limit: only the hour-old temporary files go (removed %u, %llu bytes)", removed,
          (unsigned long long)freed);
    freed = 0;
    removed = rtk_bvh_cache_prune(d, 7500, since, &freed);
    check(removed == 3 && freed == 3500 && !exists_in(d, keyless) && !exists_in(d, a) && !exists_in(d, b) &&
              exists_in(d, c) && exists_in(d, own),
          "7500 bytes over 10500: the three least recently used go, with and without a plugin key "
          "(removed %u, %llu bytes)", removed, (unsigned long long)freed);
    freed = 0;
    removed = rtk_bvh_cache_prune(d, 1, since, &freed);
    check(removed == 1 && freed == 3000 && !exists_in(d, c) && exists_in(d, own),
          "1 byte: all but the render's own tree go (removed %u, %llu bytes)", removed, (unsigned long long)freed);
    check(exists_in(d, "notes.txt") && exists_in(d, "00000000000000A1-00000000000000B1.bvh") &&
              exists_in(d, "00000000000000a1-00000000000000b1-00000000000000C1.bvh") &&
              exists_in(d, "00000000000000a2-00000000000000b2.bvh.tmp78-0") &&
              exists_in(d, "00000000000000a1-00000000000000b1.bvh.old") && exists_in(d, "00000000000000a5-00000000000000b5.bvh"),
          "other files, a fresh temporary file and a directory stay");
    check(rtk_bvh_cache_prune("/nonexistent/rtk-cache", 1, since, NULL) == 0, "a missing directory: nothing, no failure");
    /* A load marks the file used. */
    write_file(path, good, good_size);
    const struct timespec old[2] = {{now.tv_sec - 1000, 0}, {now.tv_sec - 1000, 0}};
    utimensat(AT_FDCWD, path, old, 0);
    capture cap;
    capture_begin(&cap);
    int used = rtk_bvh_cache_load(probe, path, ghash, bhash, median, 1);
    free(capture_end(&cap));
    struct stat st;
    const int stated = stat(path, &st) == 0;
    const long long age = stated ? (long long)(now.tv_sec - st.st_mtime) : -1;
    check(used && stated && age <= 5, "a load marks the file used (modified %lld s before the test)", age);
    nftw(d, remove_entry, 16, FTW_DEPTH | FTW_PHYS);
    group_done("cache_limit: least recently used trees removed, nothing else", f0, p0);
}

/* Copies the file plugin was loaded from to path. */
static int copy_plugin_file(const rtk_plugin *plugin, const char *path)
{
    Dl_info info;
    size_t size = 0;
    unsigned char *data = NULL;
    if (dladdr(plugin->functions, &info) && info.dli_fname)
        data = read_file(info.dli_fname, &size);
    int ok = data && write_file(path, data, size);
    free(data);
    return ok;
}

/* One build of the probe through the cache in d: 1 loaded, 0 built, -1
 * failed; *err gets what was printed. [caller frees *err] */
static int build_through(const rtk_plugin *plugin, const rtk_params *p, const char *d, rtk_bvh_cache_use *use,
                         char **err)
{
    capture c;
    capture_begin(&c);
    rtk_status st = rtk_bvh_build_cached(probe, plugin, p, 1, d, use);
    *err = capture_end(&c);
    return st != RTK_OK ? -1 : use->from_cache;
}

/* Two builds of one plugin in one cache, as a build tree's and an
 * install's: copies of median's file at two paths. Each keeps a tree of
 * its own, so they alternate without a rebuild after their first; a copy
 * rebuilt at its path never gets its old tree; cache_limit still removes
 * the least recently used. */
static void test_two_builds(void)
{
    int f0 = failed, p0 = passed;
    char d[512], file[2][600], tree[2][1024];
    const rtk_plugin *copy[2] = {NULL, NULL};
    rtk_params *p[2] = {NULL, NULL};
    snprintf(d, sizeof d, "%s/two-builds", dir);
    mkdir(d, 0755);
    for (int i = 0; i < 2; i++) {
        char sub[560];
        snprintf(sub, sizeof sub, "%s/build-%c", dir, 'a' + i);
        mkdir(sub, 0755);
        snprintf(file[i], sizeof file[i], "%s/median.so", sub);
        if (!copy_plugin_file(median, file[i]) ||
            rtk_plugin_open(file[i], RTK_KIND_ACCELERATOR, &copy[i]) != RTK_OK) {
            check(0, "copy %d of median: %s", i, rtk_error_message());
            return;
        }
        p[i] = rtk_params_defaults(copy[i]);
        tree[i][0] = '\0';
    }
    const uint64_t key0 = rtk_bvh_cache_plugin_key(copy[0]), key1 = rtk_bvh_cache_plugin_key(copy[1]);
    check(copy[0] != copy[1] && copy[0] != median && copy[1] != median, "two copies of median: two plugins");
    check(key0 && key1 && key0 != key1 && key0 != rtk_bvh_cache_plugin_key(median),
          "each copy has a plugin key of its own");
    check(rtk_bvh_cache_builder_hash(copy[0], p[0]) == rtk_bvh_cache_builder_hash(copy[1], p[1]),
          "both copies have the same builder hash");
    rtk_bvh_cache_use use;
    char *err;
    for (int i = 0; i < 2; i++) {
        int got = build_through(copy[i], p[i], d, &use, &err);
        check(got == 0 && err[0] == '\0' && use.file[0], "copy %d, first build: built and saved, no warning (got: %s)",
              i, shown(err));
        snprintf(tree[i], sizeof tree[i], "%s", use.file);
        free(err);
    }
    check(strcmp(tree[0], tree[1]) != 0 && dir_count(d, ".bvh") == 2, "one tree file per copy (%s, %s)", tree[0],
          tree[1]);
    for (int round = 1; round <= 3; round++) {
        for (int i = 0; i < 2; i++) {
            int got = build_through(copy[i], p[i], d, &use, &err);
            check(got == 1 && err[0] == '\0' && strcmp(use.file, tree[i]) == 0 && same_bvh(ref, probe),
                  "round %d, copy %d: its own tree from the cache, no warning (got: %s)", round, i, shown(err));
            free(err);
        }
    }
    check(dir_count(d, ".bvh") == 2, "alternating builds: still two tree files");
    /* Copy 0 rebuilt at its path: its file's time changes. */
    struct timespec now;
    clock_gettime(CLOCK_REALTIME, &now);
    const struct timespec rebuilt[2] = {{now.tv_sec - 10, 0}, {now.tv_sec - 10, 0}};
    utimensat(AT_FDCWD, file[0], rebuilt, 0);
    int got = build_through(copy[0], p[0], d, &use, &err);
    check(got == 0 && count_of(err, "warning") == 1 && strstr(err, tree[0]) && strstr(err, "earlier build"),
          "copy 0 rebuilt: its old tree refused with one warning (got: %s)", shown(err));
    check(strcmp(use.file, tree[0]) == 0 && dir_count(d, ".bvh") == 2, "copy 0 rebuilt: its tree overwritten in place");
    free(err);
    got = build_through(copy[0], p[0], d, &use, &err);
    check(got == 1 && err[0] == '\0', "copy 0 rebuilt: its new tree loads next time (got: %s)", shown(err));
    free(err);
    got = build_through(copy[1], p[1], d, &use, &err);
    check(got == 1 && err[0] == '\0', "copy 1 still loads its own tree (got: %s)", shown(err));
    free(err);
    /* cache_limit over both builds' trees: the least recently used goes. */
    struct stat st;
    const long long tree_bytes = stat(tree[1], &st) == 0 ? (long long)st.st_size : 0;
    const struct timespec older[2] = {{now.tv_sec - 200, 0}, {now.tv_sec - 200, 0}};
    const struct timespec newer[2] = {{now.tv_sec - 100, 0}, {now.tv_sec - 100, 0}};
    utimensat(AT_FDCWD, tree[0], older, 0);
    utimensat(AT_FDCWD, tree[1], newer, 0);
    const struct timespec since = {now.tv_sec - 50, 0};
    uint64_t freed = 0;
    uint32_t removed = rtk_bvh_cache_prune(d, (uint64_t)tree_bytes, since, &freed);
    check(tree_bytes > 0 && removed == 1 && freed == (uint64_t)tree_bytes && access(tree[0], F_OK) != 0 &&
              access(tree[1], F_OK) == 0,
          "a limit of one tree: the least recently used build's tree goes (removed %u, %llu bytes)", removed,
          (unsigned long long)freed);
    got = build_through(copy[1], p[1], d, &use, &err);
    check(got == 1 && err[0] == '\0', "after pruning: the kept tree loads (got: %s)", shown(err));
    free(err);
    got = build_through(copy[0], p[0], d, &use, &err);
    check(got == 0 && err[0] == '\0' && strcmp(use.file, tree[0]) == 0,
          "after pruning: the removed one is built and saved again, no warning (got: %s)", shown(err));
    free(err);
    for (int i = 0; i < 2; i++)
        rtk_params_destroy(p[i]);
    group_done("two builds of a plugin share a cache: a tree each, pruned least recently used first", f0, p0);
}

int main(void)
{
    check_failures_only = 1;
    rtk_registry *reg = NULL;
    if (rtk_registry_create(&reg) != RTK_OK ||
        rtk_registry_find(reg, RTK_KIND_ACCELERATOR, "median", &median) != RTK_OK) {
        printf("FAIL  median plugin: %s\n", rtk_error_message());
        return 1;
    }
    params = rtk_params_defaults(median);
    snprintf(dir, sizeof dir, "%s", "/tmp/rtk-cache-test-XXXXXX");
    if (!mkdtemp(dir)) {
        printf("FAIL  mkdtemp: %s\n", strerror(errno));
        return 1;
    }
    make_rays();
    ref = make_sphere(40, 48, 0);
    probe = make_sphere(40, 48, 0);
    if (rtk_bvh_build(ref, median, params, 1) != RTK_OK) {
        printf("FAIL  build: %s\n", rtk_error_message());
        return 1;
    }
    printf("ok    sphere: %u triangles, %u nodes, depth %u\n", ref->triangle_count, ref->node_count, ref->bvh_depth);
    ghash = rtk_bvh_cache_geometry_hash(ref);
    bhash = rtk_bvh_cache_builder_hash(median, params);
    char *p = rtk_bvh_cache_path(dir, ghash, bhash, rtk_bvh_cache_plugin_key(median));
    snprintf(path, sizeof path, "%s", p);
    free(p);

    const char *quick = getenv("RTK_CACHE_TEST_QUICK");
    test_hash();
    test_hashes();
    test_round_trip();
    if (good) {
        test_truncation();
        test_header_fields();
        if (!quick)
            test_bit_flips();
        test_structure();
        test_stale();
        test_odd_files();
        test_prune();
        test_two_builds();
        test_fuzz(quick ? 60 : 600);
    }
    check(dir_count(dir, ".tmp") == 0, "no temporary file left in the cache dir");

    free(good);
    rtk_scene_free(ref);
    rtk_scene_free(probe);
    rtk_params_destroy(params);
    rtk_registry_destroy(reg);
    nftw(dir, remove_entry, 16, FTW_DEPTH | FTW_PHYS);
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}

/* The on-disk BVH cache (format in bvh_cache.h). A file is trusted only
 * after every check passed; any doubt means one warning and a rebuild. */
#include "accel.h"

#include <assert.h>
#include <dirent.h>
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define BUILDER_TEXT 40 /* bytes of "name version" in the header */

static_assert(sizeof(rtk_bvh_node) == 32, "the cache format stores 32-byte nodes");
static_assert(RTK_BVH_CACHE_AT_BUILDER_TEXT + BUILDER_TEXT == RTK_BVH_CACHE_HEADER_SIZE, "header layout");

static const unsigned char cache_magic[8] = {'R', 'T', 'K', 'B', 'V', 'H', 0, 0};

/* XXH64 (Yann Collet): four lanes of 8 bytes, then the tail, then an
 * avalanche. Reads are in host byte order, like the rest of the file. */
static const uint64_t P1 = 0x9E3779B185EBCA87ull, P2 = 0xC2B2AE3D27D4EB4Full, P3 = 0x165667B19E3779F9ull,
                      P4 = 0x85EBCA77C2B2AE63ull, P5 = 0x27D4EB2F165667C5ull;

static uint64_t rotl64(uint64_t x, int r)
{
    return (x << r) | (x >> (64 - r));
}

static uint64_t load64(const unsigned char *p)
{
    uint64_t v;
    memcpy(&v, p, sizeof v);
    return v;
}

static uint32_t load32(const unsigned char *p)
{
    uint32_t v;
    memcpy(&v, p, sizeof v);
    return v;
}

static uint64_t xxh_round(uint64_t acc, uint64_t input)
{
    acc += input * P2;
    return rotl64(acc, 31) * P1;
}

static uint64_t xxh_merge(uint64_t h, uint64_t v)
{
    h ^= xxh_round(0, v);
    return h * P1 + P4;
}

uint64_t rtk_hash64(const void *data, size_t size, uint64_t seed)
{
    const unsigned char *p = data;
    const unsigned char *end = size ? p + size : p;
    uint64_t h;
    if (size >= 32) {
        uint64_t v1 = seed + P1 + P2, v2 = seed + P2, v3 = seed, v4 = seed - P1;
        const unsigned char *limit = end - 32;
        do {
            v1 = xxh_round(v1, load64(p));
            v2 = xxh_round(v2, load64(p + 8));
            v3 = xxh_round(v3, load64(p + 16));
            v4 = xxh_round(v4, load64(p + 24));
            p += 32;
        } while (p <= limit);
        h = rotl64(v1, 1) + rotl64(v2, 7) + rotl64(v3, 12) + rotl64(v4, 18);
        h = xxh_merge(h, v1);
        h = xxh_merge(h, v2);
        h = xxh_merge(h, v3);
        h = xxh_merge(h, v4);
    } else {
        h = seed + P5;
    }
    h += (uint64_t)size;
    for (; end - p >= 8; p += 8) {
        h ^= xxh_round(0, load64(p));
        h = rotl64(h, 27) * P1 + P4;
    }
    if (end - p >= 4) {
        h ^= (uint64_t)load32(p) * P1;
        h = rotl64(h, 23) * P2 + P3;
        p += 4;
    }
    for (; p < end; p++) {
        h ^= *p * P5;
        h = rotl64(h, 11) * P1;
    }
    h ^= h >> 33;
    h *= P2;
    h ^= h >> 29;
    h *= P3;
    h ^= h >> 32;
    return h;
}

uint64_t rtk_bvh_cache_geometry_hash(const rtk_scene *s)
{
    const uint32_t counts[2] = {s->vertex_count, s->triangle_count};
    uint64_t h = rtk_hash64(counts, sizeof counts, RTK_BVH_CACHE_SEED);
    h = rtk_hash64(s->positions, sizeof(float) * 3 * (size_t)s->vertex_count, h);
    return rtk_hash64(s->indices, sizeof(uint32_t) * 3 * (size_t)s->triangle_count, h);
}

static uint64_t hash_text(const char *text, uint64_t h)
{
    if (!text)
        text = "";
    return rtk_hash64(text, strlen(text) + 1, h);
}

uint64_t rtk_bvh_cache_builder_hash(const rtk_plugin *plugin, const rtk_params *params)
{
    uint64_t h = hash_text(plugin->name, RTK_BVH_CACHE_SEED);
    h = hash_text(plugin->version, h);
    uint32_t count = params ? params->count : 0;
    h = rtk_hash64(&count, sizeof count, h);
    for (uint32_t i = 0; i < count; i++) {
        const rtk_param_value *v = &params->values[i];
        uint32_t type = (uint32_t)v->desc->type;
        h = hash_text(v->desc->name, h);
        h = rtk_hash64(&type, sizeof type, h);
        if (type == RTK_PARAM_FLOAT)
            h = rtk_hash64(&v->f, sizeof v->f, h);
        else if (type == RTK_PARAM_STRING)
            h = hash_text(v->s, h);
        else
            h = rtk_hash64(&v->i, sizeof v->i, h);
    }
    return h;
}

uint64_t rtk_bvh_cache_plugin_stamp(const rtk_plugin *plugin)
{
    Dl_info info;
    struct stat st;
    if (!dladdr(plugin->functions, &info) || !info.dli_fname || stat(info.dli_fname, &st) != 0)
        return 0;
    const uint64_t fields[5] = {(uint64_t)st.st_size, (uint64_t)st.st_mtim.tv_sec, (uint64_t)st.st_mtim.tv_nsec,
                                (uint64_t)st.st_ino, (uint64_t)st.st_dev};
    return rtk_hash64(fields, sizeof fields, RTK_BVH_CACHE_SEED);
}

uint64_t rtk_bvh_cache_plugin_key(const rtk_plugin *plugin)
{
    Dl_info info;
    char real[PATH_MAX];
    if (!dladdr(plugin->functions, &info) || !info.dli_fname || !realpath(info.dli_fname, real))
        return 0;
    return hash_text(real, RTK_BVH_CACHE_SEED);
}

char *rtk_bvh_cache_default_dir(void)
{
    /* The XDG spec ignores relative values of XDG_CACHE_HOME. */
    const char *xdg = getenv("XDG_CACHE_HOME");
    if (xdg && xdg[0] == '/')
        return rtk_path_join(xdg, "rtk");
    const char *home = getenv("HOME");
    if (home && home[0] == '/')
        return rtk_path_join(home, ".cache/rtk");
    return NULL;
}

char *rtk_bvh_cache_path(const char *dir, uint64_t geometry, uint64_t builder, uint64_t plugin_key)
{
    char name[64];
    snprintf(name, sizeof name, "%016llx-%016llx-%016llx.bvh", (unsigned long long)geometry,
             (unsigned long long)builder, (unsigned long long)plugin_key);
    return rtk_path_join(dir, name);
}

/* "name version" of plugin, cut to fit the header. */
static void builder_text(const rtk_plugin *plugin, char out[BUILDER_TEXT + 1])
{
    memset(out, 0, BUILDER_TEXT + 1);
    snprintf(out, BUILDER_TEXT + 1, "%s %s", plugin && plugin->name ? plugin->name : "?",
             plugin && plugin->version ? plugin->version : "?");
}

/* Frees the scene's BVH and any accelerator instance it holds. */
static void clear_bvh(rtk_scene *s)
{
    rtk_bvh_release(s);
    free(s->nodes);
    free(s->prim_ids);
    s->nodes = NULL, s->prim_ids = NULL;
    s->node_count = 0, s->bvh_depth = 0;
}

/* Reads up to size bytes; returns the count read (short at end of file),
 * or -1 with errno set. */
static ssize_t read_all(int fd, void *buf, size_t size)
{
    size_t done = 0;
    while (done < size) {
        ssize_t n = read(fd, (char *)buf + done, size - done);
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0)
            return -1;
        if (n == 0)
            break;
        done += (size_t)n;
    }
    return (ssize_t)done;
}

/* Header fields after parsing. */
typedef struct cache_header {
    uint32_t version, endian, header_size, node_size;
    uint64_t geometry, builder, plugin_file;
    uint32_t node_count, depth, prim_count, zero;
    char builder_text[BUILDER_TEXT + 1];
} cache_header;

static void parse_header(const unsigned char *b, cache_header *h)
{
    h->version = load32(b + RTK_BVH_CACHE_AT_VERSION);
    h->endian = load32(b + RTK_BVH_CACHE_AT_ENDIAN);
    h->header_size = load32(b + RTK_BVH_CACHE_AT_HEADER_SIZE);
    h->node_size = load32(b + RTK_BVH_CACHE_AT_NODE_SIZE);
    h->geometry = load64(b + RTK_BVH_CACHE_AT_GEOMETRY);
    h->builder = load64(b + RTK_BVH_CACHE_AT_BUILDER);
    h->plugin_file = load64(b + RTK_BVH_CACHE_AT_PLUGIN_FILE);
    h->node_count = load32(b + RTK_BVH_CACHE_AT_NODE_COUNT);
    h->depth = load32(b + RTK_BVH_CACHE_AT_DEPTH);
    h->prim_count = load32(b + RTK_BVH_CACHE_AT_PRIM_COUNT);
    h->zero = load32(b + RTK_BVH_CACHE_AT_ZERO);
    /* Text from the file goes to a terminal: printable ASCII only. */
    for (int i = 0; i < BUILDER_TEXT; i++) {
        unsigned char c = b[RTK_BVH_CACHE_AT_BUILDER_TEXT + i];
        h->builder_text[i] = (char)(c == 0 || (c >= 0x20 && c < 0x7f) ? c : '?');
    }
    h->builder_text[BUILDER_TEXT] = '\0';
}

static void fill_header(unsigned char *b, const rtk_scene *s, uint64_t geometry, uint64_t builder,
                        const rtk_plugin *plugin)
{
    memset(b, 0, RTK_BVH_CACHE_HEADER_SIZE);
    memcpy(b, cache_magic, sizeof cache_magic);
    const uint32_t words[4] = {RTK_BVH_CACHE_VERSION, RTK_BVH_CACHE_ENDIAN, RTK_BVH_CACHE_HEADER_SIZE,
                               (uint32_t)sizeof(rtk_bvh_node)};
    memcpy(b + RTK_BVH_CACHE_AT_VERSION, words, sizeof words);
    const uint64_t hashes[3] = {geometry, builder, rtk_bvh_cache_plugin_stamp(plugin)};
    memcpy(b + RTK_BVH_CACHE_AT_GEOMETRY, hashes, sizeof hashes);
    const uint32_t counts[4] = {s->node_count, s->bvh_depth, s->triangle_count, 0};
    memcpy(b + RTK_BVH_CACHE_AT_NODE_COUNT, counts, sizeof counts);
    char text[BUILDER_TEXT + 1];
    builder_text(plugin, text);
    memcpy(b + RTK_BVH_CACHE_AT_BUILDER_TEXT, text, BUILDER_TEXT);
}

static uint64_t checksum(const unsigned char *header, const rtk_bvh_node *nodes, uint32_t node_count,
                         const uint32_t *prim_ids, uint32_t prim_count)
{
    uint64_t h = rtk_hash64(header, RTK_BVH_CACHE_HEADER_SIZE, RTK_BVH_CACHE_SEED);
    h = rtk_hash64(nodes, sizeof *nodes * (size_t)node_count, h);
    return rtk_hash64(prim_ids, sizeof *prim_ids * (size_t)prim_count, h);
}

/* The checks of one load, in order; on failure why says what is wrong
 * (empty when the file is simply absent). Fills the scene only on success. */
static int load_checked(rtk_scene *s, int fd, const char *path, uint64_t geometry, uint64_t builder,
                        const rtk_plugin *plugin, uint32_t threads, char *why, size_t why_size)
{
    const uint32_t n = s->triangle_count;
    struct stat st;
    if (fstat(fd, &st) != 0) {
        snprintf(why, why_size, "cannot stat: %s", strerror(errno));
        return 0;
    }
    if (!S_ISREG(st.st_mode)) {
        snprintf(why, why_size, "not a regular file");
        return 0;
    }
    const unsigned long long size = st.st_size > 0 ? (unsigned long long)st.st_size : 0;
    unsigned char hb[RTK_BVH_CACHE_HEADER_SIZE];
    ssize_t got = read_all(fd, hb, sizeof hb);
    if (got < 0) {
        snprintf(why, why_size, "cannot read: %s", strerror(errno));
        return 0;
    }
    if ((size_t)got >= sizeof cache_magic && memcmp(hb, cache_magic, sizeof cache_magic) != 0) {
        snprintf(why, why_size, "not an rtk BVH cache (bad magic)");
        return 0;
    }
    if ((size_t)got < sizeof hb) {
        snprintf(why, why_size, "truncated (%llu bytes, shorter than the %u-byte header)", size,
                 RTK_BVH_CACHE_HEADER_SIZE);
        return 0;
    }
    cache_header h;
    parse_header(hb, &h);
    if (h.endian != RTK_BVH_CACHE_ENDIAN) {
        if (h.endian == 0x04030201u)
            snprintf(why, why_size, "written on a machine of the other byte order");
        else
            snprintf(why, why_size, "bad byte-order marker 0x%08x", h.endian);
        return 0;
    }
    if (h.version != RTK_BVH_CACHE_VERSION) {
        snprintf(why, why_size, "format version %u, expected %u", h.version, RTK_BVH_CACHE_VERSION);
        return 0;
    }
    if (h.header_size != RTK_BVH_CACHE_HEADER_SIZE || h.node_size != sizeof(rtk_bvh_node) || h.zero != 0) {
        snprintf(why, why_size, "malformed header (header size %u, node size %u, reserved %u; expected %u, %u, 0)",
                 h.header_size, h.node_size, h.zero, RTK_BVH_CACHE_HEADER_SIZE, (unsigned)sizeof(rtk_bvh_node));
        return 0;
    }
    if (h.geometry != geometry || h.prim_count != n) {
        snprintf(why, why_size,
                 "stale: built for other geometry (%u triangles, hash %016llx; the scene has %u, %016llx)",
                 h.prim_count, (unsigned long long)h.geometry, n, (unsigned long long)geometry);
        return 0;
    }
    if (h.builder != builder) {
        char want[BUILDER_TEXT + 1];
        builder_text(plugin, want);
        if (strcmp(h.builder_text, want) != 0)
            snprintf(why, why_size, "stale: built by '%s', not '%s'", h.builder_text, want);
        else
            snprintf(why, why_size, "stale: built by '%s' with other parameters", h.builder_text);
        return 0;
    }
    if (h.plugin_file != rtk_bvh_cache_plugin_stamp(plugin)) {
        snprintf(why, why_size, "stale: built by an earlier build of '%s' (the plugin file changed since)",
                 h.builder_text);
        return 0;
    }
    /* n <= (UINT32_MAX - 1) / 2 (checked by the caller), so 2n - 1 fits. */
    const uint32_t max_nodes = 2 * n - 1;
    if (h.node_count == 0 || h.node_count > max_nodes) {
        snprintf(why, why_size, "node count %u outside 1 .. %u", h.node_count, max_nodes);
        return 0;
    }
    /* Both counts are 32-bit: the sum stays far below 2^64. */
    const unsigned long long expected = RTK_BVH_CACHE_HEADER_SIZE + 32ull * h.node_count + 4ull * h.prim_count + 8ull;
    if (size < expected) {
        snprintf(why, why_size, "truncated (%llu of %llu bytes)", size, expected);
        return 0;
    }
    if (size > expected) {
        snprintf(why, why_size, "%llu bytes, expected %llu (trailing data)", size, expected);
        return 0;
    }
    rtk_bvh_node *nodes = rtk_alloc(sizeof *nodes * (size_t)h.node_count);
    uint32_t *prims = rtk_alloc(sizeof *prims * (size_t)n);
    int ok = 0;
    uint64_t stored = 0;
    if (!nodes || !prims) {
        snprintf(why, why_size, "out of memory for %u nodes", h.node_count);
        goto done;
    }
    const size_t node_bytes = sizeof *nodes * (size_t)h.node_count, prim_bytes = sizeof *prims * (size_t)n;
    double t0 = rtk_now();
    ssize_t a = read_all(fd, nodes, node_bytes);
    ssize_t b = a == (ssize_t)node_bytes ? read_all(fd, prims, prim_bytes) : 0;
    ssize_t c = b == (ssize_t)prim_bytes ? read_all(fd, &stored, sizeof stored) : 0;
    if (a < 0 || b < 0 || c < 0) {
        snprintf(why, why_size, "cannot read: %s", strerror(errno));
        goto done;
    }
    if (c != (ssize_t)sizeof stored) {
        snprintf(why, why_size, "truncated while reading (the file changed)");
        goto done;
    }
    double t1 = rtk_now();
    if (checksum(hb, nodes, h.node_count, prims, n) != stored) {
        snprintf(why, why_size, "checksum mismatch");
        goto done;
    }
    double t2 = rtk_now();
    rtk_build_args args;
    memset(&args, 0, sizeof args);
    args.size = sizeof args;
    args.prim_count = n;
    args.max_nodes = max_nodes;
    args.nodes = nodes;
    args.node_count = h.node_count;
    args.prim_order = prims;
    args.thread_count = threads ? threads : 1;
    uint32_t depth = 0;
    /* The structure, then (as the wide tree gathers the corners) the
     * leaves' boxes against them. */
    int valid = rtk_bvh_validate(&args, 0, &depth) == RTK_OK;
    double t3 = rtk_now();
    if (valid && depth != h.depth) {
        snprintf(why, why_size, "header says depth %u, the tree has %u", h.depth, depth);
        goto done;
    }
    if (valid) {
        s->nodes = nodes, s->node_count = h.node_count, s->bvh_depth = depth;
        s->prim_ids = prims;
        valid = rtk_bvh_finish(s, threads ? threads : 1, NULL, 0, 1) == RTK_OK;
        if (!valid) {
            s->nodes = NULL, s->prim_ids = NULL;
            s->node_count = 0, s->bvh_depth = 0;
        }
    }
    if (!valid) {
        const char *msg = rtk_error_message();
        const char *prefix = "builder output: ";
        if (strncmp(msg, prefix, strlen(prefix)) == 0)
            msg += strlen(prefix);
        snprintf(why, why_size, "invalid tree: %s", msg);
        goto done;
    }
    nodes = NULL, prims = NULL; /* the scene's now */
    ok = 1;
    rtk_log(RTK_LOG_DEBUG,
            "BVH cache %s: loaded %u nodes, depth %u (read %.2f ms, checksum %.2f ms, validation %.2f ms, "
            "wide tree and leaf check %.2f ms)",
            path, s->node_count, depth, 1e3 * (t1 - t0), 1e3 * (t2 - t1), 1e3 * (t3 - t2), 1e3 * (rtk_now() - t3));
done:
    free(nodes);
    free(prims);
    return ok;
}

int rtk_bvh_cache_load(rtk_scene *s, const char *path, uint64_t geometry, uint64_t builder, const rtk_plugin *plugin,
                       uint32_t threads)
{
    clear_bvh(s);
    if (s->triangle_count == 0 || s->triangle_count > (UINT32_MAX - 1) / 2)
        return 0;
    /* O_NONBLOCK: a FIFO planted at the path must not hang the render. */
    int fd = open(path, O_RDONLY | O_CLOEXEC | O_NONBLOCK);
    char why[1024] = "";
    int ok = 0;
    if (fd < 0) {
        if (errno == ENOENT || errno == ENOTDIR)
            rtk_log(RTK_LOG_DEBUG, "BVH cache %s: not there yet", path);
        else
            snprintf(why, sizeof why, "cannot open: %s", strerror(errno));
    } else {
        ok = load_checked(s, fd, path, geometry, builder, plugin, threads, why, sizeof why);
        if (ok)
            futimens(fd, NULL); /* used now, for rtk_bvh_cache_prune; a read-only cache stays as it is */
        close(fd);
    }
    if (!ok && why[0])
        rtk_log(RTK_LOG_WARN, "BVH cache %s: %s; rebuilding it", path, why);
    return ok;
}

/* Writes all of size bytes; 0 on failure with errno set. */
static int write_all(int fd, const void *buf, size_t size)
{
    size_t done = 0;
    while (done < size) {
        ssize_t n = write(fd, (const char *)buf + done, size - done);
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0) {
            if (n == 0)
                errno = EIO;
            return 0;
        }
        done += (size_t)n;
    }
    return 1;
}

rtk_status rtk_bvh_cache_save(const rtk_scene *s, const char *path, uint64_t geometry, uint64_t builder,
                              const rtk_plugin *plugin)
{
    if (!s->nodes || s->node_count == 0 || !s->prim_ids || s->triangle_count == 0)
        return rtk_error(RTK_ERR_INVALID, "BVH cache %s: the scene has no kernel BVH to save", path);
    static atomic_uint counter;
    size_t len = strlen(path) + 64;
    char *temp = rtk_alloc(len);
    if (!temp)
        return RTK_ERR_NOMEM;
    rtk_temp_remove_stale(path, len - 64); /* output.h: what killed saves left */
    snprintf(temp, len, "%s.tmp%ld-%u", path, (long)getpid(), atomic_fetch_add(&counter, 1));
    int slot = rtk_temp_register(temp);
    rtk_xfsz_hold();
    unsigned char hb[RTK_BVH_CACHE_HEADER_SIZE];
    fill_header(hb, s, geometry, builder, plugin);
    uint64_t sum = checksum(hb, s->nodes, s->node_count, s->prim_ids, s->triangle_count);
    const char *step = "create";
    int fd = open(temp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    int ok = fd >= 0;
    rtk_interrupt_stop_point("cache-save");
    if (ok) {
        step = "write";
        ok = write_all(fd, hb, sizeof hb) && write_all(fd, s->nodes, sizeof *s->nodes * (size_t)s->node_count) &&
             write_all(fd, s->prim_ids, sizeof *s->prim_ids * (size_t)s->triangle_count) &&
             write_all(fd, &sum, sizeof sum);
        int err = errno;
        if (close(fd) != 0 && ok) {
            ok = 0;
            err = errno;
        }
        errno = err;
    }
    if (ok) {
        step = "rename";
        ok = rename(temp, path) == 0;
    }
    rtk_status st = RTK_OK;
    if (!ok) {
        int err = errno;
        if (fd >= 0)
            unlink(temp);
        st = rtk_error(RTK_ERR_IO, "BVH cache %s: cannot %s %s: %s", path, step, strcmp(step, "rename") ? temp : "it",
                       strerror(err));
        rtk_log(RTK_LOG_WARN, "%s; rendering goes on without saving it", rtk_error_message());
    } else {
        rtk_log(RTK_LOG_DEBUG, "BVH cache %s: saved %u nodes", path, s->node_count);
    }
    rtk_temp_unregister(slot);
    rtk_xfsz_release();
    free(temp);
    return st;
}

/* Whether the 16 characters at s are lowercase hex digits (stops at a NUL). */
static int hex16(const char *s)
{
    for (int i = 0; i < 16; i++)
        if (!((s[i] >= '0' && s[i] <= '9') || (s[i] >= 'a' && s[i] <= 'f')))
            return 0;
    return 1;
}

/* Whether name is a tree file's, <16 hex>-<16 hex>-<16 hex>.bvh (what
 * rtk_bvh_cache_path makes) or <16 hex>-<16 hex>.bvh (an older rtk's
 * name, without the plugin key: pruned, never read), and with tmp set, a
 * save's temporary file (that name and ".tmp" then anything). */
static int cache_file_name(const char *name, int *tmp)
{
    if (!hex16(name) || name[16] != '-' || !hex16(name + 17))
        return 0;
    const size_t end = name[33] == '-' && hex16(name + 34) ? 50 : 33;
    if (strncmp(name + end, ".bvh", 4) != 0)
        return 0;
    *tmp = name[end + 4] != '\0';
    return !*tmp || strncmp(name + end + 4, ".tmp", 4) == 0;
}

typedef struct cache_entry {
    char *name;
    uint64_t bytes;
    struct timespec used;
} cache_entry;

static int timespec_before(struct timespec a, struct timespec b)
{
    return a.tv_sec < b.tv_sec || (a.tv_sec == b.tv_sec && a.tv_nsec < b.tv_nsec);
}

/* Least recently used first; equal times by name, so the order is fixed. */
static int entry_order(const void *x, const void *y)
{
    const cache_entry *a = x, *b = y;
    if (timespec_before(a->used, b->used))
        return -1;
    if (timespec_before(b->used, a->used))
        return 1;
    return strcmp(a->name, b->name);
}

/* Removes dir/name; 1 when it went (or was already gone). */
static int remove_entry(int fd, const char *dir, const char *name)
{
    if (unlinkat(fd, name, 0) == 0 || errno == ENOENT)
        return 1;
    rtk_log(RTK_LOG_DEBUG, "BVH cache %s/%s: cannot remove it: %s", dir, name, strerror(errno));
    return 0;
}

uint32_t rtk_bvh_cache_prune(const char *dir, uint64_t limit, struct timespec since, uint64_t *freed)
{
    DIR *d = opendir(dir);
    if (!d) {
        rtk_log(RTK_LOG_DEBUG, "BVH cache %s: cannot read the directory to prune it: %s", dir, strerror(errno));
        return 0;
    }
    const int fd = dirfd(d);
    struct timespec now;
    clock_gettime(CLOCK_REALTIME, &now);
    cache_entry *entries = NULL;
    uint32_t count = 0, cap = 0, removed = 0;
    uint64_t total = 0, gone = 0;
    int complete = 1;
    for (struct dirent *e; (e = readdir(d));) {
        int tmp;
        struct stat st;
        if (!cache_file_name(e->d_name, &tmp) || fstatat(fd, e->d_name, &st, AT_SYMLINK_NOFOLLOW) != 0 ||
            !S_ISREG(st.st_mode))
            continue;
        if (tmp) {
            /* A save takes seconds at most: an hour-old one is dead. */
            if (now.tv_sec - st.st_mtim.tv_sec >= 3600 && remove_entry(fd, dir, e->d_name))
                removed++, gone += (uint64_t)st.st_size;
            continue;
        }
        total += (uint64_t)st.st_size;
        if (!timespec_before(st.st_mtim, since))
            continue; /* this render's own */
        if (!rtk_grow_array((void **)&entries, &cap, count, sizeof *entries)) {
            complete = 0;
            break;
        }
        if (!(entries[count].name = rtk_strdup(e->d_name))) {
            complete = 0;
            break;
        }
        entries[count].bytes = (uint64_t)st.st_size;
        entries[count++].used = st.st_mtim;
    }
    /* Out of memory part way: the total is short, so remove nothing more. */
    if (complete && limit > 0 && total > limit) {
        if (count > 1) /* entries is NULL when every file was this render's own */
            qsort(entries, count, sizeof *entries, entry_order);
        for (uint32_t i = 0; i < count && total > limit; i++) {
            if (remove_entry(fd, dir, entries[i].name)) {
                total -= entries[i].bytes;
                gone += entries[i].bytes;
                removed++;
            }
        }
    }
    closedir(d);
    for (uint32_t i = 0; i < count; i++)
        free(entries[i].name);
    free(entries);
    if (freed)
        *freed += gone;
    return removed;
}

/* mkdir -p dir; on failure why says what went wrong. */
static int make_dirs(const char *dir, char *why, size_t why_size)
{
    struct stat st;
    if (stat(dir, &st) == 0) {
        if (S_ISDIR(st.st_mode))
            return 1;
        snprintf(why, why_size, "it exists and is not a directory");
        return 0;
    }
    char *copy = rtk_strdup(dir);
    if (!copy) {
        snprintf(why, why_size, "out of memory");
        return 0;
    }
    int ok = 1;
    for (char *p = copy + 1; ok; p++) {
        if (*p != '/' && *p != '\0')
            continue;
        char c = *p;
        *p = '\0';
        if (mkdir(copy, 0755) != 0 && errno != EEXIST) {
            snprintf(why, why_size, "cannot create '%s': %s", copy, strerror(errno));
            ok = 0;
        }
        *p = c;
        if (!c)
            break;
    }
    free(copy);
    if (ok && (stat(dir, &st) != 0 || !S_ISDIR(st.st_mode))) {
        snprintf(why, why_size, "it is not a directory");
        ok = 0;
    }
    return ok;
}

/* 1 when the accelerator answers traces itself (ABI 1.1): a cached tree
 * would bypass its traversal, so such builds are never cached. */
static int own_traversal(const rtk_plugin *plugin)
{
    const rtk_accelerator_fns *fns = plugin->functions;
    if (fns->size < offsetof(rtk_accelerator_fns, any) + sizeof fns->any)
        return 0;
    return fns->closest && fns->any;
}

rtk_status rtk_bvh_build_cached(rtk_scene *s, const rtk_plugin *plugin, const rtk_params *params, uint32_t threads,
                                const char *dir, rtk_bvh_cache_use *use)
{
    if (rtk_accelerator_is_device(plugin))
        return rtk_device_build(s, plugin, params, threads, dir, use);
    if (s->instance_count) {
        memset(use, 0, sizeof *use);
        rtk_status st = rtk_instances_build(s, plugin, params, threads, dir, &use->from_cache);
        if (st == RTK_OK && dir)
            snprintf(use->file, sizeof use->file, "%s (one file per mesh)", dir);
        return st;
    }
    return rtk_bvh_build_cached_own(s, plugin, params, threads, dir, use);
}

rtk_status rtk_bvh_build_cached_own(rtk_scene *s, const rtk_plugin *plugin, const rtk_params *params,
                                    uint32_t threads, const char *dir, rtk_bvh_cache_use *use)
{
    memset(use, 0, sizeof *use);
    if (!dir || s->triangle_count == 0 || s->triangle_count > (UINT32_MAX - 1) / 2 || own_traversal(plugin))
        return rtk_bvh_build(s, plugin, params, threads);
    uint64_t geometry = rtk_bvh_cache_geometry_hash(s);
    uint64_t builder = rtk_bvh_cache_builder_hash(plugin, params);
    char *path = rtk_bvh_cache_path(dir, geometry, builder, rtk_bvh_cache_plugin_key(plugin));
    if (!path)
        return rtk_bvh_build(s, plugin, params, threads);
    if (rtk_bvh_cache_load(s, path, geometry, builder, plugin, threads)) {
        use->from_cache = 1;
        snprintf(use->file, sizeof use->file, "%s", path);
        free(path);
        return RTK_OK;
    }
    rtk_status st = rtk_bvh_build(s, plugin, params, threads);
    if (st == RTK_OK && s->node_count > 0 && !s->own_traversal) {
        char why[1024] = "";
        char key[1200];
        snprintf(key, sizeof key, "bvh cache dir %s", dir);
        if (!make_dirs(dir, why, sizeof why))
            rtk_warn_once(key, "BVH cache directory %s: %s; rendering goes on without a cache", dir, why);
        else if (rtk_bvh_cache_save(s, path, geometry, builder, plugin) == RTK_OK)
            snprintf(use->file, sizeof use->file, "%s", path);
    }
    free(path);
    return st;
}

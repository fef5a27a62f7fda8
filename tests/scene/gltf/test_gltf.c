/* glTF features and refusals (kernel/scene/io/gltf.cpp): each on a small file
 * written here, its buffer made by the gbuf helpers below, then the
 * Khronos sample models of ../shared/data/gltf-samples when present.
 * - refusals before tinygltf parses: JSON nested past the limit (.gltf
 *   and .glb), glTF 1.0 binaries, unsupported required extensions (Draco,
 *   EXT_meshopt_compression) named by rtk's own message. */
#include "config/config.h"
#include "render/render.h"
#include "image/image.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "check.h"
#include "scratch.h"

#ifdef RTK_HAVE_MESHOPT
#include <meshoptimizer.h>
#endif

#ifndef RTK_SOURCE_ROOT
#define RTK_SOURCE_ROOT "."
#endif

#define ALL_NEEDS (RTK_NEED_NORMALS | RTK_NEED_UVS | RTK_NEED_MATERIALS | RTK_NEED_TEXTURES | RTK_NEED_LIGHTS)

static const rtk_plugin *builder;
static rtk_params *builder_params;

/* ---- a glTF's buffer, buffer views and accessors, built up in memory ---- */

typedef struct gbuf {
    unsigned char data[1 << 16];
    size_t size;
    char views[8192], accessors[8192];
    int view_count, accessor_count;
} gbuf;

/* Appends bytes (padded to 4) as a buffer view; its index. */
static int gview(gbuf *g, const void *bytes, size_t n)
{
    memcpy(g->data + g->size, bytes, n);
    size_t len = strlen(g->views);
    snprintf(g->views + len, sizeof g->views - len, "%s{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}",
             g->view_count ? "," : "", g->size, n);
    g->size = (g->size + n + 3) & ~(size_t)3;
    return g->view_count++;
}

/* Appends an accessor given as its JSON members; its index. */
static int gaccessor_json(gbuf *g, const char *members)
{
    size_t len = strlen(g->accessors);
    snprintf(g->accessors + len, sizeof g->accessors - len, "%s{%s}", g->accessor_count ? "," : "", members);
    return g->accessor_count++;
}

/* count elements of type ("VEC3") in component type (5126 float ...) from
 * bytes, with extra members (",\"normalized\":true") or NULL; its index. */
static int gaccessor(gbuf *g, const void *bytes, size_t n, int component, int count, const char *type,
                     const char *extra)
{
    char members[512];
    snprintf(members, sizeof members, "\"bufferView\":%d,\"componentType\":%d,\"count\":%d,\"type\":\"%s\"%s",
             gview(g, bytes, n), component, count, type, extra ? extra : "");
    return gaccessor_json(g, members);
}

static int gfloats(gbuf *g, const float *v, int count, const char *type)
{
    int k = strcmp(type, "SCALAR") == 0 ? 1 : strcmp(type, "MAT4") == 0 ? 16 : type[3] - '0';
    return gaccessor(g, v, sizeof(float) * (size_t)(count * k), 5126, count, type, NULL);
}

/* Writes name (.gltf) with the buffer beside it (name.bin) and body, the
 * members other than asset and the buffer's; returns its path. */
static const char *write_gltf(const char *name, const gbuf *g, const char *body)
{
    char bin[256];
    snprintf(bin, sizeof bin, "%s.bin", name);
    write_file(bin, g->data, g->size ? g->size : 4);
    size_t cap = strlen(body) + strlen(g->views) + strlen(g->accessors) + 1024;
    char *json = malloc(cap);
    snprintf(json, cap,
             "{\"asset\":{\"version\":\"2.0\"},%s,\"buffers\":[{\"uri\":\"%s\",\"byteLength\":%zu}],"
             "\"bufferViews\":[%s],\"accessors\":[%s]}",
             body, bin, g->size ? g->size : 4, g->views, g->accessors);
    const char *path = write_file(name, json, strlen(json));
    free(json);
    return path;
}

static void put_u32(unsigned char *p, uint32_t v)
{
    for (int k = 0; k < 4; k++)
        p[k] = (unsigned char)(v >> (8 * k));
}

/* Writes a .glb: header of version, a JSON chunk and a BIN chunk of
 * bin_size bytes when bin is not NULL. */
static const char *write_glb_bin(const char *name, uint32_t version, const char *json, const void *bin,
                                 size_t bin_size)
{
    size_t n = (strlen(json) + 3) & ~(size_t)3, padded = (bin_size + 3) & ~(size_t)3;
    size_t total = 20 + n + (bin ? 8 + padded : 0);
    unsigned char *out = calloc(1, total);
    memcpy(out, "glTF", 4);
    put_u32(out + 4, version);
    put_u32(out + 8, (uint32_t)total);
    put_u32(out + 12, (uint32_t)n);
    memcpy(out + 16, "JSON", 4);
    memset(out + 20, ' ', n);
    memcpy(out + 20, json, strlen(json));
    if (bin) {
        put_u32(out + 20 + n, (uint32_t)padded);
        memcpy(out + 24 + n, "BIN\0", 4);
        memcpy(out + 28 + n, bin, bin_size);
    }
    const char *path = write_file(name, out, total);
    free(out);
    return path;
}

static const char *write_glb(const char *name, uint32_t version, const char *json)
{
    return write_glb_bin(name, version, json, NULL, 0);
}

static rtk_scene *load(const char *path, uint32_t needs)
{
    rtk_scene *s = NULL;
    if (rtk_scene_load(path, needs, &s) != RTK_OK) {
        check(0, "load %s: %s", path, rtk_error_message());
        return NULL;
    }
    return s;
}

static rtk_scene *load_built(const char *path, uint32_t needs)
{
    rtk_scene *s = load(path, needs);
    rtk_bvh_cache_use use;
    if (s && rtk_bvh_build_cached(s, builder, builder_params, 1, NULL, &use) != RTK_OK) {
        check(0, "build %s: %s", path, rtk_error_message());
        rtk_scene_free(s);
        return NULL;
    }
    return s;
}

/* Loading path fails with code and a message naming the file and holding
 * every one of the texts (NULL-terminated). */
static void expect_refused(const char *what, const char *path, rtk_status code, ...)
{
    rtk_scene *s = NULL;
    rtk_status status = rtk_scene_load(path, ALL_NEEDS, &s);
    const char *msg = rtk_error_message();
    int ok = status == code && strstr(msg, path) != NULL;
    va_list ap;
    va_start(ap, code);
    for (const char *t = va_arg(ap, const char *); t; t = va_arg(ap, const char *))
        ok = ok && strstr(msg, t) != NULL;
    va_end(ap);
    check(ok, "%s refused: status %d, \"%s\"", what, (int)status, status == RTK_OK ? "" : msg);
    rtk_scene_free(s);
}

/* A unit triangle's POSITION and indices; the mesh JSON refers to
 * accessors 0 and 1. */
static void triangle_data(gbuf *g)
{
    const float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const uint16_t idx[4] = {0, 1, 2, 0};
    gaccessor(g, pos, sizeof pos, 5126, 3, "VEC3", ",\"min\":[0,0,0],\"max\":[1,1,0]");
    gaccessor(g, idx, 6, 5123, 3, "SCALAR", NULL);
}

static const char *triangle_scene = "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
                                    "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1}]}]";

/* ---- refusals before tinygltf parses ---- */

static void test_refusals(void)
{
    printf("refusals before parsing\n");
    /* 15,000 nested arrays in asset.extras crashed tinygltf's parser. */
    const int deep = 15000;
    char *json = malloc(2 * (size_t)deep + 256);
    int n = sprintf(json, "{\"asset\":{\"version\":\"2.0\",\"extras\":");
    for (int i = 0; i < deep; i++)
        json[n++] = '[';
    for (int i = 0; i < deep; i++)
        json[n++] = ']';
    sprintf(json + n, "}}");
    expect_refused("15,000 nested arrays (.gltf)", write_file("deep.gltf", json, strlen(json)), RTK_ERR_PARSE,
                   "nested more than 100 levels", NULL);
    expect_refused("15,000 nested arrays (.glb)", write_glb("deep.glb", 2, json), RTK_ERR_PARSE,
                   "nested more than 100 levels", NULL);
    free(json);

    /* Brackets inside strings do not count, and 100 levels are accepted. */
    gbuf *g = calloc(1, sizeof *g);
    triangle_data(g);
    char body[4096];
    n = snprintf(body, sizeof body, "%s,\"extras\":{\"text\":\"[[[{{{\\\"[[[\",\"deep\":", triangle_scene);
    for (int i = 0; i < 98; i++)
        body[n++] = '[';
    for (int i = 0; i < 98; i++)
        body[n++] = ']';
    sprintf(body + n, "}");
    rtk_scene *s = load(write_gltf("deep_ok.gltf", g, body), 0);
    check(s && s->triangle_count == 1, "100 levels of JSON and brackets in strings load");
    rtk_scene_free(s);

    /* A FIFO is refused at once, not read (which would wait for a writer). */
    const char *fifo = in_tmp("fifo.gltf");
    if (mkfifo(fifo, 0600) == 0)
        expect_refused("a FIFO", fifo, RTK_ERR_IO, "regular file", NULL);
    else
        check(0, "mkfifo %s", fifo);

    expect_refused("glTF 1.0 binary", write_glb("v1.glb", 1, "{\"asset\":{\"version\":\"1.0\"}}"),
                   RTK_ERR_UNSUPPORTED, "glTF 1.0", NULL);
    expect_refused("glTF 1.0 text",
                   write_file("v1.gltf", "{\"asset\":{\"version\":\"1.0\"},\"meshes\":{}}", 39),
                   RTK_ERR_UNSUPPORTED, "glTF 1.0", NULL);

    /* Draco: an accessor without a buffer view, the data in the extension;
     * tinygltf alone fails with "accessor[0] invalid bufferView". */
    const char *draco = "{\"asset\":{\"version\":\"2.0\"},"
                        "\"extensionsUsed\":[\"KHR_draco_mesh_compression\"],"
                        "\"extensionsRequired\":[\"KHR_draco_mesh_compression\"],"
                        "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
                        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"extensions\":"
                        "{\"KHR_draco_mesh_compression\":{\"bufferView\":0,\"attributes\":{\"POSITION\":0}}}}]}],"
                        "\"accessors\":[{\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"}],"
                        "\"bufferViews\":[{\"buffer\":0,\"byteLength\":4}],"
                        "\"buffers\":[{\"byteLength\":4,\"uri\":\"data:application/octet-stream;base64,AAAAAA==\"}]}";
#ifdef RTK_HAVE_DRACO
    /* Decoded before anything else reads the primitive: four zero bytes
     * are no Draco mesh, said in rtk's words. */
    expect_refused("Draco", write_file("draco_zero.gltf", draco, strlen(draco)), RTK_ERR_PARSE,
                   "KHR_draco_mesh_compression", "could not decode", NULL);
    expect_refused("Draco (.glb)", write_glb("draco_zero.glb", 2, draco), RTK_ERR_PARSE,
                   "KHR_draco_mesh_compression", NULL);
#else
    expect_refused("Draco", write_file("draco_zero.gltf", draco, strlen(draco)), RTK_ERR_UNSUPPORTED,
                   "KHR_draco_mesh_compression", "requires", NULL);
    expect_refused("Draco (.glb)", write_glb("draco_zero.glb", 2, draco), RTK_ERR_UNSUPPORTED,
                   "KHR_draco_mesh_compression", NULL);
#endif
    const char *meshopt = "{\"asset\":{\"version\":\"2.0\"},"
                          "\"extensionsRequired\":[\"EXT_meshopt_compression\"],"
                          "\"bufferViews\":[{\"buffer\":0,\"byteLength\":4,\"extensions\":{\"EXT_meshopt_compression\":"
                          "{\"buffer\":0,\"byteLength\":4,\"byteStride\":4,\"count\":1,\"mode\":\"ATTRIBUTES\"}}}],"
                          "\"accessors\":[{\"bufferView\":7,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"}],"
                          "\"buffers\":[{\"byteLength\":4,\"uri\":\"data:application/octet-stream;base64,AAAAAA==\"}]}";
#ifdef RTK_HAVE_MESHOPT
    /* Decoded once tinygltf has parsed the file: four zero bytes are no
     * meshopt vertex stream. */
    expect_refused("EXT_meshopt_compression", write_file("meshopt_bad.gltf", meshopt, strlen(meshopt)),
                   RTK_ERR_PARSE, "buffer view 0: EXT_meshopt_compression: the data does not decode", NULL);
#else
    expect_refused("EXT_meshopt_compression", write_file("meshopt_bad.gltf", meshopt, strlen(meshopt)),
                   RTK_ERR_UNSUPPORTED, "EXT_meshopt_compression", NULL);
#endif
    free(g);
}

/* Overwrites the little-endian u32 at byte at of path. */
static void patch_u32(const char *path, long at, uint32_t v)
{
    unsigned char b[4];
    put_u32(b, v);
    FILE *f = fopen(path, "r+b");
    check(f && fseek(f, at, SEEK_SET) == 0 && fwrite(b, 1, 4, f) == 4, "patch %s", path);
    if (f)
        fclose(f);
}

/* A GLB container that does not hold what its header and chunks declare
 * is refused, naming the file, before tinygltf reads it: tinygltf 2.7
 * lets a BIN chunk run 8 bytes past the file and copies them (a read past
 * the end under ASan), and says "Invalid glTF binary." of the rest. */
static void test_glb_container(void)
{
    printf("GLB containers\n");
    const char *json = "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"byteLength\":12}]}";
    const unsigned char bin[12] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};
    const size_t n = (strlen(json) + 3) & ~(size_t)3, total = 20 + n + 8 + 12;
    const char *whole = write_glb_bin("whole.glb", 2, json, bin, sizeof bin);
    const char *past = write_glb_bin("bin_past.glb", 2,
                                     "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"byteLength\":16}]}", bin,
                                     sizeof bin);
    const char *cut = write_glb_bin("cut.glb", 2, json, bin, sizeof bin);
    if (!whole || !past || !cut) {
        check(0, "write the GLB files");
        return;
    }
    rtk_scene *s = load(whole, ALL_NEEDS);
    check(s != NULL, "the whole GLB loads%s%s", s ? "" : ": ", s ? "" : rtk_error_message());
    rtk_scene_free(s);

    patch_u32(past, (long)(20 + n), 16);
    expect_refused("a BIN chunk 4 bytes past the end", past, RTK_ERR_PARSE, "BIN chunk runs past the end", NULL);

    check(truncate(cut, (off_t)total - 4) == 0, "truncate %s", cut);
    expect_refused("a GLB 4 bytes short", cut, RTK_ERR_PARSE, "truncated", "declares", NULL);
    check(truncate(cut, 12) == 0, "truncate %s", cut);
    expect_refused("a GLB cut inside its header", cut, RTK_ERR_PARSE, "ends inside its 20-byte header", NULL);

    /* The Draco primitive's JSON is rewritten before tinygltf parses it;
     * the check comes first, so a file longer on paper stays refused. */
    const char *draco = "{\"asset\":{\"version\":\"2.0\"},\"meshes\":[{\"primitives\":[{\"attributes\":"
                        "{\"POSITION\":0},\"extensions\":{\"KHR_draco_mesh_compression\":{\"bufferView\":0,"
                        "\"attributes\":{\"POSITION\":0}}}}]}],\"buffers\":[{\"byteLength\":12}]}";
    const char *longer = write_glb_bin("draco_longer.glb", 2, draco, bin, sizeof bin);
    struct stat st;
    if (!longer || stat(longer, &st) != 0) {
        check(0, "write draco_longer.glb");
        return;
    }
    patch_u32(longer, 8, (uint32_t)st.st_size + 8);
    expect_refused("a Draco GLB 8 bytes short", longer, RTK_ERR_PARSE, "truncated", "declares", NULL);
}

/* ---- KHR_mesh_quantization and sparse accessors ---- */

static int near(double a, double b, double tol) { return fabs(a - b) <= tol; }

/* Corner c of triangle t of s: position, normal, uv. */
static const float *corner_pos(const rtk_scene *s, uint32_t t, int c) { return s->positions + 3 * (size_t)s->indices[3 * t + c]; }

static void test_quantization(void)
{
    printf("KHR_mesh_quantization\n");
    gbuf *g = calloc(1, sizeof *g);
    /* SHORT positions as integers, BYTE normals normalized, UNSIGNED_BYTE
     * texture coordinates normalized and UNSIGNED_SHORT not (a quantized
     * file scales them back with KHR_texture_transform or node scale). */
    const int16_t pos[12] = {0, 0, 0, 4, 0, 0, 0, -4, 0, 0, 0, 0};
    const int8_t nrm[12] = {0, 0, 127, 0, 0, -128, 0, 90, 90, 0, 0, 0};
    const uint8_t uv[8] = {0, 255, 51, 0, 102, 0, 0, 0};
    triangle_data(g); /* accessors 0, 1 */
    gaccessor(g, pos, 6 * 3, 5122, 3, "VEC3", ",\"min\":[0,-4,0],\"max\":[4,0,0]");
    gaccessor(g, nrm, 12, 5120, 3, "VEC3", ",\"normalized\":true");
    gaccessor(g, uv, 6, 5121, 3, "VEC2", ",\"normalized\":true");
    const char *body = "\"extensionsUsed\":[\"KHR_mesh_quantization\"],"
                       "\"extensionsRequired\":[\"KHR_mesh_quantization\"],"
                       "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0,\"scale\":[0.25,0.25,0.25]}],"
                       "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":2,\"NORMAL\":3,"
                       "\"TEXCOORD_0\":4},\"indices\":1}]}]";
    rtk_scene *s = load(write_gltf("quantized.gltf", g, body), ALL_NEEDS);
    if (s) {
        const float *b = corner_pos(s, 0, 1), *c = corner_pos(s, 0, 2);
        check(s->triangle_count == 1 && b[0] == 1.0f && c[1] == -1.0f, "SHORT positions scaled by the node: (%g %g %g)",
              b[0], c[1], c[2]);
        const float *n = s->normals;
        check(n && n[2] == 1.0f && n[5] == -1.0f && near(n[7], sqrt(0.5), 1e-6) && near(n[8], sqrt(0.5), 1e-6),
              "BYTE normalized normals: +z, -z (-128 is -1), diagonal");
        const float *t = s->uvs;
        check(t && t[0] == 0.0f && t[1] == 1.0f && near(t[2], 0.2, 1e-7) && near(t[4], 0.4, 1e-7),
              "UNSIGNED_BYTE normalized texture coordinates");
    }
    rtk_scene_free(s);
    free(g);
}

static void test_sparse(void)
{
    printf("sparse accessors\n");
    gbuf *g = calloc(1, sizeof *g);
    triangle_data(g);
    /* Vertex 2 of the triangle moved by a sparse accessor over accessor 0's
     * view, and a sparse accessor with no buffer view (zeros) that sets
     * vertices 1 and 2 of another triangle. */
    const uint8_t which[2] = {2, 0};
    const float moved[3] = {0, 5, 0};
    const uint16_t which2[2] = {1, 2};
    const float set[6] = {3, 0, 0, 0, 3, 0};
    int iv = gview(g, which, 1), vv = gview(g, moved, sizeof moved);
    int iv2 = gview(g, which2, 4), vv2 = gview(g, set, sizeof set);
    char members[512];
    snprintf(members, sizeof members,
             "\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"sparse\":{\"count\":1,"
             "\"indices\":{\"bufferView\":%d,\"componentType\":5121},\"values\":{\"bufferView\":%d}}",
             iv, vv);
    gaccessor_json(g, members); /* 2 */
    snprintf(members, sizeof members,
             "\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"sparse\":{\"count\":2,"
             "\"indices\":{\"bufferView\":%d,\"componentType\":5123},\"values\":{\"bufferView\":%d}}",
             iv2, vv2);
    gaccessor_json(g, members); /* 3 */
    snprintf(members, sizeof members,
             "\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"sparse\":{\"count\":1,"
             "\"indices\":{\"bufferView\":%d,\"componentType\":5121},"
             "\"values\":{\"bufferView\":%d,\"byteOffset\":4}}", iv, vv);
    gaccessor_json(g, members); /* 4: values past their view's end */
    const char *body = "\"scenes\":[{\"nodes\":[0,1]}],\"nodes\":[{\"mesh\":0},{\"mesh\":1}],"
                       "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":2},\"indices\":1}]},"
                       "{\"primitives\":[{\"attributes\":{\"POSITION\":3},\"indices\":1}]}]";
    rtk_scene *s = load(write_gltf("sparse.gltf", g, body), 0);
    if (s) {
        check(s->triangle_count == 2, "two triangles");
        const float *a = corner_pos(s, 0, 0), *b = corner_pos(s, 0, 1), *c = corner_pos(s, 0, 2);
        check(a[0] == 0 && b[0] == 1 && c[1] == 5, "sparse value replaces vertex 2 of the base view");
        a = corner_pos(s, 1, 0), b = corner_pos(s, 1, 1), c = corner_pos(s, 1, 2);
        check(a[0] == 0 && a[1] == 0 && b[0] == 3 && c[1] == 3, "sparse over zeros (no buffer view)");
    }
    rtk_scene_free(s);
    const char *bad = "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
                      "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":4},\"indices\":1}]}]";
    expect_refused("sparse values past their view", write_gltf("sparse_bad.gltf", g, bad), RTK_ERR_PARSE,
                   "sparse values", "accessor 4", NULL);
    /* Zeros for a billion vertices from a few bytes of JSON: refused. */
    snprintf(members, sizeof members,
             "\"componentType\":5126,\"count\":1000000000,\"type\":\"VEC3\",\"sparse\":{\"count\":2,"
             "\"indices\":{\"bufferView\":%d,\"componentType\":5123},\"values\":{\"bufferView\":%d}}",
             iv2, vv2);
    gaccessor_json(g, members); /* 5 */
    const char *huge = "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
                       "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":5},\"indices\":1}]}]";
    expect_refused("a billion zeros without a buffer view", write_gltf("sparse_huge.gltf", g, huge), RTK_ERR_PARSE,
                   "1000000000 elements without a buffer view", NULL);
    free(g);
}

/* ---- texture coordinates: KHR_texture_transform, TEXCOORD_1; COLOR_0 ---- */

/* A 2x2 PNG: red, green on the top row, blue, white below; texel centres
 * at u, v = 0.25 and 0.75. */
static void write_quads_png(const char *name)
{
    const float rgba[16] = {1, 0, 0, 1, 0, 1, 0, 1, 0, 0, 1, 1, 1, 1, 1, 1};
    const char *names[4] = {"R", "G", "B", "A"};
    if (rtk_image_write(in_tmp(name), 2, 2, 4, names, rgba, 0) != RTK_OK)
        check(0, "write %s: %s", name, rtk_error_message());
}

/* What the surface at barycentrics (u, v) of s's triangle prim shows. */
static rtk_surface surface_at(const rtk_scene *s, uint32_t prim, float u, float v)
{
    rtk_ray ray = {{0.25f, 0.25f, 1.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, INFINITY};
    rtk_hit hit = {1.0f, u, v, prim, RTK_INVALID_ID};
    rtk_surface out;
    rtk_surface_at(s, &ray, &hit, &out);
    return out;
}

static int rgb_is(rtk_rgb c, double r, double g, double b)
{
    return near(c.r, r, 2e-3) && near(c.g, g, 2e-3) && near(c.b, b, 2e-3);
}

/* The unit triangle with TEXCOORD_0 = its (x, y) and TEXCOORD_1 = (x, y)
 * / 2 + (0.5, 0.5); accessors 0, 1 (triangle_data), 2 and 3. */
static void uv_triangle_data(gbuf *g)
{
    triangle_data(g);
    const float uv0[6] = {0, 0, 1, 0, 0, 1}, uv1[6] = {0.5f, 0.5f, 1, 0.5f, 0.5f, 1};
    gfloats(g, uv0, 3, "VEC2");
    gfloats(g, uv1, 3, "VEC2");
}

static void test_texture_transform(void)
{
    printf("KHR_texture_transform and TEXCOORD_1\n");
    write_quads_png("quads.png");
    gbuf *g = calloc(1, sizeof *g);
    uv_triangle_data(g);
    /* Mesh i uses material i; the triangle's centre (u = v = 0.5) reads
     * uv (0.5, 0.5) untransformed, on the corner of all four texels. */
    const char *body =
        "\"extensionsUsed\":[\"KHR_texture_transform\"],\"extensionsRequired\":[\"KHR_texture_transform\"],"
        "\"scenes\":[{\"nodes\":[0,1,2,3]}],"
        "\"nodes\":[{\"mesh\":0},{\"mesh\":1},{\"mesh\":2},{\"mesh\":3}],"
        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":2,\"TEXCOORD_1\":3},"
        "\"indices\":1,\"material\":0}]},"
        "{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":2,\"TEXCOORD_1\":3},\"indices\":1,"
        "\"material\":1}]},"
        "{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":2,\"TEXCOORD_1\":3},\"indices\":1,"
        "\"material\":2}]},"
        "{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":2},\"indices\":1,\"material\":2}]}],"
        "\"materials\":["
        /* 0: offset and scale: uv' = uv / 2 + (0.5, 0): green at the centre */
        "{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0,\"extensions\":{\"KHR_texture_transform\":"
        "{\"offset\":[0.5,0],\"scale\":[0.5,0.5]}}}},"
        /* emission: texCoord overridden to 1, rotated a quarter turn:
         * uv1 (0.75, 0.75) -> (0.75 / 2 - 0.125, 1.125 - 0.75 / 2): blue */
        "\"emissiveFactor\":[1,1,1],\"emissiveTexture\":{\"index\":0,\"extensions\":{\"KHR_texture_transform\":"
        "{\"offset\":[-0.125,1.125],\"rotation\":1.5707963267948966,\"scale\":[0.5,0.5],\"texCoord\":1}}},"
        "\"normalTexture\":{\"index\":0,\"extensions\":{\"KHR_texture_transform\":{\"scale\":[2,3]}}},"
        "\"alphaMode\":\"MASK\"},"
        /* 1: rotation alone, about the origin: uv (0.5, 0.5) -> (0.5, -0.5),
         * wrapped to (0.5, 0.5) by repeat; a quarter of the texture
         * shifted by the offset: (0.25, 0.25) is red */
        "{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0,\"extensions\":{\"KHR_texture_transform\":"
        "{\"rotation\":1.5707963267948966,\"offset\":[-0.25,0.75]}}}}},"
        /* 2: TEXCOORD_1 without a transform: (0.75, 0.75) is white; the
         * primitive without TEXCOORD_1 reads TEXCOORD_0 there */
        "{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0,\"texCoord\":1}}}],"
        "\"textures\":[{\"source\":0}],\"images\":[{\"uri\":\"quads.png\"}]";
    rtk_scene *s = load(write_gltf("transform.gltf", g, body), ALL_NEEDS);
    if (s && s->triangle_count == 4 && s->material_count == 3) {
        const rtk_material *m = &s->materials[0];
        check(m->base_uv.transformed && m->base_uv.set == 0 && m->base_uv.m[0] == 0.5f && m->base_uv.m[2] == 0.5f &&
                  m->base_uv.m[4] == 0.5f && m->base_uv.m[5] == 0.0f,
              "base colour: offset and scale as a matrix");
        check(m->alpha_uv.transformed && memcmp(&m->alpha_uv, &m->base_uv, sizeof m->base_uv) == 0,
              "a MASK cutout reads its alpha through the base colour's transform");
        check(m->emission_uv.set == 1 && m->emission_uv.transformed, "emission: texCoord 1 from the extension");
        check(m->normal_uv.transformed && m->normal_uv.m[0] == 2.0f && m->normal_uv.m[4] == 3.0f &&
                  m->normal_uv.m[1] == 0.0f && m->normal_uv.m[3] == 0.0f,
              "normal texture: its own scale");
        check(s->uvs1 != NULL, "TEXCOORD_1 kept for the textures that read it");
        rtk_surface c = surface_at(s, 0, 0.5f, 0.5f);
        check(rgb_is(c.base_color, 0, 1, 0), "offset + scale: the centre shows green (%g %g %g)", c.base_color.r,
              c.base_color.g, c.base_color.b);
        check(rgb_is(c.emission, 0, 0, 1), "rotation + texCoord 1 on the emissive slot: blue (%g %g %g)",
              c.emission.r, c.emission.g, c.emission.b);
        c = surface_at(s, 1, 0.5f, 0.5f);
        check(rgb_is(c.base_color, 1, 0, 0), "rotation counter-clockwise with offset: red (%g %g %g)", c.base_color.r,
              c.base_color.g, c.base_color.b);
        c = surface_at(s, 2, 0.5f, 0.5f);
        check(rgb_is(c.base_color, 1, 1, 1), "texCoord 1 reads TEXCOORD_1: white (%g %g %g)", c.base_color.r,
              c.base_color.g, c.base_color.b);
        c = surface_at(s, 3, 0.25f, 0.25f);
        check(rgb_is(c.base_color, 1, 0, 0), "texCoord 1 on a primitive without TEXCOORD_1 reads TEXCOORD_0: red");
    } else {
        check(0, "transform.gltf: 4 triangles and 3 materials");
    }
    rtk_scene_free(s);

    /* The same file without texture needs keeps no second set. */
    s = load(in_tmp("transform.gltf"), RTK_NEED_NORMALS);
    check(s && !s->uvs1 && !s->colors, "no uvs asked for, the cutout on TEXCOORD_0: no TEXCOORD_1 kept");
    rtk_scene_free(s);
    free(g);
}

static void test_vertex_colors(void)
{
    printf("COLOR_0\n");
    gbuf *g = calloc(1, sizeof *g);
    triangle_data(g);
    const uint8_t rgba[12] = {255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 0};
    const float rgb[9] = {1, 1, 1, 0.5f, 0.5f, 0.5f, 0, 0, 0};
    gaccessor(g, rgba, sizeof rgba, 5121, 3, "VEC4", ",\"normalized\":true"); /* 2 */
    gfloats(g, rgb, 3, "VEC3");                                             /* 3 */
    const char *body =
        "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"COLOR_0\":2},\"indices\":1,\"material\":0},"
        "{\"attributes\":{\"POSITION\":0,\"COLOR_0\":3},\"indices\":1,\"material\":1},"
        "{\"attributes\":{\"POSITION\":0},\"indices\":1,\"material\":1}]}],"
        "\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,1,1,1]},\"alphaMode\":\"MASK\"},"
        "{\"pbrMetallicRoughness\":{\"baseColorFactor\":[1,1,0.5,1]}}]";
    rtk_scene *s = load(write_gltf("colors.gltf", g, body), ALL_NEEDS);
    if (s && s->triangle_count == 3) {
        rtk_surface c = surface_at(s, 0, 0.0f, 0.0f);
        check(rgb_is(c.base_color, 0.5, 0, 0) && c.alpha == 1.0f, "RGBA bytes times the factor at corner 0 (%g %g %g)",
              c.base_color.r, c.base_color.g, c.base_color.b);
        c = surface_at(s, 0, 0.5f, 0.25f);
        check(rgb_is(c.base_color, 0.125, 0.5, 0.25) && near(c.alpha, 0.75, 1e-6),
              "interpolated inside: colour and alpha (%g %g %g, %g)", c.base_color.r, c.base_color.g, c.base_color.b,
              c.alpha);
        rtk_ray down = {{0.1f, 0.1f, 1.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, INFINITY};
        check(rtk_alpha_opaque(s, &down, 0, 0.1f, 0.1f) && !rtk_alpha_opaque(s, &down, 0, 0.1f, 0.8f),
              "a MASK cutout sees COLOR_0's alpha");
        c = surface_at(s, 1, 0.5f, 0.0f);
        check(rgb_is(c.base_color, 0.75, 0.75, 0.375), "RGB floats (%g %g %g)", c.base_color.r, c.base_color.g,
              c.base_color.b);
        c = surface_at(s, 2, 0.5f, 0.25f);
        check(rgb_is(c.base_color, 1, 1, 0.5), "a primitive without COLOR_0 in a scene with it: white (%g %g %g)",
              c.base_color.r, c.base_color.g, c.base_color.b);
    } else {
        check(0, "colors.gltf: 3 triangles");
    }
    rtk_scene_free(s);
    s = load(in_tmp("colors.gltf"), RTK_NEED_NORMALS);
    check(s && s->colors != NULL, "no materials asked for: colours kept for the cutout's alpha");
    rtk_scene_free(s);
    free(g);
}

static int exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

/* ---- morph targets at their default weights ---- */

/* Whether s has a vertex at (x, y, z). */
static int has_vertex(const rtk_scene *s, float x, float y, float z)
{
    for (uint32_t v = 0; s && v < s->vertex_count; v++) {
        const float *p = s->positions + 3 * (size_t)v;
        if (near(p[0], x, 1e-6) && near(p[1], y, 1e-6) && near(p[2], z, 1e-6))
            return 1;
    }
    return 0;
}

static void test_morph(void)
{
    printf("morph targets\n");
    gbuf *g = calloc(1, sizeof *g);
    triangle_data(g);
    const float up[9] = {0, 0, 0, 0, 0, 0, 0, 2, 0}, right[9] = {0, 0, 0, 4, 0, 0, 0, 0, 0};
    const float n[9] = {0, 0, 1, 0, 0, 1, 0, 0, 1}, tilt[9] = {1, 0, 0, 1, 0, 0, 1, 0, 0};
    gfloats(g, up, 3, "VEC3");    /* 2 */
    gfloats(g, right, 3, "VEC3"); /* 3 */
    gfloats(g, n, 3, "VEC3");     /* 4 */
    gfloats(g, tilt, 3, "VEC3");  /* 5 */
    /* Nodes 0 and 1 share the mesh at its default weights (0.5, 0.25):
     * vertex 2 at y = 2, vertex 1 at x = 2, normals (0.5, 0, 1); node 2
     * has its own weights (1, 0). */
    const char *body =
        "\"scenes\":[{\"nodes\":[0,1,2]}],\"nodes\":[{\"mesh\":0},{\"mesh\":0,\"translation\":[0,0,5]},"
        "{\"mesh\":0,\"weights\":[1,0],\"translation\":[0,0,-5]}],"
        "\"meshes\":[{\"weights\":[0.5,0.25],\"primitives\":[{\"attributes\":{\"POSITION\":0,\"NORMAL\":4},"
        "\"indices\":1,\"targets\":[{\"POSITION\":2,\"NORMAL\":5},{\"POSITION\":3}]}]}]";
    rtk_scene *s = load(write_gltf("morph.gltf", g, body), ALL_NEEDS);
    if (s && s->mesh_count == 1 && s->instance_count == 2) {
        const rtk_scene *m = s->meshes[0];
        check(has_vertex(m, 0, 2, 0) && has_vertex(m, 2, 0, 0) && has_vertex(m, 0, 0, 0),
              "the shared mesh at the default weights: (0, 2, 0), (2, 0, 0)");
        const float *nm = m->normals;
        check(nm && near(nm[0], 0.5 / sqrt(1.25), 1e-6) && near(nm[2], 1 / sqrt(1.25), 1e-6),
              "normals morphed too, then normalized (%g %g %g)", nm ? nm[0] : 0, nm ? nm[1] : 0, nm ? nm[2] : 0);
        check(s->triangle_count == 1 && has_vertex(s, 0, 3, -5) && has_vertex(s, 1, 0, -5),
              "a node's own weights (1, 0): its flattened copy has (0, 3), (1, 0)");
    } else {
        check(0, "morph.gltf: one mesh placed twice and one flattened copy (%u meshes, %u instances)",
              s ? s->mesh_count : 0, s ? s->instance_count : 0);
    }
    rtk_scene_free(s);
    free(g);
}

/* ---- EXT_mesh_gpu_instancing ---- */

static void test_gpu_instancing(void)
{
    printf("EXT_mesh_gpu_instancing\n");
    gbuf *g = calloc(1, sizeof *g);
    triangle_data(g);
    const float t[9] = {0, 0, 0, 10, 0, 0, 0, 10, 0}, sc[9] = {1, 1, 1, 2, 2, 2, 1, 1, 1};
    /* A quarter turn about z as normalized shorts (sin 45 = 23170 / 32767). */
    const int16_t q[12] = {0, 0, 0, 32767, 0, 0, 23170, 23170, 0, 0, 0, 32767};
    gfloats(g, t, 3, "VEC3");                                              /* 2 */
    gaccessor(g, q, sizeof q, 5122, 3, "VEC4", ",\"normalized\":true");   /* 3 */
    gfloats(g, sc, 3, "VEC3");                                             /* 4 */
    gfloats(g, t, 2, "VEC3");                                              /* 5: two elements */
    const char *body =
        "\"extensionsUsed\":[\"EXT_mesh_gpu_instancing\"],\"extensionsRequired\":[\"EXT_mesh_gpu_instancing\"],"
        "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"translation\":[0,0,-3],\"children\":[1]},"
        "{\"mesh\":0,\"extensions\":{\"EXT_mesh_gpu_instancing\":{\"attributes\":"
        "{\"TRANSLATION\":2,\"ROTATION\":3,\"SCALE\":4}}}}],"
        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1}]}]";
    rtk_scene *s = load_built(write_gltf("gpu.gltf", g, body), ALL_NEEDS);
    if (s && s->mesh_count == 1 && s->instance_count == 3) {
        const double *a = s->instances[0].to_world, *b = s->instances[1].to_world, *c = s->instances[2].to_world;
        check(s->triangle_count == 0 && s->meshes[0]->triangle_count == 1, "one mesh, no flattened copy");
        check(a[0] == 1 && a[3] == 0 && a[11] == -3, "instance 0: the parent's translation only");
        check(near(b[0], 0, 1e-4) && near(b[1], -2, 1e-4) && near(b[4], 2, 1e-4) && b[3] == 10 && b[11] == -3,
              "instance 1: rotated a quarter turn (normalized shorts), scaled 2, at x = 10");
        check(c[7] == 10 && c[11] == -3, "instance 2: at y = 10");
        /* Traced through the top level: a ray down z inside instance 2. */
        rtk_ctx ctx;
        memset(&ctx, 0, sizeof ctx);
        ctx.scene = s;
        rtk_ray r = {{0.25f, 10.25f, 5.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, INFINITY};
        rtk_hit h;
        check(rtk_trace(&ctx, &r, &h) && h.inst == 2 && near(h.t, 8.0, 1e-5), "a ray finds instance 2 at z = -3");
    } else {
        check(0, "gpu.gltf: one mesh and three instances (%u, %u)", s ? s->mesh_count : 0,
              s ? s->instance_count : 0);
    }
    rtk_scene_free(s);
    const char *bad = "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0,\"extensions\":"
                      "{\"EXT_mesh_gpu_instancing\":{\"attributes\":{\"TRANSLATION\":5,\"SCALE\":4}}}}],"
                      "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1}]}]";
    expect_refused("instancing attributes of different counts", write_gltf("gpu_bad.gltf", g, bad), RTK_ERR_PARSE,
                   "node 0", "EXT_mesh_gpu_instancing SCALE accessor 4", "3 elements, but the other attributes have 2",
                   NULL);
    free(g);
}

/* ---- skins in the rest pose ---- */

static void test_skin(void)
{
    printf("skins\n");
    gbuf *g = calloc(1, sizeof *g);
    triangle_data(g);
    /* Vertex 0 on joint 0, vertex 1 on joint 1, vertex 2 half on each. */
    const uint8_t joints[12] = {0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0};
    const float weights[12] = {1, 0, 0, 0, 1, 0, 0, 0, 0.5f, 0.5f, 0, 0};
    const float ibm[32] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1,
                           1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, -1, 0, 1};
    gaccessor(g, joints, sizeof joints, 5121, 3, "VEC4", NULL); /* 2 */
    gfloats(g, weights, 3, "VEC4");                              /* 3 */
    gfloats(g, ibm, 2, "MAT4");                                  /* 4 */
    const uint8_t bad_joints[12] = {0, 0, 0, 0, 7, 0, 0, 0, 0, 1, 0, 0};
    gaccessor(g, bad_joints, sizeof bad_joints, 5121, 3, "VEC4", NULL); /* 5 */
    /* The skinned node's own translation is ignored; joint 1 sits at
     * y = 5 under joint 0, its inverse bind matrix a move by y = -1. */
    const char *skin = "\"scenes\":[{\"nodes\":[0,1]}],"
                       "\"nodes\":[{\"mesh\":0,\"skin\":0,\"translation\":[100,0,0]},{\"children\":[2]},"
                       "{\"translation\":[0,5,0]}],\"skins\":[{\"joints\":[1,2],\"inverseBindMatrices\":4}],"
                       "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"JOINTS_0\":%d,"
                       "\"WEIGHTS_0\":3},\"indices\":1}]}]";
    char body[1024];
    snprintf(body, sizeof body, skin, 2);
    rtk_scene *s = load(write_gltf("skin.gltf", g, body), 0);
    check(s && s->triangle_count == 1 && has_vertex(s, 0, 0, 0) && has_vertex(s, 1, 4, 0) && has_vertex(s, 0, 3, 0),
          "vertices placed by their joints: (0, 0, 0), (1, 4, 0), and the blend (0, 3, 0)");
    rtk_scene_free(s);
    snprintf(body, sizeof body, skin, 5);
    expect_refused("a joint past the skin's", write_gltf("skin_bad.gltf", g, body), RTK_ERR_PARSE, "JOINTS_0",
                   "uses joint 7, but the skin has 2 joints", NULL);
    free(g);
}

/* ---- doubleSided false for camera rays; BLEND as stochastic coverage ---- */

/* A context tracing s; ray is the current sample's camera ray when camera. */
static rtk_ctx trace_ctx(const rtk_scene *s, const rtk_camera *cam, const rtk_ray *camera_ray)
{
    rtk_ctx ctx;
    memset(&ctx, 0, sizeof ctx);
    ctx.scene = s;
    ctx.camera = cam;
    if (camera_ray)
        ctx.camera_ray = *camera_ray;
    return ctx;
}

static void test_double_sided(void)
{
    printf("doubleSided\n");
    gbuf *g = calloc(1, sizeof *g);
    triangle_data(g);
    /* Node 0: single-sided at z = 0, facing +z; node 1: double-sided at
     * z = 1; node 2 and 3 share a single-sided mesh, node 3 mirrored in z,
     * both at x = 10 (the mirror keeps the authored side the front). */
    const char *body =
        "\"scenes\":[{\"nodes\":[0,1,2,3]}],\"nodes\":[{\"mesh\":0},{\"mesh\":1,\"translation\":[0,0,1]},"
        "{\"mesh\":2,\"translation\":[10,0,0]},{\"mesh\":2,\"translation\":[10,0,-2],\"scale\":[1,1,-1]}],"
        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,\"material\":0}]},"
        "{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,\"material\":1}]},"
        "{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,\"material\":0}]}],"
        "\"materials\":[{},{\"doubleSided\":true}]";
    /* No material needs: the ids are kept for the side test all the same. */
    rtk_scene *s = load_built(write_gltf("sides.gltf", g, body), 0);
    if (s && s->single_sided && s->tri_material && s->instance_count == 2) {
        rtk_camera cam;
        memset(&cam, 0, sizeof cam);
        rtk_hit h;
        int got;
        rtk_ray up = {{0.25f, 0.25f, -5.0f}, 0.0f, {0.0f, 0.0f, 1.0f}, INFINITY};
        rtk_ctx ctx = trace_ctx(s, &cam, &up);
        got = rtk_trace(&ctx, &up, &h);
        check(got && near(h.t, 6.0, 1e-5),
              "a camera ray passes through the back of the single-sided triangle to the double-sided one (t %g)", h.t);
        rtk_ray other = up;
        other.tmin = 1e-6f; /* not bit for bit the camera ray */
        got = rtk_trace(&ctx, &other, &h);
        check(got && near(h.t, 5.0, 1e-5), "a secondary ray stops at its back (t %g)", h.t);
        check(rtk_occluded(&ctx, &up), "shadow rays see both sides");
        rtk_ray down = {{0.25f, 0.25f, 5.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, INFINITY};
        ctx = trace_ctx(s, &cam, &down);
        down.tmin = 4.5f;
        ctx.camera_ray = down;
        got = rtk_trace(&ctx, &down, &h);
        check(got && near(h.t, 5.0, 1e-5), "a camera ray sees its front (t %g)", h.t);
        rtk_ray inst_up = {{10.25f, 0.25f, -5.0f}, 0.0f, {0.0f, 0.0f, 1.0f}, INFINITY};
        ctx = trace_ctx(s, &cam, &inst_up);
        got = rtk_trace(&ctx, &inst_up, &h);
        check(got && h.inst != RTK_INVALID_ID && near(h.t, 3.0, 1e-5),
              "instances: the mirrored copy at z = -2 faces -z, the camera ray from below sees it (t %g)", h.t);
        rtk_ray inst_down = {{10.25f, 0.25f, 5.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, INFINITY};
        ctx = trace_ctx(s, &cam, &inst_down);
        got = rtk_trace(&ctx, &inst_down, &h);
        check(got && near(h.t, 5.0, 1e-5),
              "instances: the unmirrored copy faces +z, seen from above (t %g)", h.t);
        rtk_ray mid = {{10.25f, 0.25f, -1.0f}, 0.0f, {0.0f, 0.0f, 1.0f}, INFINITY};
        ctx = trace_ctx(s, &cam, &mid);
        check(!rtk_trace(&ctx, &mid, &h), "instances: a camera ray between them meets only backs: a miss");
    } else {
        check(0, "sides.gltf: single-sided, material ids kept, two instances");
    }
    rtk_scene_free(s);
    free(g);
}

static void test_blend_coverage(void)
{
    printf("BLEND as coverage\n");
    gbuf *g = calloc(1, sizeof *g);
    triangle_data(g);
    const char *body =
        "\"scenes\":[{\"nodes\":[0,1]}],\"nodes\":[{\"mesh\":0},{\"mesh\":1}],"
        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,\"material\":0}]},"
        "{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,\"material\":1}]}],"
        "\"materials\":[{\"alphaMode\":\"BLEND\",\"doubleSided\":true,"
        "\"pbrMetallicRoughness\":{\"baseColorFactor\":[1,1,1,0.25]}},"
        "{\"alphaMode\":\"BLEND\",\"doubleSided\":true}]";
    rtk_scene *s = load_built(write_gltf("blend.gltf", g, body), 0);
    if (s && s->material_count == 2) {
        float cutoff;
        check(rtk_material_cutout(&s->materials[0], &cutoff) && cutoff < 0.0f && s->has_cutouts,
              "BLEND with alpha 0.25 is stochastic coverage");
        check(!rtk_material_cutout(&s->materials[1], &cutoff), "BLEND with alpha 1 and no texture stays opaque");
        /* Mesh 0 (alpha 0.25) and mesh 1 (alpha 1) are the same triangle:
         * the ray stops at prim 0 about a quarter of the time, else at 1. */
        rtk_ctx ctx = trace_ctx(s, NULL, NULL);
        rtk_pcg32 rng;
        rtk_pcg32_seed(&rng, 7, 1);
        int stops = 0, n = 20000, same = 1, agree = 1;
        for (int i = 0; i < n; i++) {
            rtk_ray r = {{0.05f + 0.4f * rtk_pcg32_float(&rng), 0.05f + 0.4f * rtk_pcg32_float(&rng), 1.0f},
                         0.0f,
                         {0.0f, 0.0f, -1.0f},
                         INFINITY};
            rtk_hit h, h2;
            int got = rtk_trace(&ctx, &r, &h);
            stops += got && h.prim == 0;
            same &= rtk_trace(&ctx, &r, &h2) == got && h2.prim == h.prim;
            /* The blend triangle alone: occlusion agrees with the hit. */
            rtk_ray shadow = r;
            shadow.tmax = 2.0f;
            agree &= rtk_alpha_opaque(s, &shadow, 0, 0.25f, 0.25f) == rtk_alpha_opaque(s, &r, 0, 0.25f, 0.25f);
        }
        double f = (double)stops / n;
        check(fabs(f - 0.25) < 0.02, "a quarter of the rays stop at the alpha 0.25 triangle (%.4f)", f);
        check(same && agree, "the same ray decides the same, whatever its tmax");
    } else {
        check(0, "blend.gltf: two materials");
    }
    rtk_scene_free(s);
    free(g);
}

/* ---- KHR_draco_mesh_compression ---- */

/* A quad (0, 0, 0) (2, 0, 0) (2, 1, 0) (0, 1, 0) with uvs (0, 1) (1, 1)
 * (1, 0) (0, 0), faces 0 1 2 and 0 2 3, POSITION Draco id 0 quantized to
 * 14 bits and TEXCOORD_0 id 1 to 12: libdraco 1.5.5's Encoder
 * (TriangleSoupMeshBuilder, speed 10) wrote these bytes. */
static const unsigned char draco_quad[120] = {
    0x44, 0x52, 0x41, 0x43, 0x4f, 0x02, 0x02, 0x01, 0x00, 0x00, 0x00, 0x02, 0x04, 0x01, 0x00, 0x01, 0x02, 0x00, 0x02,
    0x03, 0x01, 0x02, 0x00, 0x09, 0x03, 0x00, 0x00, 0x03, 0x09, 0x02, 0x00, 0x01, 0x02, 0x02, 0x00, 0x01, 0x01, 0x00,
    0x0f, 0x03, 0x01, 0x20, 0x01, 0x10, 0x2b, 0x01, 0x10, 0x03, 0x00, 0x64, 0x90, 0x08, 0x00, 0xf0, 0xff, 0x03, 0x00,
    0x02, 0x00, 0x00, 0x00, 0x00, 0xff, 0x3f, 0x00, 0x00, 0x00, 0x01, 0x01, 0x00, 0x03, 0x03, 0x01, 0x20, 0x01, 0x20,
    0x03, 0x00, 0x20, 0x84, 0x86, 0x02, 0x00, 0x00, 0x00, 0x00, 0xff, 0x0f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x40, 0x0e, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x80, 0x3f, 0x0c};

static void test_draco(void)
{
    printf("KHR_draco_mesh_compression\n");
    gbuf *g = calloc(1, sizeof *g);
    int view = gview(g, draco_quad, sizeof draco_quad);
    (void)view;
    gaccessor_json(g, "\"componentType\":5126,\"count\":4,\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[2,1,0]");
    gaccessor_json(g, "\"componentType\":5126,\"count\":4,\"type\":\"VEC2\"");
    gaccessor_json(g, "\"componentType\":5123,\"count\":6,\"type\":\"SCALAR\"");
    const char *body =
        "\"extensionsUsed\":[\"KHR_draco_mesh_compression\"],\"extensionsRequired\":[\"KHR_draco_mesh_compression\"],"
        "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":1},\"indices\":2,"
        "\"extensions\":{\"KHR_draco_mesh_compression\":{\"bufferView\":0,"
        "\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":1}}}}]}]";
    const char *path = write_gltf("draco.gltf", g, body);
#ifdef RTK_HAVE_DRACO
    rtk_scene *s = load(path, ALL_NEEDS);
    if (s && s->triangle_count == 2) {
        int corners = 0;
        const float want[4][5] = {{0, 0, 0, 0, 1}, {2, 0, 0, 1, 1}, {2, 1, 0, 1, 0}, {0, 1, 0, 0, 0}};
        for (uint32_t t = 0; t < 2; t++)
            for (int c = 0; c < 3; c++) {
                const float *p = corner_pos(s, t, c), *uv = s->uvs + 6 * t + 2 * c;
                for (int k = 0; k < 4; k++)
                    corners += near(p[0], want[k][0], 1e-3) && near(p[1], want[k][1], 1e-3) && near(p[2], 0, 1e-6) &&
                               near(uv[0], want[k][3], 1e-3) && near(uv[1], want[k][4], 1e-3);
            }
        check(corners == 6, "two triangles, each corner a corner of the quad with its uv (%d of 6)", corners);
    } else {
        check(0, "draco.gltf: two triangles");
    }
    rtk_scene_free(s);
    /* Bytes that are not Draco data: rtk's message, naming the primitive. */
    const unsigned char junk[8] = {1, 2, 3, 4, 5, 6, 7, 8};
    memcpy(g->data, junk, sizeof junk);
    expect_refused("junk for Draco data", write_gltf("draco_junk.gltf", g, body), RTK_ERR_PARSE,
                   "mesh 0 primitive 0: KHR_draco_mesh_compression: Draco could not decode it", NULL);
#else
    expect_refused("Draco without libdraco", path, RTK_ERR_UNSUPPORTED, "KHR_draco_mesh_compression",
                   "built without Draco", NULL);
#endif
    free(g);
}

/* ---- EXT_meshopt_compression ---- */

static void test_meshopt(void)
{
    printf("EXT_meshopt_compression\n");
    /* A quad: positions (ATTRIBUTES, stride 12), indices (TRIANGLES,
     * stride 2), normals as octahedral bytes (ATTRIBUTES, OCTAHEDRAL
     * filter, stride 4); compressed into buffer 0, the views naming the
     * fallback buffer 1, which has no data (as gltfpack writes it). */
    const float pos[12] = {0, 0, 0, 2, 0, 0, 2, 1, 0, 0, 1, 0};
    const unsigned idx[6] = {0, 1, 2, 0, 2, 3};
    const float normals[16] = {0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0};
    unsigned char packed[512];
    size_t sizes[3] = {0, 0, 0};
#ifdef RTK_HAVE_MESHOPT
    int8_t oct[16];
    meshopt_encodeFilterOct(oct, 4, 4, 8, normals);
    sizes[0] = meshopt_encodeVertexBuffer(packed, 160, pos, 4, 12);
    sizes[1] = meshopt_encodeIndexBuffer(packed + 160, 160, idx, 6);
    sizes[2] = meshopt_encodeVertexBuffer(packed + 320, 160, oct, 4, 4);
#else
    (void)pos, (void)idx, (void)normals;
    memset(packed, 0, sizeof packed);
    sizes[0] = sizes[1] = sizes[2] = 8;
#endif
    char json[4096];
    const char *uri_or_glb[2] = {"\"uri\":\"meshopt.bin\",", ""};
    for (int glb = 0; glb < 2; glb++) {
        snprintf(json, sizeof json,
                 "{\"asset\":{\"version\":\"2.0\"},"
                 "\"extensionsUsed\":[\"EXT_meshopt_compression\",\"KHR_mesh_quantization\"],"
                 "\"extensionsRequired\":[\"EXT_meshopt_compression\",\"KHR_mesh_quantization\"],"
                 "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
                 "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"NORMAL\":2},\"indices\":1}]}],"
                 "\"buffers\":[{%s\"byteLength\":480},"
                 "{\"byteLength\":76,\"extensions\":{\"EXT_meshopt_compression\":{\"fallback\":true}}}],"
                 "\"bufferViews\":["
                 "{\"buffer\":1,\"byteLength\":48,\"byteStride\":12,\"extensions\":{\"EXT_meshopt_compression\":"
                 "{\"buffer\":0,\"byteLength\":%zu,\"byteStride\":12,\"count\":4,\"mode\":\"ATTRIBUTES\"}}},"
                 "{\"buffer\":1,\"byteOffset\":48,\"byteLength\":12,\"extensions\":{\"EXT_meshopt_compression\":"
                 "{\"buffer\":0,\"byteOffset\":160,\"byteLength\":%zu,\"byteStride\":2,\"count\":6,"
                 "\"mode\":\"TRIANGLES\"}}},"
                 "{\"buffer\":1,\"byteOffset\":60,\"byteLength\":16,\"byteStride\":4,\"extensions\":"
                 "{\"EXT_meshopt_compression\":{\"buffer\":0,\"byteOffset\":320,\"byteLength\":%zu,"
                 "\"byteStride\":4,\"count\":4,\"mode\":\"ATTRIBUTES\",\"filter\":\"OCTAHEDRAL\"}}}],"
                 "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":4,\"type\":\"VEC3\","
                 "\"min\":[0,0,0],\"max\":[2,1,0]},"
                 "{\"bufferView\":1,\"componentType\":5123,\"count\":6,\"type\":\"SCALAR\"},"
                 "{\"bufferView\":2,\"componentType\":5120,\"normalized\":true,\"count\":4,\"type\":\"VEC3\"}]}",
                 uri_or_glb[glb], sizes[0], sizes[1], sizes[2]);
        const char *path;
        if (glb) {
            path = write_glb_bin("meshopt.glb", 2, json, packed, 480);
        } else {
            write_file("meshopt.bin", packed, 480);
            path = write_file("meshopt.gltf", json, strlen(json));
        }
        const char *what = glb ? "meshopt .glb" : "meshopt .gltf";
#ifdef RTK_HAVE_MESHOPT
        rtk_scene *s = load(path, ALL_NEEDS);
        if (s && s->triangle_count == 2) {
            int ok = 1;
            for (uint32_t t = 0; t < 2; t++)
                for (int c = 0; c < 3; c++) {
                    const float *p = corner_pos(s, t, c), *want = pos + 3 * idx[3 * t + (unsigned)c];
                    ok &= p[0] == want[0] && p[1] == want[1] && p[2] == want[2];
                    ok &= near(s->normals[9 * t + 3 * (unsigned)c + 2], 1.0, 1e-6);
                }
            check(ok, "%s: the quad's corners bit for bit, its octahedral normals +z", what);
        } else {
            check(0, "%s: two triangles", what);
        }
        rtk_scene_free(s);
#else
        expect_refused(what, path, RTK_ERR_UNSUPPORTED, "EXT_meshopt_compression", "built without meshoptimizer",
                       NULL);
#endif
    }
#ifdef RTK_HAVE_MESHOPT
    /* Data that does not decode: rtk's message, naming the view. */
    memset(packed, 0xff, sizeof packed);
    write_file("meshopt.bin", packed, 480);
    expect_refused("meshopt data that does not decode", in_tmp("meshopt.gltf"), RTK_ERR_PARSE,
                   "buffer view 0: EXT_meshopt_compression: the data does not decode", NULL);
#endif
}

/* ---- the Khronos sample models, when ../shared/data is present ---- */

static const char *sample(const char *rel)
{
    static char path[4][1024];
    static int next;
    char *p = path[next++ & 3];
    snprintf(p, 1024, "%s/../shared/data/gltf-samples/%s", RTK_SOURCE_ROOT, rel);
    return p;
}

/* Any material of s whose slot map (by offset in rtk_material) is transformed or reads set. */
static int any_map(const rtk_scene *s, int transformed, int set)
{
    for (uint32_t i = 0; i < s->material_count; i++) {
        const rtk_material *m = &s->materials[i];
        const rtk_tex_map *maps[4] = {&m->base_uv, &m->alpha_uv, &m->normal_uv, &m->emission_uv};
        for (int k = 0; k < 4; k++)
            if ((transformed && maps[k]->transformed) || (set && maps[k]->set == set))
                return 1;
    }
    return 0;
}

static void test_samples(void)
{
    if (!exists(sample(""))) {
        printf("sample models: skipped, %s is absent\n", sample(""));
        return;
    }
    printf("sample models\n");
    rtk_scene *s = load(sample("TextureTransformTest/glTF/TextureTransformTest.gltf"), ALL_NEEDS);
    check(s && any_map(s, 1, 0), "TextureTransformTest: transformed texture maps");
    rtk_scene_free(s);
    s = load(sample("MultiUVTest/glTF/MultiUVTest.gltf"), ALL_NEEDS);
    check(s && s->uvs1 && any_map(s, 0, 1), "MultiUVTest: the emissive texture reads TEXCOORD_1");
    rtk_scene_free(s);
    s = load(sample("BoxVertexColors/glTF/BoxVertexColors.gltf"), ALL_NEEDS);
    check(s && s->colors, "BoxVertexColors: vertex colours");
    rtk_scene_free(s);
    s = load(sample("VertexColorTest/glTF/VertexColorTest.gltf"), ALL_NEEDS);
    check(s && s->colors, "VertexColorTest: vertex colours");
    rtk_scene_free(s);
    /* 14 vertices in the base view, 10 of them raised by the sparse values. */
    s = load(sample("SimpleSparseAccessor/glTF/SimpleSparseAccessor.gltf"), 0);
    float top = 0.0f;
    for (uint32_t v = 0; s && v < s->vertex_count; v++)
        top = fmaxf(top, s->positions[3 * v + 1]);
    check(s && s->triangle_count == 12 && top == 4.0f, "SimpleSparseAccessor: 12 triangles, the peak at y = 4 (%g)",
          top);
    rtk_scene_free(s);
    s = load(sample("AnimatedMorphCube/glTF-Quantized/AnimatedMorphCube.gltf"), ALL_NEEDS);
    check(s && s->triangle_count == 12, "AnimatedMorphCube quantized: a cube of 12 triangles");
    rtk_scene_free(s);
    /* At the default weights (0.5, 0.5) the apex is at (0.5, 1.5); the
     * screenshot shows a frame of the animation. */
    s = load(sample("SimpleMorph/glTF/SimpleMorph.gltf"), 0);
    check(s && has_vertex(s, 0.5f, 1.5f, 0.0f), "SimpleMorph: the apex at (0.5, 1.5, 0)");
    rtk_scene_free(s);
    s = load(sample("SimpleInstancing/glTF/SimpleInstancing.gltf"), 0);
    check(s && s->mesh_count == 1 && s->instance_count == 125, "SimpleInstancing: one mesh placed 125 times (%u, %u)",
          s ? s->mesh_count : 0, s ? s->instance_count : 0);
    rtk_scene_free(s);
    /* 84 skinned parts in 4 trees, each a trunk of 100 from y = 0 with
     * branches above it (the rest pose; the screenshot is animated). */
    s = load(sample("RecursiveSkeletons/glTF/RecursiveSkeletons.gltf"), 0);
    check(s && s->bounds.upper.y > 120.0f && s->bounds.lower.y > -1.0f && s->bounds.upper.x - s->bounds.lower.x > 50.0f,
          "RecursiveSkeletons: four trees 120 high over 50 across (bounds y %g..%g, x %g..%g)",
          s ? s->bounds.lower.y : 0, s ? s->bounds.upper.y : 0, s ? s->bounds.lower.x : 0, s ? s->bounds.upper.x : 0);
    rtk_scene_free(s);
#ifdef RTK_HAVE_DRACO
    s = load(sample("Box/glTF-Draco/Box.gltf"), 0);
    rtk_scene *plain = load(sample("Box/glTF/Box.gltf"), 0);
    check(s && plain && s->triangle_count == 12 && plain->triangle_count == 12 &&
              near(s->bounds.upper.x, plain->bounds.upper.x, 1e-3) && near(s->bounds.lower.y, plain->bounds.lower.y, 1e-3),
          "Box Draco: the 12 triangles and bounds of the uncompressed Box");
    rtk_scene_free(plain);
    rtk_scene_free(s);
    s = load(sample("CesiumMilkTruck/glTF-Draco/CesiumMilkTruck.gltf"), ALL_NEEDS);
    check(s && s->triangle_count + s->mesh_count > 0 && s->texture_count == 1, "CesiumMilkTruck Draco loads with its texture");
    rtk_scene_free(s);
#else
    expect_refused("Box Draco", sample("Box/glTF-Draco/Box.gltf"), RTK_ERR_UNSUPPORTED, "KHR_draco_mesh_compression",
                   NULL);
#endif
}

int main(void)
{
    setvbuf(stdout, NULL, _IOLBF, 0);
    scratch_begin("rtk-gltf");
    rtk_registry *reg = NULL;
    if (rtk_registry_create(&reg) != RTK_OK ||
        rtk_registry_find(reg, RTK_KIND_ACCELERATOR, "sah", &builder) != RTK_OK) {
        printf("FAIL  sah plugin: %s\n", rtk_error_message());
        return 1;
    }
    builder_params = rtk_params_defaults(builder);
    rtk_log_set_level(RTK_LOG_ERROR);
    test_refusals();
    test_glb_container();
    test_quantization();
    test_sparse();
    test_texture_transform();
    test_vertex_colors();
    test_morph();
    test_gpu_instancing();
    test_skin();
    test_double_sided();
    test_blend_coverage();
    test_draco();
    test_meshopt();
    test_samples();
    rtk_params_destroy(builder_params);
    rtk_registry_destroy(reg);
    if (!getenv("KEEP"))
        scratch_end();
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}

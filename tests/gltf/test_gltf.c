/* glTF features and refusals (kernel/io/gltf.cpp): each on a small file
 * written here, its buffer made by the gbuf helpers below, then the
 * Khronos sample models of ../shared/data/gltf-samples when present.
 * - refusals before tinygltf parses: JSON nested past the limit (.gltf
 *   and .glb), glTF 1.0 binaries, unsupported required extensions (Draco,
 *   EXT_meshopt_compression) named by rtk's own message. */
#include "internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "../check.h"

#ifndef RTK_SOURCE_ROOT
#define RTK_SOURCE_ROOT "."
#endif

#define ALL_NEEDS (RTK_NEED_NORMALS | RTK_NEED_UVS | RTK_NEED_MATERIALS | RTK_NEED_TEXTURES | RTK_NEED_LIGHTS)

static char tmpdir[256];
static const rtk_plugin *builder;
static rtk_params *builder_params;

static const char *in_tmp(const char *name)
{
    static char path[8][512];
    static int next;
    char *p = path[next++ & 7];
    snprintf(p, 512, "%s/%s", tmpdir, name);
    return p;
}

static const char *write_bytes(const char *name, const void *data, size_t size)
{
    const char *path = in_tmp(name);
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(data, 1, size, f) != size) {
        printf("FAIL  cannot write %s\n", path);
        exit(1);
    }
    fclose(f);
    return path;
}

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
    int k = strcmp(type, "SCALAR") == 0 ? 1 : type[3] - '0';
    return gaccessor(g, v, sizeof(float) * (size_t)(count * k), 5126, count, type, NULL);
}

/* Writes name (.gltf) with the buffer beside it (name.bin) and body, the
 * members other than asset and the buffer's; returns its path. */
static const char *write_gltf(const char *name, const gbuf *g, const char *body)
{
    char bin[256];
    snprintf(bin, sizeof bin, "%s.bin", name);
    write_bytes(bin, g->data, g->size ? g->size : 4);
    size_t cap = strlen(body) + strlen(g->views) + strlen(g->accessors) + 1024;
    char *json = malloc(cap);
    snprintf(json, cap,
             "{\"asset\":{\"version\":\"2.0\"},%s,\"buffers\":[{\"uri\":\"%s\",\"byteLength\":%zu}],"
             "\"bufferViews\":[%s],\"accessors\":[%s]}",
             body, bin, g->size ? g->size : 4, g->views, g->accessors);
    const char *path = write_bytes(name, json, strlen(json));
    free(json);
    return path;
}

static void put_u32(unsigned char *p, uint32_t v)
{
    for (int k = 0; k < 4; k++)
        p[k] = (unsigned char)(v >> (8 * k));
}

/* Writes a .glb: header of version, one JSON chunk. */
static const char *write_glb(const char *name, uint32_t version, const char *json)
{
    size_t n = (strlen(json) + 3) & ~(size_t)3, total = 20 + n;
    unsigned char *out = calloc(1, total);
    memcpy(out, "glTF", 4);
    put_u32(out + 4, version);
    put_u32(out + 8, (uint32_t)total);
    put_u32(out + 12, (uint32_t)n);
    memcpy(out + 16, "JSON", 4);
    memset(out + 20, ' ', n);
    memcpy(out + 20, json, strlen(json));
    const char *path = write_bytes(name, out, total);
    free(out);
    return path;
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
    if (s && rtk_bvh_build(s, builder, builder_params, 1) != RTK_OK) {
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
    expect_refused("15,000 nested arrays (.gltf)", write_bytes("deep.gltf", json, strlen(json)), RTK_ERR_PARSE,
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

    expect_refused("glTF 1.0 binary", write_glb("v1.glb", 1, "{\"asset\":{\"version\":\"1.0\"}}"),
                   RTK_ERR_UNSUPPORTED, "glTF 1.0", NULL);
    expect_refused("glTF 1.0 text",
                   write_bytes("v1.gltf", "{\"asset\":{\"version\":\"1.0\"},\"meshes\":{}}", 39),
                   RTK_ERR_UNSUPPORTED, "glTF 1.0", NULL);

    /* Draco: an accessor without a buffer view, the data in the extension;
     * tinygltf alone fails with "accessor[0] invalid bufferView". */
    const char *draco = "{\"asset\":{\"version\":\"2.0\"},"
                        "\"extensionsUsed\":[\"KHR_draco_mesh_compression\"],"
                        "\"extensionsRequired\":[\"KHR_draco_mesh_compression\"],"
                        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"extensions\":"
                        "{\"KHR_draco_mesh_compression\":{\"bufferView\":0,\"attributes\":{\"POSITION\":0}}}}]}],"
                        "\"accessors\":[{\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"}],"
                        "\"bufferViews\":[{\"buffer\":0,\"byteLength\":4}],"
                        "\"buffers\":[{\"byteLength\":4,\"uri\":\"data:application/octet-stream;base64,AAAAAA==\"}]}";
    expect_refused("Draco", write_bytes("draco.gltf", draco, strlen(draco)), RTK_ERR_UNSUPPORTED,
                   "KHR_draco_mesh_compression", "requires", NULL);
    expect_refused("Draco (.glb)", write_glb("draco.glb", 2, draco), RTK_ERR_UNSUPPORTED,
                   "KHR_draco_mesh_compression", NULL);
    const char *meshopt = "{\"asset\":{\"version\":\"2.0\"},"
                          "\"extensionsRequired\":[\"EXT_meshopt_compression\"],"
                          "\"bufferViews\":[{\"buffer\":0,\"byteLength\":4,\"extensions\":{\"EXT_meshopt_compression\":"
                          "{\"buffer\":0,\"byteLength\":4,\"byteStride\":4,\"count\":1,\"mode\":\"ATTRIBUTES\"}}}],"
                          "\"accessors\":[{\"bufferView\":7,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"}],"
                          "\"buffers\":[{\"byteLength\":4}]}";
    expect_refused("EXT_meshopt_compression", write_bytes("meshopt.gltf", meshopt, strlen(meshopt)),
                   RTK_ERR_UNSUPPORTED, "EXT_meshopt_compression", NULL);
    free(g);
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
    free(g);
}

static int exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

int main(void)
{
    setvbuf(stdout, NULL, _IOLBF, 0);
    snprintf(tmpdir, sizeof tmpdir, "/tmp/rtk-gltf-XXXXXX");
    if (!mkdtemp(tmpdir)) {
        printf("FAIL  cannot make a temporary directory\n");
        return 1;
    }
    rtk_registry *reg = NULL;
    if (rtk_registry_create(&reg) != RTK_OK ||
        rtk_registry_find(reg, RTK_KIND_ACCELERATOR, "sah", &builder) != RTK_OK) {
        printf("FAIL  sah plugin: %s\n", rtk_error_message());
        return 1;
    }
    builder_params = rtk_params_defaults(builder);
    rtk_log_set_level(RTK_LOG_ERROR);
    test_refusals();
    test_quantization();
    test_sparse();
    (void)load_built;
    (void)exists;
    rtk_params_destroy(builder_params);
    rtk_registry_destroy(reg);
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmpdir);
    if (!getenv("KEEP") && system(cmd) != 0)
        printf("note  could not remove %s\n", tmpdir);
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}

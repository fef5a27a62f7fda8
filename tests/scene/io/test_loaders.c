/* Scene loaders (kernel/scene/scene_build.c, kernel/scene/io/obj.cpp, kernel/scene/io/gltf.cpp):
 * small OBJ and glTF files written here into a temporary folder, then the
 * meshes of ../shared/data when that folder is present. */
#include "config/config.h"
#include "render/render.h"
#include "image/image.h"

#include <ftw.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "scratch.h"

#ifndef RTK_SOURCE_ROOT
#define RTK_SOURCE_ROOT "."
#endif

#define ALL_NEEDS (RTK_NEED_NORMALS | RTK_NEED_UVS | RTK_NEED_MATERIALS | RTK_NEED_TEXTURES | RTK_NEED_LIGHTS)

static int passed, failed;

static void check(int ok, const char *what, int line)
{
    if (ok) {
        passed++;
    } else {
        failed++;
        printf("FAILED line %d: %s\n", line, what);
    }
}

#define CHECK(cond) check((cond) != 0, #cond, __LINE__)
#define CHECK_NEAR(a, b, tol) check(fabs((double)(a) - (double)(b)) <= (tol), #a " ~ " #b, __LINE__)

static int message_has(const char *text) { return strstr(rtk_error_message(), text) != NULL; }

/* Loads path; on failure prints the message and returns NULL. */
static rtk_scene *load(const char *path, uint32_t needs)
{
    rtk_scene *scene = NULL;
    rtk_status status = rtk_scene_load(path, needs, &scene);
    if (status != RTK_OK) {
        printf("  load %s: status %d: %s\n", path, (int)status, rtk_error_message());
        return NULL;
    }
    return scene;
}

/* Expects loading path to fail with code and a message naming the file
 * and containing text. */
static void expect_refused(const char *path, rtk_status code, const char *text, int line)
{
    rtk_scene *scene = NULL;
    rtk_status status = rtk_scene_load(path, ALL_NEEDS, &scene);
    check(status == code, "status of a refused load", line);
    check(scene == NULL, "no scene after a refused load", line);
    check(message_has(path), "the message names the file", line);
    check(message_has(text), text, line);
    printf("  refused as expected: %s\n", rtk_error_message());
    rtk_scene_free(scene);
}

static const float *vertex_of(const rtk_scene *s, uint32_t triangle, int corner)
{
    return s->positions + (size_t)s->indices[triangle * 3 + corner] * 3;
}

static double triangle_area(const rtk_scene *s, uint32_t t)
{
    const float *a = vertex_of(s, t, 0), *b = vertex_of(s, t, 1), *c = vertex_of(s, t, 2);
    double e1[3], e2[3];
    for (int k = 0; k < 3; k++) {
        e1[k] = (double)b[k] - a[k];
        e2[k] = (double)c[k] - a[k];
    }
    double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    return 0.5 * sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
}

static double total_area(const rtk_scene *s)
{
    double sum = 0.0;
    for (uint32_t t = 0; t < s->triangle_count; t++)
        sum += triangle_area(s, t);
    return sum;
}

static int has_vertex(const rtk_scene *s, uint32_t t, float x, float y, float z)
{
    for (int k = 0; k < 3; k++) {
        const float *p = vertex_of(s, t, k);
        if (fabsf(p[0] - x) < 1e-5f && fabsf(p[1] - y) < 1e-5f && fabsf(p[2] - z) < 1e-5f)
            return 1;
    }
    return 0;
}

static void test_obj_quad(void)
{
    printf("obj: quad with materials and a missing texture\n");
    write_text("quad.mtl", "newmtl painted\n"
                           "Kd 0.5 0.25 0.125\nKs 0.1 0.2 0.3\nNs 32\nNi 1.33\nKe 0 0 0\nillum 2\n"
                           "map_Kd textures/missing.png\n"
                           "newmtl glassy\n"
                           "Kd 1 1 1\nTr 0.25\nKe 2 3 4\nmap_d textures/cutout.png\n");
    const char *obj = write_text("quad.obj", "mtllib quad.mtl\n"
                                             "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                                             "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                                             "vn 0 0 2\n"
                                             "usemtl painted\n"
                                             "f 1/1/1 2/2/1 3/3/1 4/4/1\n"
                                             "usemtl glassy\n"
                                             "f 1 3 4\n");
    rtk_scene *s = load(obj, ALL_NEEDS);
    CHECK(s != NULL);
    if (!s)
        return;
    CHECK(s->triangle_count == 3);
    CHECK(s->vertex_count == 4);
    CHECK(s->material_count == 2);
    CHECK(s->texture_count == 2);
    CHECK(s->normals && s->uvs && s->tri_material);
    const rtk_material *m = &s->materials[0];
    CHECK(m->name && strcmp(m->name, "painted") == 0);
    CHECK_NEAR(m->base_color.r, 0.5, 1e-6);
    CHECK_NEAR(m->base_color.g, 0.25, 1e-6);
    CHECK_NEAR(m->base_color.b, 0.125, 1e-6);
    CHECK_NEAR(m->specular.b, 0.3, 1e-6);
    CHECK_NEAR(m->shininess, 32, 1e-6);
    CHECK_NEAR(m->ior, 1.33, 1e-6);
    CHECK(m->illum == 2);
    CHECK(m->base_tex >= 0 && m->alpha_tex == -1 && m->normal_tex == -1);
    const rtk_material *g = &s->materials[1];
    CHECK_NEAR(g->alpha, 0.75, 1e-6); /* Tr 0.25 without d */
    CHECK_NEAR(g->ior, 1.5, 1e-6);    /* no Ni: rtk's default, not tinyobjloader's 1.0 */
    CHECK_NEAR(g->emission.b, 4, 1e-6);
    CHECK(g->alpha_tex >= 0 && g->alpha_mode == RTK_ALPHA_BLEND);
    if (m->base_tex >= 0) {
        const rtk_texture *t = &s->textures[m->base_tex];
        CHECK(t->path && strstr(t->path, tmpdir) && strstr(t->path, "textures/missing.png"));
        CHECK(t->srgb == 1);
        CHECK(t->decoded == 1 && t->missing == 1);
    }
    if (g->alpha_tex >= 0)
        CHECK(s->textures[g->alpha_tex].srgb == 0);
    CHECK(s->tri_material[0] == 0 && s->tri_material[1] == 0 && s->tri_material[2] == 1);
    CHECK_NEAR(s->normals[2], 1.0, 1e-6); /* unit length after loading */
    CHECK_NEAR(s->normals[9 * 2 + 2], 1.0, 1e-6); /* no vn: geometric normal of a CCW face is +z */
    CHECK_NEAR(total_area(s), 1.5, 1e-6);
    CHECK(s->bounds.lower.x == 0 && s->bounds.upper.x == 1 && s->bounds.upper.y == 1 && s->bounds.upper.z == 0);
    rtk_scene_free(s);

    /* Without needs, nothing optional is kept or decoded but what the
     * cutout material (map_d) needs for traversal: materials, uvs and its
     * alpha texture. */
    s = load(obj, 0);
    CHECK(s != NULL);
    if (!s)
        return;
    CHECK(s->triangle_count == 3);
    CHECK(!s->normals && s->uvs && s->tri_material && s->has_cutouts);
    for (uint32_t i = 0; i < s->texture_count; i++)
        CHECK(s->textures[i].decoded == ((int)i == s->materials[1].alpha_tex));
    rtk_scene_free(s);

    /* A UTF-8 byte order mark is skipped, not taken for part of a statement. */
    s = load(write_text("bom.obj", "\xEF\xBB\xBFv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"), 0);
    CHECK(s && s->triangle_count == 1 && s->vertex_count == 3);
    rtk_scene_free(s);

    /* Extensions are matched without regard to case. */
    write_text("QUAD2.OBJ", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    s = load(in_tmp("QUAD2.OBJ"), 0);
    CHECK(s && s->triangle_count == 1);
    rtk_scene_free(s);
}

static void test_obj_errors(void)
{
    printf("obj: broken files\n");
    expect_refused(write_text("range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"), RTK_ERR_PARSE, "vertex 9",
                   __LINE__);
    expect_refused(write_text("range_vt.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n"), RTK_ERR_PARSE,
                   "texture coordinate 2", __LINE__);
    expect_refused(write_text("relative.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n"), RTK_ERR_PARSE,
                   "vertex -4", __LINE__);
    /* 1e39 does not fit a float: the loader sees an infinite coordinate. */
    expect_refused(write_text("inf.obj", "v 0 0 0\nv 1e39 0 0\nv 0 1 0\nf 1 2 3\n"), RTK_ERR_INVALID, "vertex 2",
                   __LINE__);
    expect_refused(in_tmp("absent.obj"), RTK_ERR_IO, "absent.obj", __LINE__);
    expect_refused(write_text("scene.fbx", "nothing"), RTK_ERR_UNSUPPORTED, ".obj", __LINE__);
    expect_refused(write_text("utf16.obj", "\xFF\xFE" "v"), RTK_ERR_UNSUPPORTED, "UTF-16", __LINE__);
}

static void test_obj_degenerate(void)
{
    printf("obj: degenerate triangles are dropped\n");
    const char *obj = write_text("degenerate.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\n"
                                                   "f 1 2 3\n" /* collinear */
                                                   "f 1 2 4\n");
    rtk_scene *s = load(obj, ALL_NEEDS);
    CHECK(s != NULL);
    if (!s)
        return;
    CHECK(s->triangle_count == 1);
    CHECK(s->dropped_degenerate == 1);
    CHECK(has_vertex(s, 0, 0, 1, 0));
    rtk_scene_free(s);

    obj = write_text("collapsed.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 1 2\nf 1 2 3\n");
    s = load(obj, 0);
    CHECK(s && s->triangle_count == 1 && s->dropped_degenerate == 1);
    rtk_scene_free(s);
}

/* Appends "v x y 0" lines for a polygon and one face using all of them. */
static void polygon_obj(const char *name, const double (*xy)[2], int n)
{
    size_t cap = (size_t)n * 64 + 64, len = 0;
    char *text = malloc(cap);
    for (int i = 0; i < n; i++)
        len += (size_t)snprintf(text + len, cap - len, "v %.9g %.9g 0\n", xy[i][0], xy[i][1]);
    len += (size_t)snprintf(text + len, cap - len, "f");
    for (int i = 0; i < n; i++)
        len += (size_t)snprintf(text + len, cap - len, " %d", i + 1);
    snprintf(text + len, cap - len, "\n");
    write_text(name, text);
    free(text);
}

static double shoelace(const double (*xy)[2], int n)
{
    double a = 0.0;
    for (int i = 0; i < n; i++)
        a += xy[i][0] * xy[(i + 1) % n][1] - xy[(i + 1) % n][0] * xy[i][1];
    return fabs(a) * 0.5;
}

static void test_obj_polygons(void)
{
    printf("obj: concave polygons and faces of more than 255 corners\n");
    static const double ell[6][2] = {{0, 0}, {2, 0}, {2, 1}, {1, 1}, {1, 2}, {0, 2}};
    polygon_obj("ell.obj", ell, 6);
    rtk_scene *s = load(in_tmp("ell.obj"), 0);
    CHECK(s && s->triangle_count == 4);
    if (s)
        CHECK_NEAR(total_area(s), 3.0, 1e-6);
    rtk_scene_free(s);

    static const double concave_quad[4][2] = {{0, 0}, {2, 0}, {0.5, 0.5}, {0, 2}};
    polygon_obj("dart.obj", concave_quad, 4);
    s = load(in_tmp("dart.obj"), 0);
    CHECK(s && s->triangle_count == 2);
    if (s)
        CHECK_NEAR(total_area(s), shoelace(concave_quad, 4), 1e-6);
    rtk_scene_free(s);

    enum { STAR = 300 };
    static double star[STAR][2];
    for (int i = 0; i < STAR; i++) {
        double r = i % 2 ? 0.5 : 1.0, a = 2.0 * 3.14159265358979 * i / STAR;
        star[i][0] = r * cos(a);
        star[i][1] = r * sin(a);
    }
    polygon_obj("star.obj", (const double(*)[2])star, STAR);
    s = load(in_tmp("star.obj"), 0);
    CHECK(s && s->triangle_count + s->dropped_degenerate == STAR - 2);
    if (s)
        CHECK_NEAR(total_area(s), shoelace((const double(*)[2])star, STAR), 1e-4);
    rtk_scene_free(s);
}

/* A buffer of float positions, float normals and u16 indices for one triangle. */
static size_t triangle_buffer(unsigned char *out, int with_normals)
{
    const float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const float nrm[9] = {0.70710678f, 0.70710678f, 0, 0.70710678f, 0.70710678f, 0, 0.70710678f, 0.70710678f, 0};
    const uint16_t idx[4] = {0, 1, 2, 0};
    size_t n = 0;
    memcpy(out + n, pos, sizeof pos);
    n += sizeof pos;
    if (with_normals) {
        memcpy(out + n, nrm, sizeof nrm);
        n += sizeof nrm;
    }
    memcpy(out + n, idx, sizeof idx);
    n += sizeof idx;
    return n;
}

static void test_gltf_hierarchy(void)
{
    printf("gltf: node hierarchy, camera and material\n");
    unsigned char bin[128];
    size_t size = triangle_buffer(bin, 1);
    write_file("tri.bin", bin, size);
    char json[4096];
    snprintf(json, sizeof json,
             "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0,2]}],"
             "\"nodes\":[{\"translation\":[1,0,0],\"rotation\":[0,0,0.70710678,0.70710678],\"children\":[1]},"
             "{\"translation\":[0,2,0],\"scale\":[2,1,1],\"mesh\":0},"
             "{\"translation\":[0,0,5],\"camera\":0}],"
             "\"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":0.5,\"znear\":0.1,\"aspectRatio\":1.5}}],"
             "\"meshes\":[{\"name\":\"tri\",\"primitives\":[{\"attributes\":{\"POSITION\":0,\"NORMAL\":1},"
             "\"indices\":2,\"material\":0}]}],"
             "\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.2,0.4,0.6,0.5],"
             "\"metallicFactor\":0.25,\"roughnessFactor\":0.75},\"alphaMode\":\"BLEND\",\"emissiveFactor\":[1,1,1],"
             "\"extensions\":{\"KHR_materials_emissive_strength\":{\"emissiveStrength\":3},"
             "\"KHR_materials_ior\":{\"ior\":1.4},\"KHR_materials_transmission\":{\"transmissionFactor\":0.5}}}],"
             "\"buffers\":[{\"uri\":\"tri.bin\",\"byteLength\":%zu}],"
             "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":36},"
             "{\"buffer\":0,\"byteOffset\":36,\"byteLength\":36},{\"buffer\":0,\"byteOffset\":72,\"byteLength\":6}],"
             "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\","
             "\"min\":[0,0,0],\"max\":[1,1,0]},"
             "{\"bufferView\":1,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"},"
             "{\"bufferView\":2,\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}]}",
             size);
    rtk_scene *s = load(write_text("tree.gltf", json), ALL_NEEDS);
    CHECK(s != NULL);
    if (!s)
        return;
    CHECK(s->triangle_count == 1);
    /* child: scale (2,1,1), +(0,2,0); parent: 90 degrees about z, +(1,0,0) */
    CHECK(has_vertex(s, 0, -1, 0, 0));
    CHECK(has_vertex(s, 0, -1, 2, 0));
    CHECK(has_vertex(s, 0, -2, 0, 0));
    /* normal (1,1,0)/sqrt2 through the inverse transpose: (0.5,1,0) -> rotated (-1,0.5,0), normalized */
    CHECK_NEAR(s->normals[0], -2.0 / sqrt(5.0), 1e-5);
    CHECK_NEAR(s->normals[1], 1.0 / sqrt(5.0), 1e-5);
    CHECK(s->has_camera == 1);
    CHECK_NEAR(s->camera.position.z, 5, 1e-6);
    CHECK_NEAR(s->camera.look_at.z, 4, 1e-6);
    CHECK_NEAR(s->camera.up.y, 1, 1e-6);
    CHECK_NEAR(s->camera.fov_deg, 0.5 * 180.0 / 3.14159265358979, 1e-4);
    CHECK_NEAR(s->camera_aspect, 1.5, 1e-6);
    CHECK(s->material_count == 1);
    if (s->material_count == 1) {
        const rtk_material *m = &s->materials[0];
        CHECK_NEAR(m->base_color.g, 0.4, 1e-6);
        CHECK_NEAR(m->alpha, 0.5, 1e-6);
        CHECK(m->alpha_mode == RTK_ALPHA_BLEND);
        CHECK_NEAR(m->metallic, 0.25, 1e-6);
        CHECK_NEAR(m->roughness, 0.75, 1e-6);
        CHECK_NEAR(m->emission.r, 3, 1e-6);
        CHECK_NEAR(m->ior, 1.4, 1e-6);
        CHECK_NEAR(m->transmission, 0.5, 1e-6);
    }
    CHECK(s->tri_material && s->tri_material[0] == 0);
    rtk_scene_free(s);
}

static const unsigned char orange_png[70] = {
    0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48, 0x44, 0x52, 0x00, 0x00,
    0x00, 0x01, 0x00, 0x00, 0x00, 0x01, 0x08, 0x06, 0x00, 0x00, 0x00, 0x1f, 0x15, 0xc4, 0x89, 0x00, 0x00, 0x00,
    0x0d, 0x49, 0x44, 0x41, 0x54, 0x78, 0x9c, 0x63, 0xf8, 0xdf, 0xc0, 0xf0, 0x1f, 0x00, 0x06, 0x80, 0x02, 0x7f,
    0x10, 0x4c, 0x1b, 0xe1, 0x00, 0x00, 0x00, 0x00, 0x49, 0x45, 0x4e, 0x44, 0xae, 0x42, 0x60, 0x82};

static void put_u32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)v;
    p[1] = (unsigned char)(v >> 8);
    p[2] = (unsigned char)(v >> 16);
    p[3] = (unsigned char)(v >> 24);
}

/* Writes a .glb of json and bin, each chunk padded to 4 bytes. */
static const char *write_glb(const char *name, const char *json, const unsigned char *bin, size_t bin_size)
{
    size_t json_size = (strlen(json) + 3) & ~(size_t)3, bin_padded = (bin_size + 3) & ~(size_t)3;
    size_t total = 12 + 8 + json_size + 8 + bin_padded;
    unsigned char *out = calloc(1, total);
    memcpy(out, "glTF", 4);
    put_u32(out + 4, 2);
    put_u32(out + 8, (uint32_t)total);
    put_u32(out + 12, (uint32_t)json_size);
    memcpy(out + 16, "JSON", 4);
    memset(out + 20, ' ', json_size);
    memcpy(out + 20, json, strlen(json));
    put_u32(out + 20 + json_size, (uint32_t)bin_padded);
    memcpy(out + 24 + json_size, "BIN\0", 4);
    memcpy(out + 28 + json_size, bin, bin_size);
    const char *path = write_file(name, out, total);
    free(out);
    return path;
}

static void test_glb(void)
{
    printf("glb: embedded image, mirrored node\n");
    unsigned char bin[256];
    size_t size = triangle_buffer(bin, 0);
    size_t image_offset = (size + 3) & ~(size_t)3;
    memcpy(bin + image_offset, orange_png, sizeof orange_png);
    char json[4096];
    snprintf(json, sizeof json,
             "{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[0]}],"
             "\"nodes\":[{\"scale\":[-1,1,1],\"mesh\":0}],"
             "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,\"material\":0}]}],"
             "\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0}},\"alphaMode\":\"MASK\"}],"
             "\"textures\":[{\"source\":0}],\"images\":[{\"bufferView\":2,\"mimeType\":\"image/png\"}],"
             "\"buffers\":[{\"byteLength\":%zu}],"
             "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":36},"
             "{\"buffer\":0,\"byteOffset\":36,\"byteLength\":6},"
             "{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu}],"
             "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\","
             "\"min\":[0,0,0],\"max\":[1,1,0]},"
             "{\"bufferView\":1,\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}]}",
             (image_offset + sizeof orange_png + 3) & ~(size_t)3, image_offset, sizeof orange_png);
    const char *glb = write_glb("tri.glb", json, bin, image_offset + sizeof orange_png);
    rtk_scene *s = load(glb, ALL_NEEDS);
    CHECK(s != NULL);
    if (!s)
        return;
    CHECK(s->triangle_count == 1);
    CHECK(has_vertex(s, 0, -1, 0, 0));
    /* The mirror keeps the authored front side: the stored winding faces +z. */
    const float *a = vertex_of(s, 0, 0), *b = vertex_of(s, 0, 1), *c = vertex_of(s, 0, 2);
    double nz = ((double)b[0] - a[0]) * ((double)c[1] - a[1]) - ((double)b[1] - a[1]) * ((double)c[0] - a[0]);
    CHECK(nz > 0);
    CHECK(s->texture_count == 1);
    CHECK(s->material_count == 1);
    if (s->texture_count == 1 && s->material_count == 1) {
        const rtk_texture *t = &s->textures[0];
        CHECK(t->path == NULL && t->bytes && t->byte_count == sizeof orange_png);
        CHECK(t->bytes && memcmp(t->bytes, orange_png, sizeof orange_png) == 0);
        CHECK(t->srgb == 1 && t->decoded == 1);
        CHECK(s->materials[0].base_tex == 0 && s->materials[0].alpha_tex == 0);
        CHECK(s->materials[0].alpha_mode == RTK_ALPHA_MASK);
    }
    rtk_scene_free(s);

    /* Without needs the MASK material's image is still decoded: traversal
     * tests its alpha. */
    s = load(glb, 0);
    CHECK(s && s->texture_count == 1 && s->textures[0].decoded == 1 && s->has_cutouts);
    rtk_scene_free(s);
}

/* A one-triangle glTF with the given extra JSON members for node 0 and
 * the given index data; used for the broken-file cases. */
static const char *small_gltf(const char *name, const char *nodes, const uint16_t idx[3], const char *images)
{
    unsigned char bin[64];
    const float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    memcpy(bin, pos, sizeof pos);
    memcpy(bin + 36, idx, 6);
    memset(bin + 42, 0, 2);
    char bin_name[256], json[4096];
    snprintf(bin_name, sizeof bin_name, "%s.bin", name);
    write_file(bin_name, bin, 44);
    snprintf(json, sizeof json,
             "{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[0]}],\"nodes\":%s,"
             "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1%s}]}],%s"
             "\"buffers\":[{\"uri\":\"%s\",\"byteLength\":44}],"
             "\"bufferViews\":[{\"buffer\":0,\"byteLength\":36},{\"buffer\":0,\"byteOffset\":36,\"byteLength\":6}],"
             "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\","
             "\"min\":[0,0,0],\"max\":[1,1,0]},"
             "{\"bufferView\":1,\"componentType\":5123,\"count\":3,\"type\":\"SCALAR\"}]}",
             nodes, images ? ",\"material\":0" : "", images ? images : "", bin_name);
    return write_text(name, json);
}

static void test_gltf_errors(void)
{
    printf("gltf: broken files\n");
    const uint16_t good[3] = {0, 1, 2}, bad[3] = {0, 1, 7};
    expect_refused(small_gltf("cycle.gltf", "[{\"mesh\":0,\"children\":[1]},{\"children\":[0]}]", good, NULL),
                   RTK_ERR_PARSE, "cycle", __LINE__);
    expect_refused(small_gltf("index.gltf", "[{\"mesh\":0}]", bad, NULL), RTK_ERR_PARSE, "index 2 is 7", __LINE__);
    expect_refused(small_gltf("nomesh.gltf", "[{\"mesh\":4}]", good, NULL), RTK_ERR_PARSE, "mesh 4", __LINE__);

    printf("gltf: a missing image still loads\n");
    const char *path = small_gltf("noimage.gltf", "[{\"mesh\":0}]", good,
                                  "\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0}}}],"
                                  "\"textures\":[{\"source\":0}],\"images\":[{\"uri\":\"no%20such.png\"}],");
    rtk_scene *s = load(path, ALL_NEEDS);
    CHECK(s != NULL);
    if (s) {
        CHECK(s->texture_count == 1);
        if (s->texture_count == 1) {
            CHECK(s->textures[0].path && strstr(s->textures[0].path, "/no such.png"));
            CHECK(s->textures[0].missing == 1);
        }
    }
    rtk_scene_free(s);
}

static int exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

static void test_shared_data(void)
{
    const char *root = RTK_SOURCE_ROOT "/../shared/data";
    if (!exists(root)) {
        printf("shared data: skipped, %s is absent\n", root);
        return;
    }
    char path[1024];
    printf("shared data: bunny\n");
    snprintf(path, sizeof path, "%s/meshes/bunny.obj", root);
    rtk_scene *s = load(path, ALL_NEEDS);
    CHECK(s && s->triangle_count == 75408 && s->vertex_count == 37706);
    rtk_scene_free(s);

    printf("shared data: balloon\n");
    snprintf(path, sizeof path, "%s/gltf/balloon/scene.gltf", root);
    s = load(path, ALL_NEEDS);
    CHECK(s && s->triangle_count > 0 && s->material_count > 1 && s->texture_count > 0);
    rtk_scene_free(s);

    printf("shared data: smallpine (its normal map is missing)\n");
    snprintf(path, sizeof path, "%s/gltf/smallpine/scene.gltf", root);
    s = load(path, ALL_NEEDS);
    CHECK(s && s->triangle_count > 0);
    if (s) {
        int missing = 0;
        for (uint32_t i = 0; i < s->texture_count; i++)
            missing += s->textures[i].missing && strstr(s->textures[i].path ? s->textures[i].path : "", "normal");
        CHECK(missing == 1);
    }
    rtk_scene_free(s);

    printf("shared data: showroom\n");
    snprintf(path, sizeof path, "%s/showroom/showroom.obj", root);
    double start = rtk_now();
    s = load(path, RTK_NEED_NORMALS | RTK_NEED_UVS | RTK_NEED_MATERIALS);
    /* Every polygon becomes corners - 2 triangles, kept or dropped as zero-area. */
    CHECK(s && s->triangle_count + s->dropped_degenerate == 2212586);
    if (s)
        printf("  %u triangles (%u degenerate dropped), %u materials, %u textures in %.2f s\n", s->triangle_count,
               s->dropped_degenerate, s->material_count, s->texture_count, rtk_now() - start);
    rtk_scene_free(s);
}

int main(void)
{
    scratch_begin("rtk-test-loaders");
    test_obj_quad();
    test_obj_errors();
    test_obj_degenerate();
    test_obj_polygons();
    test_gltf_hierarchy();
    test_glb();
    test_gltf_errors();
    test_shared_data();
    scratch_end();
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}

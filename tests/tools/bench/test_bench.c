/* The pieces of tools/bench/bench.c: the recipe's OBJ reader, PCG32 against
 * the reference generator's published output, the ray hash and primary
 * rays against values computed by recipe.py (Python doubles), the AO
 * basis. test_bench.py checks the whole `rtk bench` command. */
#include "bench/bench.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static int passed, failed;

static void check(int ok, const char *what)
{
    printf("%s  %s\n", ok ? "ok  " : "FAIL", what);
    ok ? passed++ : failed++;
}

static const char *write_obj(const char *text)
{
    static char path[64];
    snprintf(path, sizeof path, "/tmp/rtk_test_bench_%d.obj", (int)getpid());
    FILE *f = fopen(path, "w");
    if (f) {
        fputs(text, f);
        fclose(f);
    }
    return path;
}

static void test_obj(void)
{
    /* A pentagon fanned from its first corner, i/j/k and negative indices,
     * a degenerate triangle kept, an unreferenced vertex in the bounds. */
    const char *path = write_obj("# comment\n"
                                 "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0.5 2 0\nv 0 1 0\n"
                                 "vt 0 0\nvn 0 0 1\no thing\ng group\ns 1\nusemtl x\n"
                                 "f 1/1/1 2/1/1 3//1 4/1 5\n"
                                 "f -5 -4 -4\n"
                                 "f 1 2\n"
                                 "v 9 -3 5e-1\n");
    rtk_scene *s = NULL;
    rtk_status st = rtk_bench_read_obj(path, &s);
    check(st == RTK_OK, "OBJ with every face form reads");
    if (st != RTK_OK) {
        printf("  %s\n", rtk_error_message());
        return;
    }
    check(s->triangle_count == 4 && s->vertex_count == 6,
          "pentagon fans into 3 triangles, the degenerate one stays, a 2-vertex face gives none");
    const uint32_t want[12] = {0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 1, 1};
    check(memcmp(s->indices, want, sizeof want) == 0, "fan is (0, i, i+1); negative indices count back");
    check(s->bounds.upper.x == 9.0f && s->bounds.lower.y == -3.0f && s->bounds.upper.z == 0.5f,
          "bounds cover every vertex, referenced or not");
    rtk_scene_free(s);

    const struct {
        const char *text, *where;
    } bad[] = {
        {"v 0 0 0\nv 1 0 0\nf 1 2 3\n", ":3:"},
        {"v 0 0\n", ":1:"},
        {"v 0 0 0\nv 1 0 0\nv 1 1 0\n\nf 1 2 x\n", ":5:"},
        {"v 0 0 0\nv 1 0 0\nv 1 1 0\nf -4 1 2\n", ":4:"},
        {"v 0 0 nan\n", ":1:"},
        {"v 0 0 0\nv 1 0 0\nf 1 2\n", "no triangles"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        path = write_obj(bad[i].text);
        st = rtk_bench_read_obj(path, &s);
        char what[160];
        snprintf(what, sizeof what, "bad OBJ %zu refused with '%s'", i, bad[i].where);
        check(st != RTK_OK && s == NULL && strstr(rtk_error_message(), bad[i].where), what);
    }
    st = rtk_bench_read_obj("/nonexistent/x.obj", &s);
    check(st == RTK_ERR_IO, "missing file is an I/O error");
    unlink(path);
}

static void test_pcg32(void)
{
    /* pcg32-demo: pcg32_srandom_r(&rng, 42u, 54u), first six outputs. */
    const uint32_t want[6] = {0xa15c02b7u, 0x7b47f409u, 0xba1d3330u, 0x83d2f293u, 0xbfa4784bu, 0xcbed606eu};
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 42u, 54u);
    int same = 1;
    for (int i = 0; i < 6; i++)
        same &= rtk_pcg32_next(&rng) == want[i];
    check(same, "PCG32 (42, 54) gives the reference generator's output");
}

static void test_rays(void)
{
    check(rtk_bench_ray_hash(NULL, 0) == 0xcbf29ce484222325ull, "hash of no rays is the FNV-1a offset basis");
    rtk_ray r = {{1.0f, 2.0f, 3.0f}, 0.0f, {0.0f, -1.0f, 0.5f}, INFINITY};
    check(rtk_bench_ray_hash(&r, 1) == 0xf4ef03a3b45adf88ull, "hash of one ray equals recipe.py's");
    /* recipe.py: look_camera((0,0,1), (0,0,0), 45), 4x3. */
    rtk_bench_camera cam;
    const double eye[3] = {0, 0, 1}, at[3] = {0, 0, 0}, up[3] = {0, 1, 0};
    check(rtk_bench_camera_look(eye, at, up, 45.0, &cam) == RTK_OK, "explicit camera");
    rtk_ray rays[12];
    rtk_bench_primary_rays(&cam, 4, 3, rays);
    check(rays[0].dir.x == (float)-0.3708062469959259 && rays[0].dir.y == (float)0.24720416963100433 &&
              rays[0].dir.z == (float)-0.8952054381370544 && rays[0].tmin == 0.0f && isinf(rays[0].tmax),
          "top-left primary ray equals recipe.py's");
    check(rtk_bench_ray_hash(rays, 12) == 0x47d42e73254a925dull, "4x3 primary rays hash as recipe.py's");
    check(rtk_bench_camera_look(eye, eye, up, 45.0, &cam) != RTK_OK, "eye == look-at refused");
    const double above[3] = {0, 5, 0};
    check(rtk_bench_camera_look(above, at, up, 45.0, &cam) != RTK_OK, "looking along up refused");
    check(rtk_bench_camera_look(eye, at, up, 180.0, &cam) != RTK_OK, "fov 180 refused");
}

static void test_ao(void)
{
    /* A unit triangle facing +z hit straight on: AO rays leave from
     * 1e-4 * diag above the hit, towards +z, with tfar 0.1 * diag. */
    rtk_scene *s = rtk_scene_new("ao", 0);
    uint32_t a, b, c;
    rtk_scene_add_vertex(s, 0, 0, 0, &a);
    rtk_scene_add_vertex(s, 1, 0, 0, &b);
    rtk_scene_add_vertex(s, 0, 1, 0, &c);
    rtk_scene_add_triangle(s, a, b, c, NULL, NULL, RTK_INVALID_ID);
    rtk_ray primary = {{0.25f, 0.25f, 1.0f}, 0.0f, {0.0f, 0.0f, -1.0f}, INFINITY};
    rtk_hit hit = {1.0f, 0.25f, 0.25f, 0, RTK_INVALID_ID};
    rtk_ray ao[8];
    rtk_bench_ao_rays(s, &primary, &hit, 7, 2.0, 8, ao);
    int ok = 1;
    for (int i = 0; i < 8; i++) {
        float len = sqrtf(ao[i].dir.x * ao[i].dir.x + ao[i].dir.y * ao[i].dir.y + ao[i].dir.z * ao[i].dir.z);
        ok &= ao[i].org.x == 0.25f && ao[i].org.y == 0.25f && ao[i].org.z == 2e-4f;
        ok &= ao[i].dir.z > 0.0f && fabsf(len - 1.0f) < 1e-6f && ao[i].tmin == 0.0f && ao[i].tmax == 0.2f;
    }
    check(ok, "AO rays: offset origin, unit directions in the hemisphere, tfar 0.1 diag");
    /* The same triangle seen from below: the normal flips. */
    primary.org.z = -1.0f, primary.dir.z = 1.0f;
    rtk_bench_ao_rays(s, &primary, &hit, 7, 2.0, 8, ao);
    ok = 1;
    for (int i = 0; i < 8; i++)
        ok &= ao[i].org.z == -2e-4f && ao[i].dir.z < 0.0f;
    check(ok, "AO rays leave on the side the primary ray came from");
    rtk_scene_free(s);
}

int main(void)
{
    test_obj();
    test_pcg32();
    test_rays();
    test_ao();
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}

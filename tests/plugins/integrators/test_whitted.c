/* whitted against closed forms: the point-light law, a mirror against the
 * mirrored camera, and a glass slab's Fresnel reflection, total internal
 * reflection and parallel exit. Whitted is deterministic for a given ray,
 * so the checks are to float rounding (relative 1e-5 unless stated). */
#include "internal.h"
#include "lights.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

static int passed, failed;
static const rtk_plugin *whitted, *median;

static uint32_t material(rtk_scene *s, rtk_material m)
{
    uint32_t id = 0;
    rtk_scene_add_material(s, &m, &id);
    return id;
}

static rtk_material diffuse(float rho, float le)
{
    rtk_material m = rtk_material_default();
    m.base_color = rtk_rgb_make(rho, rho, rho);
    m.emission = rtk_rgb_make(le, le, le);
    return m;
}

static void add_quad(rtk_scene *s, rtk_vec3 o, rtk_vec3 e1, rtk_vec3 e2, uint32_t m)
{
    uint32_t i[4];
    rtk_vec3 p[4] = {o, rtk_vec3_add(o, e1), rtk_vec3_add(rtk_vec3_add(o, e1), e2), rtk_vec3_add(o, e2)};
    for (int k = 0; k < 4; k++)
        rtk_scene_add_vertex(s, p[k].x, p[k].y, p[k].z, &i[k]);
    rtk_scene_add_triangle(s, i[0], i[1], i[2], NULL, NULL, m);
    rtk_scene_add_triangle(s, i[0], i[2], i[3], NULL, NULL, m);
}

/* Radiance along ray in scene s (finished here) with max_depth. */
static double radiance(rtk_scene *s, rtk_ray ray, const char *max_depth)
{
    rtk_params *ap = rtk_params_defaults(median), *ip = rtk_params_defaults(whitted);
    const rtk_integrator_fns *f = whitted->functions;
    void *state = NULL;
    double out = -1.0;
    if (rtk_bvh_build(s, median, ap, 1) == RTK_OK && rtk_params_set_text(ip, "max_depth", max_depth) == RTK_OK &&
        f->create(ip, &state) == RTK_OK) {
        rtk_ctx ctx = {0};
        ctx.scene = s;
        rtk_ctx_start_sample(&ctx, 0, 0);
        rtk_li_result r = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, INFINITY};
        f->li(state, &ctx, &ray, &r);
        out = r.radiance.g;
        f->destroy(state);
    } else {
        printf("     set-up failed: %s\n", rtk_error_message());
    }
    rtk_params_destroy(ap);
    rtk_params_destroy(ip);
    return out;
}

static void expect(const char *what, double got, double truth, double rel)
{
    int ok = fabs(got - truth) <= rel * fabs(truth) + (truth == 0.0 ? 0.0 : 1e-12);
    printf("%s  %s: %.9g, truth %.9g\n", ok ? "ok  " : "FAIL", what, got, truth);
    ok ? passed++ : failed++;
}

static rtk_ray make_ray(rtk_vec3 org, rtk_vec3 dir)
{
    rtk_ray r = {org, 0.0f, dir, INFINITY};
    return r;
}

static double fresnel(double cos_i, double n1, double n2)
{
    double sin_t = n1 / n2 * sqrt(1.0 - cos_i * cos_i);
    if (sin_t >= 1.0)
        return 1.0;
    double cos_t = sqrt(1.0 - sin_t * sin_t);
    double a = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t);
    double b = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
    return 0.5 * (a * a + b * b);
}

static rtk_material glass(void)
{
    rtk_material m = rtk_material_default();
    m.transmission = 1.0f;
    m.ior = 1.5f;
    return m;
}

/* A glTF file with a floor quad and a KHR_lights_punctual point light on a
 * translated node: the loader places the light, and whitted lights the
 * floor by the same law as above. */
static void test_gltf_light(void)
{
    char dir[] = "/tmp/rtk-whitted-XXXXXX";
    if (!mkdtemp(dir)) {
        expect("temporary directory", 0.0, 1.0, 0.0);
        return;
    }
    char bin[256], gltf[256];
    snprintf(bin, sizeof bin, "%s/quad.bin", dir);
    snprintf(gltf, sizeof gltf, "%s/quad.gltf", dir);
    const float pos[12] = {-5, 0, -5, -5, 0, 5, 5, 0, 5, 5, 0, -5};
    const uint16_t idx[6] = {0, 1, 2, 0, 2, 3};
    FILE *f = fopen(bin, "wb");
    fwrite(pos, sizeof pos, 1, f);
    fwrite(idx, sizeof idx, 1, f);
    fclose(f);
    f = fopen(gltf, "w");
    fputs("{\"asset\": {\"version\": \"2.0\"},\n"
          " \"extensionsUsed\": [\"KHR_lights_punctual\"],\n"
          " \"extensions\": {\"KHR_lights_punctual\": {\"lights\": [\n"
          "   {\"type\": \"point\", \"color\": [1.0, 1.0, 1.0], \"intensity\": 3.0}]}},\n"
          " \"scene\": 0, \"scenes\": [{\"nodes\": [0, 1]}],\n"
          " \"nodes\": [{\"mesh\": 0},\n"
          "   {\"translation\": [0.3, 2.0, -0.4], \"extensions\": {\"KHR_lights_punctual\": {\"light\": 0}}}],\n"
          " \"materials\": [{\"pbrMetallicRoughness\": {\"baseColorFactor\": [0.5, 0.5, 0.5, 1.0],\n"
          "   \"metallicFactor\": 0.0}}],\n"
          " \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"indices\": 1, \"material\": 0}]}],\n"
          " \"buffers\": [{\"uri\": \"quad.bin\", \"byteLength\": 60}],\n"
          " \"bufferViews\": [{\"buffer\": 0, \"byteOffset\": 0, \"byteLength\": 48},\n"
          "   {\"buffer\": 0, \"byteOffset\": 48, \"byteLength\": 12}],\n"
          " \"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 4, \"type\": \"VEC3\",\n"
          "   \"min\": [-5, 0, -5], \"max\": [5, 0, 5]},\n"
          "   {\"bufferView\": 1, \"componentType\": 5123, \"count\": 6, \"type\": \"SCALAR\"}]}\n",
          f);
    fclose(f);
    rtk_scene *s = NULL;
    rtk_status st = rtk_scene_load(gltf, RTK_NEED_NORMALS | RTK_NEED_MATERIALS | RTK_NEED_LIGHTS, &s);
    if (st != RTK_OK) {
        printf("     %s\n", rtk_error_message());
        expect("glTF with KHR_lights_punctual loads", 0.0, 1.0, 0.0);
    } else {
        const rtk_punctual_light *l = rtk_scene_punctual(s, 0);
        expect("glTF KHR_lights_punctual: one light", rtk_scene_punctual_count(s), 1.0, 0.0);
        if (l) {
            expect("glTF light: placed by its node", l->position.y, 2.0, 0.0);
            double r2 = 0.3 * 0.3 + 2.0 * 2.0 + 0.4 * 0.4, cos_t = 2.0 / sqrt(r2);
            /* rtk_scene_load finished the scene; radiance() builds it. */
            double got = radiance(s, make_ray(rtk_vec3_make(0, 1, 0), rtk_vec3_make(0, -1, 0)), "5");
            expect("glTF point light: Lo = rho I cos / (pi r^2)", got, 0.5 * 3.0 * cos_t / (M_PI * r2), 1e-5);
        }
        rtk_scene_free(s);
    }
    remove(bin);
    remove(gltf);
    rmdir(dir);
}

int main(void)
{
    rtk_registry *reg = NULL;
    if (rtk_registry_create(&reg) != RTK_OK ||
        rtk_registry_find(reg, RTK_KIND_INTEGRATOR, "whitted", &whitted) != RTK_OK ||
        rtk_registry_find(reg, RTK_KIND_ACCELERATOR, "median", &median) != RTK_OK) {
        printf("FAIL  plugins: %s\n", rtk_error_message());
        return 1;
    }
    const uint32_t needs = RTK_NEED_NORMALS | RTK_NEED_MATERIALS | RTK_NEED_LIGHTS;

    /* Point light of intensity I at distance r over Lambert rho:
     * Lo = rho I cos(theta) / (pi r^2). */
    {
        rtk_scene *s = rtk_scene_new("point", needs);
        add_quad(s, rtk_vec3_make(-5, 0, -5), rtk_vec3_make(0, 0, 10), rtk_vec3_make(10, 0, 0), material(s, diffuse(0.5f, 0)));
        rtk_punctual_light l = {.type = RTK_LIGHT_POINT, .position = rtk_vec3_make(0.3f, 2.0f, -0.4f),
                                .intensity = rtk_rgb_make(3, 3, 3)};
        rtk_scene_add_punctual(s, &l);
        rtk_scene_finish(s);
        double r2 = 0.3 * 0.3 + 2.0 * 2.0 + 0.4 * 0.4, cos_t = 2.0 / sqrt(r2);
        double got = radiance(s, make_ray(rtk_vec3_make(0, 1, 0), rtk_vec3_make(0, -1, 0)), "5");
        expect("point light: Lo = rho I cos / (pi r^2)", got, 0.5 * 3.0 * cos_t / (M_PI * r2), 1e-5);
        rtk_scene_free(s);
    }

    /* Mirror of reflectance R at z = 0 facing +z, a lit diffuse block in
     * front of it: the mirror shows R x what a camera mirrored through the
     * plane sees in the same scene without the mirror. */
    for (int with_mirror = 1; with_mirror >= 0; with_mirror--) {
        static double seen_in_mirror[8];
        rtk_scene *s = rtk_scene_new("mirror", needs);
        rtk_material mirror = rtk_material_default();
        mirror.illum = 3;
        mirror.specular = rtk_rgb_make(0.8f, 0.8f, 0.8f);
        if (with_mirror)
            add_quad(s, rtk_vec3_make(-5, -5, 0), rtk_vec3_make(10, 0, 0), rtk_vec3_make(0, 10, 0), material(s, mirror));
        uint32_t red = material(s, diffuse(0.6f, 0));
        /* A card at z = 2, both windings: lit from either side. */
        add_quad(s, rtk_vec3_make(-1, -1, 2), rtk_vec3_make(2, 0, 0), rtk_vec3_make(0, 2, 0), red);
        add_quad(s, rtk_vec3_make(-1, -1, 2), rtk_vec3_make(0, 2, 0), rtk_vec3_make(2, 0, 0), red);
        rtk_punctual_light l = {.type = RTK_LIGHT_POINT, .position = rtk_vec3_make(0.5f, 3.0f, 1.0f),
                                .intensity = rtk_rgb_make(5, 5, 5)};
        rtk_scene_add_punctual(s, &l);
        rtk_scene_finish(s);
        for (int k = 0; k < 8; k++) {
            /* From (x, y, 1), aimed at the mirror and beyond at the block's back. */
            rtk_vec3 org = rtk_vec3_make(0.1f * k - 0.3f, 0.05f * k - 0.2f, 1.0f);
            rtk_vec3 dir = rtk_vec3_normalize(rtk_vec3_make(-0.02f * k, 0.03f, -1.0f));
            if (with_mirror) {
                seen_in_mirror[k] = radiance(s, make_ray(org, dir), "5");
            } else {
                rtk_vec3 morg = rtk_vec3_make(org.x, org.y, -org.z), mdir = rtk_vec3_make(dir.x, dir.y, -dir.z);
                double direct_view = radiance(s, make_ray(morg, mdir), "5");
                char what[128];
                snprintf(what, sizeof what, "mirror shows R x the mirrored camera's view (ray %d)", k);
                expect(what, seen_in_mirror[k], 0.8 * direct_view, 1e-4);
                if (k == 0 && !(direct_view > 0.0))
                    expect("the mirrored view is lit", direct_view, 1.0, 0.0);
            }
        }
        rtk_scene_free(s);
    }

    /* Glass (n = 1.5) at normal incidence reflects ((n - 1)/(n + 1))^2 = 0.04:
     * a white emitter behind the camera seen in the slab, one bounce only. */
    {
        rtk_scene *s = rtk_scene_new("slab", needs);
        uint32_t g = material(s, glass()), white = material(s, diffuse(0, 1.0f));
        add_quad(s, rtk_vec3_make(-50, -50, 0), rtk_vec3_make(100, 0, 0), rtk_vec3_make(0, 100, 0), g);      /* top, +z */
        add_quad(s, rtk_vec3_make(-50, -50, -0.1f), rtk_vec3_make(0, 100, 0), rtk_vec3_make(100, 0, 0), g);  /* bottom, -z */
        add_quad(s, rtk_vec3_make(-50, -50, 2), rtk_vec3_make(0, 100, 0), rtk_vec3_make(100, 0, 0), white);  /* emitter, -z */
        rtk_scene_finish(s);
        double got = radiance(s, make_ray(rtk_vec3_make(0.2f, 0.1f, 1.0f), rtk_vec3_make(0, 0, -1)), "1");
        expect("glass reflects 0.04 at normal incidence", got, 0.04, 1e-5);
        rtk_scene_free(s);
    }

    /* Total internal reflection: from inside a glass block, towards its
     * top face at angle a to the normal; an emitter above catches any
     * transmitted ray. Below the critical angle asin(1/1.5) = 41.81 deg the
     * face transmits (1 - F) Le; beyond it, nothing. */
    {
        const double angles[] = {30.0, 41.0, 41.9, 60.0};
        for (int k = 0; k < 4; k++) {
            rtk_scene *s = rtk_scene_new("tir", needs);
            uint32_t g = material(s, glass()), white = material(s, diffuse(0, 1.0f));
            add_quad(s, rtk_vec3_make(-50, 0, -50), rtk_vec3_make(0, 0, 100), rtk_vec3_make(100, 0, 0), g);   /* top, +y */
            add_quad(s, rtk_vec3_make(-50, -1, -50), rtk_vec3_make(100, 0, 0), rtk_vec3_make(0, 0, 100), g);  /* bottom, -y */
            add_quad(s, rtk_vec3_make(-500, 1, -500), rtk_vec3_make(1000, 0, 0), rtk_vec3_make(0, 0, 1000), white); /* -y */
            rtk_scene_finish(s);
            double a = angles[k] * M_PI / 180.0;
            rtk_vec3 dir = rtk_vec3_make((float)sin(a), (float)cos(a), 0.0f);
            double got = radiance(s, make_ray(rtk_vec3_make(0, -0.5f, 0), dir), "1");
            double truth = 1.0 - fresnel(cos(a), 1.5, 1.0);
            char what[128];
            snprintf(what, sizeof what, "glass at %.1f deg from inside: %s", angles[k],
                     truth == 0.0 ? "total internal reflection" : "transmits 1 - F");
            expect(what, got, truth, 2e-5);
            rtk_scene_free(s);
        }
    }

    /* A ray through a parallel slab leaves parallel to the entering one,
     * shifted sideways: a 2 mm emitter 10 units away on that exact line is
     * hit, and shows (1 - F_in)(1 - F_out) Le. */
    {
        rtk_scene *s = rtk_scene_new("parallel", needs);
        uint32_t g = material(s, glass()), white = material(s, diffuse(0, 1.0f));
        add_quad(s, rtk_vec3_make(-50, -50, 0), rtk_vec3_make(100, 0, 0), rtk_vec3_make(0, 100, 0), g);
        add_quad(s, rtk_vec3_make(-50, -50, -0.1f), rtk_vec3_make(0, 100, 0), rtk_vec3_make(100, 0, 0), g);
        double th = 30.0 * M_PI / 180.0, tt = asin(sin(th) / 1.5);
        double x = 1.0 * tan(th) + 0.1 * tan(tt) + 9.9 * tan(th);
        const float h = 1e-3f;
        add_quad(s, rtk_vec3_make((float)x - h, -h, -10.0f), rtk_vec3_make(2 * h, 0, 0), rtk_vec3_make(0, 2 * h, 0), white);
        rtk_scene_finish(s);
        rtk_vec3 dir = rtk_vec3_make((float)sin(th), 0.0f, (float)-cos(th));
        double got = radiance(s, make_ray(rtk_vec3_make(0, 0, 1), dir), "3");
        double truth = (1.0 - fresnel(cos(th), 1.0, 1.5)) * (1.0 - fresnel(cos(tt), 1.5, 1.0));
        expect("slab: the transmitted ray leaves parallel to the entering one", got, truth, 2e-5);
        rtk_scene_free(s);
    }
    test_gltf_light();
    rtk_registry_destroy(reg);
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}

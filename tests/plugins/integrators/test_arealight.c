/* arealight against analytic irradiance. The estimate at one receiver
 * point is the mean of N independent samples; it passes within 5
 * standard errors, the standard error taken from the samples' own
 * variance (sd / sqrt(N)). Receivers are Lambertian with albedo rho, so
 * Lo = rho / pi * E = rho * L * F for a uniform emitter of radiance L with
 * view factor F. */
#include "internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

static int passed, failed;
static const rtk_plugin *arealight, *median;

static uint32_t material(rtk_scene *s, float rho, float le)
{
    rtk_material m = rtk_material_default();
    m.base_color = rtk_rgb_make(rho, rho, rho);
    m.emission = rtk_rgb_make(le, le, le);
    uint32_t id = 0;
    rtk_scene_add_material(s, &m, &id);
    return id;
}

/* Quad o, o+e1, o+e1+e2, o+e2; its front (emitting) side is e1 x e2. */
static void add_quad(rtk_scene *s, rtk_vec3 o, rtk_vec3 e1, rtk_vec3 e2, uint32_t m)
{
    uint32_t i[4];
    rtk_vec3 p[4] = {o, rtk_vec3_add(o, e1), rtk_vec3_add(rtk_vec3_add(o, e1), e2), rtk_vec3_add(o, e2)};
    for (int k = 0; k < 4; k++)
        rtk_scene_add_vertex(s, p[k].x, p[k].y, p[k].z, &i[k]);
    rtk_scene_add_triangle(s, i[0], i[1], i[2], NULL, NULL, m);
    rtk_scene_add_triangle(s, i[0], i[2], i[3], NULL, NULL, m);
}

/* Disk of radius r at height h facing down, as a fan of n triangles. */
static void add_disk(rtk_scene *s, float r, float h, int n, uint32_t m)
{
    uint32_t c;
    rtk_scene_add_vertex(s, 0, h, 0, &c);
    uint32_t first = 0, prev = 0;
    for (int k = 0; k <= n; k++) {
        double a = 2.0 * M_PI * (k % n) / n;
        uint32_t v;
        if (k < n)
            rtk_scene_add_vertex(s, r * cos(a), h, r * sin(a), &v);
        else
            v = first;
        if (k == 0)
            first = v;
        else
            rtk_scene_add_triangle(s, c, prev, v, NULL, NULL, m); /* (prev - c) x (v - c) points down */
        prev = v;
    }
}

static void expect(rtk_scene *s, rtk_vec3 target, rtk_vec3 from_dir, const char *samples, const char *mis,
                   double truth, double bias, const char *what)
{
    rtk_params *ap = rtk_params_defaults(median), *ip = rtk_params_defaults(arealight);
    const rtk_integrator_fns *f = arealight->functions;
    void *state = NULL;
    int ok = 0;
    double mean = 0.0, se = 0.0;
    const int n = 20000;
    if (rtk_bvh_build(s, median, ap, 1) == RTK_OK && rtk_params_set_text(ip, "light_samples", samples) == RTK_OK &&
        rtk_params_set_text(ip, "mis", mis) == RTK_OK && f->create(ip, &state) == RTK_OK &&
        f->prepare(state, s) == RTK_OK) {
        rtk_ctx ctx = {0};
        ctx.scene = s;
        ctx.seed = 5;
        rtk_ray ray = {rtk_vec3_add(target, rtk_vec3_scale(from_dir, 0.01f)), 0.0f, rtk_vec3_neg(from_dir), INFINITY};
        double sum = 0.0, sum2 = 0.0;
        for (int i = 0; i < n; i++) {
            rtk_ctx_start_sample(&ctx, (uint64_t)i, 0);
            rtk_li_result r = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, INFINITY};
            f->li(state, &ctx, &ray, &r);
            sum += r.radiance.g;
            sum2 += (double)r.radiance.g * r.radiance.g;
        }
        mean = sum / n;
        se = sqrt(fmax(0.0, sum2 / n - mean * mean) / n);
        ok = fabs(mean - truth) <= 5.0 * se + bias;
        f->destroy(state);
    } else {
        printf("     set-up failed: %s\n", rtk_error_message());
    }
    printf("%s  %s [light_samples=%s mis=%s]: %.6f, truth %.6f (5 SE = %.6f + bias bound %.1e)\n", ok ? "ok  " : "FAIL",
           what, samples, mis, mean, truth, 5.0 * se, bias);
    ok ? passed++ : failed++;
    rtk_params_destroy(ap);
    rtk_params_destroy(ip);
}

static rtk_scene *receiver(void)
{
    rtk_scene *s = rtk_scene_new("arealight test", RTK_NEED_NORMALS | RTK_NEED_MATERIALS | RTK_NEED_LIGHTS);
    add_quad(s, rtk_vec3_make(-5, 0, -5), rtk_vec3_make(0, 0, 10), rtk_vec3_make(10, 0, 0), material(s, 0.5f, 0.0f));
    return s;
}

int main(void)
{
    rtk_registry *reg = NULL;
    if (rtk_registry_create(&reg) != RTK_OK ||
        rtk_registry_find(reg, RTK_KIND_INTEGRATOR, "arealight", &arealight) != RTK_OK ||
        rtk_registry_find(reg, RTK_KIND_ACCELERATOR, "median", &median) != RTK_OK) {
        printf("FAIL  plugins: %s\n", rtk_error_message());
        return 1;
    }
    const rtk_vec3 up = rtk_vec3_make(0, 1, 0);
    const char *modes[2][2] = {{"1", "false"}, {"4", "true"}};

    /* Square light, half-side a at height h, radiance L = 2, above rho = 0.5. */
    const float a = 0.5f, h = 1.0f, L = 2.0f;
    double A = a / h, q = A / sqrt(1.0 + A * A);
    double F = 4.0 / M_PI * q * atan(q);
    for (int m = 0; m < 2; m++) {
        rtk_scene *s = receiver();
        add_quad(s, rtk_vec3_make(-a, h, -a), rtk_vec3_make(2 * a, 0, 0), rtk_vec3_make(0, 0, 2 * a), material(s, 0, L));
        if (rtk_scene_finish(s) == RTK_OK)
            expect(s, rtk_vec3_make(0, 0, 0), up, modes[m][0], modes[m][1], 0.5 * L * F, 0.0,
                   "square light: Lo = rho L F");
        rtk_scene_free(s);
    }

    /* Disk of radius r: F = r^2 / (h^2 + r^2). The fan of n triangles has
     * the inscribed polygon's area, smaller by the factor
     * sin(2 pi / n) / (2 pi / n); that bounds the bias of the check. */
    const float r = 0.75f;
    const int fan = 512;
    double Fd = (double)r * r / ((double)h * h + (double)r * r);
    double x = 2.0 * M_PI / fan, bias = 0.5 * L * Fd * (1.0 - sin(x) / x);
    for (int m = 0; m < 2; m++) {
        rtk_scene *s = receiver();
        add_disk(s, r, h, fan, material(s, 0, L));
        if (rtk_scene_finish(s) == RTK_OK)
            expect(s, rtk_vec3_make(0, 0, 0), up, modes[m][0], modes[m][1], 0.5 * L * Fd, bias,
                   "disk light: Lo = rho L r^2 / (h^2 + r^2)");
        rtk_scene_free(s);
    }

    /* Furnace: a convex diffuse block inside a closed box whose inner faces
     * emit Le = 1: irradiance pi Le everywhere, so Lo = rho Le. */
    for (int m = 0; m < 2; m++) {
        rtk_scene *s = rtk_scene_new("furnace", RTK_NEED_NORMALS | RTK_NEED_MATERIALS | RTK_NEED_LIGHTS);
        uint32_t wall = material(s, 0.3f, 1.0f), obj = material(s, 0.5f, 0.0f);
        add_quad(s, rtk_vec3_make(-2, -2, -2), rtk_vec3_make(0, 0, 4), rtk_vec3_make(4, 0, 0), wall); /* floor, up */
        add_quad(s, rtk_vec3_make(-2, 2, -2), rtk_vec3_make(4, 0, 0), rtk_vec3_make(0, 0, 4), wall);  /* ceiling, down */
        add_quad(s, rtk_vec3_make(-2, -2, -2), rtk_vec3_make(4, 0, 0), rtk_vec3_make(0, 4, 0), wall);  /* back, +z */
        add_quad(s, rtk_vec3_make(-2, -2, 2), rtk_vec3_make(0, 4, 0), rtk_vec3_make(4, 0, 0), wall);   /* front, -z */
        add_quad(s, rtk_vec3_make(-2, -2, -2), rtk_vec3_make(0, 4, 0), rtk_vec3_make(0, 0, 4), wall);  /* left, +x */
        add_quad(s, rtk_vec3_make(2, -2, -2), rtk_vec3_make(0, 0, 4), rtk_vec3_make(0, 4, 0), wall);   /* right, -x */
        add_quad(s, rtk_vec3_make(-0.5f, 0.5f, -0.5f), rtk_vec3_make(0, 0, 1), rtk_vec3_make(1, 0, 0), obj); /* block top */
        add_quad(s, rtk_vec3_make(-0.5f, -0.5f, -0.5f), rtk_vec3_make(1, 0, 0), rtk_vec3_make(0, 0, 1), obj); /* bottom */
        add_quad(s, rtk_vec3_make(-0.5f, -0.5f, 0.5f), rtk_vec3_make(1, 0, 0), rtk_vec3_make(0, 1, 0), obj);  /* +z */
        add_quad(s, rtk_vec3_make(-0.5f, -0.5f, -0.5f), rtk_vec3_make(0, 1, 0), rtk_vec3_make(1, 0, 0), obj); /* -z */
        add_quad(s, rtk_vec3_make(0.5f, -0.5f, -0.5f), rtk_vec3_make(0, 1, 0), rtk_vec3_make(0, 0, 1), obj);  /* +x */
        add_quad(s, rtk_vec3_make(-0.5f, -0.5f, -0.5f), rtk_vec3_make(0, 0, 1), rtk_vec3_make(0, 1, 0), obj); /* -x */
        if (rtk_scene_finish(s) == RTK_OK) {
            expect(s, rtk_vec3_make(0.1f, 0.5f, -0.2f), up, modes[m][0], modes[m][1], 0.5, 0.0,
                   "furnace: block top shows rho Le");
            expect(s, rtk_vec3_make(0.5f, 0.1f, 0.3f), rtk_vec3_make(1, 0, 0), modes[m][0], modes[m][1], 0.5, 0.0,
                   "furnace: block side shows rho Le");
        }
        rtk_scene_free(s);
    }
    rtk_registry_destroy(reg);
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}

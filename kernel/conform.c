/* The plugin conformance runner behind `rtk conform`: loads a plugin
 * exactly as the renderer does and runs the checks of its kind. Every
 * check prints one line; the last line is "N passed, N failed". */
#include "film.h"
#include "lights.h"
#include "internal.h"

#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

typedef struct runner {
    FILE *out;
    int passed, failed;
} runner;

static void check(runner *r, int ok, const char *name, const char *fmt, ...) RTK_PRINTF(4, 5);

static void check(runner *r, int ok, const char *name, const char *fmt, ...)
{
    if (ok) {
        r->passed++;
        fprintf(r->out, "ok    %s\n", name);
        return;
    }
    r->failed++;
    fprintf(r->out, "FAIL  %s: ", name);
    va_list ap;
    va_start(ap, fmt);
    vfprintf(r->out, fmt, ap);
    va_end(ap);
    fputc('\n', r->out);
}

/* Parameter sets to try: defaults, then each numeric parameter at its
 * bounds, each choice, each bool flipped. Returns NULL past the end. */
static rtk_params *param_variant(const rtk_plugin *p, int index, char *label, size_t cap)
{
    rtk_params *params = rtk_params_defaults(p);
    if (!params)
        return NULL;
    if (index == 0) {
        snprintf(label, cap, "defaults");
        return params;
    }
    int k = 1;
    for (uint32_t i = 0; i < p->param_count; i++) {
        const rtk_param_desc *d = &p->params[i];
        char values[16][64];
        int n = 0;
        if ((d->type == RTK_PARAM_INT || d->type == RTK_PARAM_FLOAT) && d->min != d->max) {
            const double ends[2] = {d->min, d->max};
            for (int e = 0; e < 2; e++) {
                if (d->type == RTK_PARAM_INT)
                    snprintf(values[n++], 64, "%lld", (long long)ends[e]);
                else if (isinf(ends[e]))
                    snprintf(values[n++], 64, "%s", ends[e] > 0 ? "inf" : "-inf");
                else
                    snprintf(values[n++], 64, "%.17g", ends[e]);
            }
        } else if (d->type == RTK_PARAM_BOOL) {
            snprintf(values[n++], 64, "%s", d->def != 0.0 ? "false" : "true");
        } else if (d->type == RTK_PARAM_STRING && d->choices) {
            const char *c = d->choices;
            while (*c && n < 16) {
                size_t len = strcspn(c, "|");
                snprintf(values[n++], 64, "%.*s", (int)len, c);
                c += len + (c[len] == '|');
            }
        }
        for (int v = 0; v < n; v++, k++) {
            if (k != index)
                continue;
            snprintf(label, cap, "%.60s=%.60s", d->name, values[v]);
            if (rtk_params_set_text(params, d->name, values[v]) != RTK_OK) {
                rtk_params_destroy(params);
                return NULL;
            }
            return params;
        }
    }
    rtk_params_destroy(params);
    return NULL;
}

static uint32_t variant_count(const rtk_plugin *p)
{
    uint32_t n = 1;
    char label[128];
    for (;;) {
        rtk_params *v = param_variant(p, (int)n, label, sizeof label);
        if (!v)
            return n;
        rtk_params_destroy(v);
        n++;
    }
}

/* Creates an instance with parameter set vi, checking both steps; label
 * names the set. Returns 1 with *state set on success. */
static int create_variant(runner *r, const rtk_plugin *p, uint32_t vi,
                          rtk_status (*create)(const rtk_params *, void **), char *label, size_t cap, void **state)
{
    char name[256];
    rtk_params *params = param_variant(p, (int)vi, label, cap);
    if (!params) {
        snprintf(name, sizeof name, "parameter set %u is accepted", vi);
        check(r, 0, name, "%s", rtk_error_message());
        return 0;
    }
    rtk_status st = create(params, state);
    snprintf(name, sizeof name, "create [%s]", label);
    check(r, st == RTK_OK, name, "%s", rtk_error_message());
    rtk_params_destroy(params);
    return st == RTK_OK;
}

static void check_schema(runner *r, const rtk_plugin *p)
{
    rtk_status st = rtk_params_check_schema(p);
    check(r, st == RTK_OK, "schema is well-formed", "%s", rtk_error_message());
    int documented = 1;
    for (uint32_t i = 0; i < p->param_count; i++)
        if (!p->params[i].doc || !p->params[i].doc[0])
            documented = 0;
    check(r, documented, "every parameter is documented", "a parameter has no doc line");
}

/* ---- accelerators ---- */

static float frand(rtk_pcg32 *rng, float lo, float hi)
{
    return lo + (hi - lo) * rtk_pcg32_float(rng);
}

static void add_tri(rtk_scene *s, rtk_vec3 a, rtk_vec3 b, rtk_vec3 c)
{
    uint32_t i0, i1, i2;
    rtk_scene_add_vertex(s, a.x, a.y, a.z, &i0);
    rtk_scene_add_vertex(s, b.x, b.y, b.z, &i1);
    rtk_scene_add_vertex(s, c.x, c.y, c.z, &i2);
    rtk_scene_add_triangle(s, i0, i1, i2, NULL, NULL, RTK_INVALID_ID);
}

/* Test meshes for builders; kept raw (no rtk_scene_finish) so that
 * degenerate and duplicated triangles reach the builder. */
static rtk_scene *make_mesh(int which, const char **name)
{
    rtk_scene *s = rtk_scene_new("conform", 0);
    if (!s)
        return NULL;
    rtk_pcg32 rng;
    rtk_pcg32_seed(&rng, 1234u + (uint64_t)which, 7u);
    switch (which) {
    case 0:
        *name = "empty mesh";
        break;
    case 1:
        *name = "one triangle";
        add_tri(s, rtk_vec3_make(-1, -1, 0), rtk_vec3_make(1, -1, 0), rtk_vec3_make(0, 1, 0));
        break;
    case 2:
        *name = "2000 random triangles";
        for (int i = 0; i < 2000; i++) {
            rtk_vec3 c = rtk_vec3_make(frand(&rng, -1, 1), frand(&rng, -1, 1), frand(&rng, -1, 1));
            rtk_vec3 v[3];
            for (int k = 0; k < 3; k++)
                v[k] = rtk_vec3_add(c, rtk_vec3_make(frand(&rng, -.1f, .1f), frand(&rng, -.1f, .1f), frand(&rng, -.1f, .1f)));
            add_tri(s, v[0], v[1], v[2]);
        }
        break;
    case 3:
        *name = "degenerate triangles among good ones";
        for (int i = 0; i < 300; i++) {
            rtk_vec3 a = rtk_vec3_make(frand(&rng, -1, 1), frand(&rng, -1, 1), frand(&rng, -1, 1));
            rtk_vec3 b = rtk_vec3_add(a, rtk_vec3_make(frand(&rng, -.2f, .2f), frand(&rng, -.2f, .2f), 0.1f));
            if (i % 3 == 0)
                add_tri(s, a, a, a); /* a point */
            else if (i % 3 == 1)
                add_tri(s, a, b, rtk_vec3_scale(rtk_vec3_add(a, b), 0.5f)); /* a line */
            else
                add_tri(s, a, b, rtk_vec3_add(a, rtk_vec3_make(0.1f, -0.05f, 0.2f)));
        }
        break;
    case 4:
        *name = "duplicated and coplanar triangles";
        for (int i = 0; i < 500; i++)
            add_tri(s, rtk_vec3_make(-1, -1, 0), rtk_vec3_make(1, -1, 0), rtk_vec3_make(0, 1, 0));
        for (int i = 0; i < 100; i++)
            add_tri(s, rtk_vec3_make(frand(&rng, -1, 0), -1, 0), rtk_vec3_make(1, frand(&rng, -1, 0), 0),
                    rtk_vec3_make(0, 1, 0));
        break;
    default: {
        *name = "closed sphere (shared edges)";
        const int nu = 48, nv = 24;
        for (int j = 0; j < nv; j++) {
            for (int i = 0; i < nu; i++) {
                rtk_vec3 p[4];
                for (int k = 0; k < 4; k++) {
                    int ii = i + (k == 1 || k == 2), jj = j + (k >= 2);
                    double th = M_PI * jj / nv, ph = 2.0 * M_PI * (ii % nu) / nu;
                    p[k] = rtk_vec3_make((float)(sin(th) * cos(ph)), (float)cos(th), (float)(sin(th) * sin(ph)));
                }
                add_tri(s, p[0], p[1], p[2]);
                add_tri(s, p[0], p[2], p[3]);
            }
        }
        break;
    }
    }
    return s;
}

static int brute_closest(const rtk_scene *s, const rtk_ray *ray, rtk_hit *hit)
{
    hit->prim = RTK_INVALID_ID;
    hit->t = ray->tmax;
    hit->u = hit->v = 0.0f;
    float best = ray->tmax;
    for (uint32_t i = 0; i < s->triangle_count; i++) {
        rtk_vec3 a, b, c;
        rtk_scene_triangle(s, i, &a, &b, &c);
        float t, u, v;
        if (rtk_intersect_triangle(ray, a, b, c, &t, &u, &v) && (t < best || (t == best && i < hit->prim))) {
            best = t;
            hit->t = t, hit->u = u, hit->v = v, hit->prim = i;
        }
    }
    return hit->prim != RTK_INVALID_ID;
}

/* Two different triangles hit at almost the same distance (coplanar
 * neighbours) are both right when the distances agree within the rounding
 * of the watertight test: its t carries a few ulps of the vertices'
 * distance from the origin, so a tree may legitimately meet the other one
 * first. The tree's answer must still be a real hit of its triangle. */
static int same_surface(const rtk_scene *s, const rtk_ray *ray, const rtk_hit *tree, const rtk_hit *brute)
{
    if (tree->t == brute->t)
        return 0; /* an exact tie must go to the lowest id */
    rtk_vec3 v[6];
    rtk_scene_triangle(s, tree->prim, &v[0], &v[1], &v[2]);
    rtk_scene_triangle(s, brute->prim, &v[3], &v[4], &v[5]);
    float t, u, w;
    if (!rtk_intersect_triangle(ray, v[0], v[1], v[2], &t, &u, &w) || t != tree->t)
        return 0;
    float reach = 0.0f;
    for (int k = 0; k < 6; k++) {
        rtk_vec3 d = rtk_vec3_sub(v[k], ray->org);
        reach = fmaxf(reach, fmaxf(fabsf(d.x), fmaxf(fabsf(d.y), fabsf(d.z))));
    }
    float bound = 16.0f * FLT_EPSILON * reach / rtk_vec3_length(ray->dir);
    return fabsf(tree->t - brute->t) <= bound;
}

/* Random rays: half aimed at points on random triangles, half anywhere. */
static rtk_ray random_ray(const rtk_scene *s, rtk_pcg32 *rng, int i)
{
    rtk_ray r;
    r.org = rtk_vec3_make(frand(rng, -2, 2), frand(rng, -2, 2), frand(rng, -2, 2));
    r.tmin = 0.0f;
    r.tmax = (i % 7 == 0) ? frand(rng, 0.1f, 2.0f) : INFINITY;
    if (s->triangle_count > 0 && i % 2 == 0) {
        rtk_vec3 a, b, c;
        rtk_scene_triangle(s, rtk_pcg32_next(rng) % s->triangle_count, &a, &b, &c);
        float u = rtk_pcg32_float(rng), v = rtk_pcg32_float(rng);
        if (i % 4 == 0)
            v = 0.0f; /* on an edge */
        if (u + v > 1.0f)
            u = 1.0f - u, v = 1.0f - v;
        rtk_vec3 target = rtk_vec3_add(a, rtk_vec3_add(rtk_vec3_scale(rtk_vec3_sub(b, a), u),
                                                       rtk_vec3_scale(rtk_vec3_sub(c, a), v)));
        r.dir = rtk_vec3_normalize(rtk_vec3_sub(target, r.org));
    } else {
        r.dir = rtk_vec3_normalize(rtk_vec3_make(frand(rng, -1, 1), frand(rng, -1, 1), frand(rng, -1, 1)));
    }
    return r;
}

static void conform_accelerator(runner *r, const rtk_plugin *p)
{
    uint32_t variants = variant_count(p);
    for (uint32_t vi = 0; vi < variants; vi++) {
        char label[128], name[256];
        rtk_params *params = param_variant(p, (int)vi, label, sizeof label);
        if (!params) {
            snprintf(name, sizeof name, "parameter set %u is accepted", vi);
            check(r, 0, name, "%s", rtk_error_message());
            continue;
        }
        for (int m = 0; m < 6; m++) {
            const char *mesh = NULL;
            rtk_scene *s = make_mesh(m, &mesh);
            if (!s) {
                check(r, 0, "test mesh", "out of memory");
                break;
            }
            snprintf(name, sizeof name, "build [%s] %s", label, mesh);
            rtk_status st = rtk_bvh_build(s, p, params, 2);
            check(r, st == RTK_OK, name, "%s", rtk_error_message());
            if (st == RTK_OK) {
                rtk_pcg32 rng;
                rtk_pcg32_seed(&rng, 99u, (uint64_t)m);
                int closest_bad = 0, any_bad = 0;
                char detail[256] = "";
                for (int i = 0; i < 3000; i++) {
                    rtk_ray ray = random_ray(s, &rng, i);
                    rtk_hit h1, h2;
                    int a = rtk_bvh_closest(s, &ray, &h1), b = brute_closest(s, &ray, &h2);
                    if (a != b || (a && (h1.prim != h2.prim || h1.t != h2.t) && !same_surface(s, &ray, &h1, &h2))) {
                        if (!closest_bad++)
                            snprintf(detail, sizeof detail, "ray %d: bvh %s prim %u t %.9g, brute force %s prim %u t %.9g", i,
                                     a ? "hit" : "miss", a ? h1.prim : 0u, a ? h1.t : 0.0, b ? "hit" : "miss",
                                     b ? h2.prim : 0u, b ? h2.t : 0.0);
                    }
                    if (rtk_bvh_any(s, &ray) != b)
                        any_bad++;
                }
                snprintf(name, sizeof name, "closest hit = brute force [%s] %s", label, mesh);
                check(r, closest_bad == 0, name, "%d of 3000 rays differ; first: %s", closest_bad, detail);
                snprintf(name, sizeof name, "any hit = brute force [%s] %s", label, mesh);
                check(r, any_bad == 0, name, "%d of 3000 rays differ", any_bad);
            }
            rtk_scene_free(s);
        }
        rtk_params_destroy(params);
    }
}

/* ---- filters ---- */

static void conform_filter(runner *r, const rtk_plugin *p)
{
    const rtk_filter_fns *f = p->functions;
    uint32_t variants = variant_count(p);
    for (uint32_t vi = 0; vi < variants; vi++) {
        char label[128], name[256];
        void *state = NULL;
        if (!create_variant(r, p, vi, f->create, label, sizeof label, &state))
            continue;
        float rad = f->radius(state);
        snprintf(name, sizeof name, "radius is finite and in (0, 64] [%s]", label);
        check(r, rad > 0.0f && rad <= 64.0f, name, "radius %g", rad);
        if (!(rad > 0.0f && rad <= 64.0f)) {
            f->destroy(state);
            continue;
        }
        rtk_pcg32 rng;
        rtk_pcg32_seed(&rng, 5u, 11u);
        int outside = 0, asym = 0, nonfinite = 0;
        float worst = 0.0f;
        for (int i = 0; i < 20000; i++) {
            float x = frand(&rng, -rad, rad), y = frand(&rng, -rad, rad);
            float w = f->eval(state, x, y);
            if (!isfinite(w))
                nonfinite++;
            float w2 = f->eval(state, -x, y), w3 = f->eval(state, x, -y);
            float tol = 1e-6f * (fabsf(w) + 1e-6f);
            if (fabsf(w - w2) > tol || fabsf(w - w3) > tol) {
                asym++;
                worst = fmaxf(worst, fmaxf(fabsf(w - w2), fabsf(w - w3)));
            }
            /* A point past the radius on one axis or both. */
            float s = 1.0f + 1e-3f + 2.0f * rtk_pcg32_float(&rng);
            float ox = (i % 3 == 1) ? x : (x < 0 ? -s * rad : s * rad);
            float oy = (i % 3 == 2) ? y : (y < 0 ? -s * rad : s * rad);
            if (f->eval(state, ox, oy) != 0.0f)
                outside++;
        }
        snprintf(name, sizeof name, "finite inside the support [%s]", label);
        check(r, nonfinite == 0 && isfinite(f->eval(state, 0, 0)), name, "%d non-finite values", nonfinite);
        snprintf(name, sizeof name, "zero past the radius [%s]", label);
        check(r, outside == 0, name, "%d of 20000 points past the radius have non-zero weight", outside);
        snprintf(name, sizeof name, "symmetric in x and y [%s]", label);
        check(r, asym == 0, name, "%d points differ from their mirror images (by up to %g)", asym, worst);
        /* Midpoint rule on a 1024^2 grid; error O(h^2) for smooth filters,
         * exact for the box whose edges fall on cell borders. */
        const int n = 1024;
        double h = 2.0 * rad / n, sum = 0.0;
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++)
                sum += f->eval(state, (float)(-rad + (i + 0.5) * h), (float)(-rad + (j + 0.5) * h));
        sum *= h * h;
        double closed = f->integral(state);
        snprintf(name, sizeof name, "weights integrate to the closed form [%s]", label);
        check(r, isfinite(closed) && closed != 0.0 && fabs(sum - closed) <= 2e-3 * fabs(closed) + 1e-9, name,
              "numeric integral %.9g, closed form %.9g", sum, closed);
        f->destroy(state);
    }
}

/* ---- integrators ---- */

static uint32_t add_material(rtk_scene *s, float r, float g, float b, float emit)
{
    rtk_material m = rtk_material_default();
    m.base_color = rtk_rgb_make(r, g, b);
    m.emission = rtk_rgb_make(emit, emit, emit);
    uint32_t id = RTK_INVALID_ID;
    rtk_scene_add_material(s, &m, &id);
    return id;
}

static void add_quad(rtk_scene *s, rtk_vec3 o, rtk_vec3 e1, rtk_vec3 e2, uint32_t material)
{
    uint32_t i[4];
    rtk_vec3 p[4] = {o, rtk_vec3_add(o, e1), rtk_vec3_add(rtk_vec3_add(o, e1), e2), rtk_vec3_add(o, e2)};
    for (int k = 0; k < 4; k++)
        rtk_scene_add_vertex(s, p[k].x, p[k].y, p[k].z, &i[k]);
    const float uv[6] = {0, 0, 1, 0, 1, 1};
    rtk_scene_add_triangle(s, i[0], i[1], i[2], NULL, uv, material);
    rtk_scene_add_triangle(s, i[0], i[2], i[3], NULL, uv, material);
}

/* A small room, open at the front, with a ceiling light and a block: every integrator
 * sees geometry, materials and an emitter. */
static rtk_status make_room(uint32_t needs, rtk_scene **out)
{
    rtk_scene *s = rtk_scene_new("conform room", needs);
    if (!s)
        return RTK_ERR_NOMEM;
    uint32_t white = add_material(s, 0.8f, 0.8f, 0.8f, 0.0f), red = add_material(s, 0.8f, 0.1f, 0.1f, 0.0f);
    uint32_t light = add_material(s, 0.0f, 0.0f, 0.0f, 10.0f);
    add_quad(s, rtk_vec3_make(-1, 0, -1), rtk_vec3_make(0, 0, 2), rtk_vec3_make(2, 0, 0), white);  /* floor */
    add_quad(s, rtk_vec3_make(-1, 2, -1), rtk_vec3_make(2, 0, 0), rtk_vec3_make(0, 0, 2), white);  /* ceiling */
    add_quad(s, rtk_vec3_make(-1, 0, -1), rtk_vec3_make(2, 0, 0), rtk_vec3_make(0, 2, 0), white);  /* back */
    add_quad(s, rtk_vec3_make(-1, 0, -1), rtk_vec3_make(0, 2, 0), rtk_vec3_make(0, 0, 2), red);    /* left */
    add_quad(s, rtk_vec3_make(1, 0, -1), rtk_vec3_make(0, 0, 2), rtk_vec3_make(0, 2, 0), white);   /* right */
    add_quad(s, rtk_vec3_make(-0.25f, 1.99f, -0.25f), rtk_vec3_make(0.5f, 0, 0), rtk_vec3_make(0, 0, 0.5f), light);
    add_quad(s, rtk_vec3_make(-0.5f, 0.6f, -0.5f), rtk_vec3_make(0.4f, 0, 0), rtk_vec3_make(0, 0, 0.4f), white);
    /* A point light under the ceiling for integrators that use punctual lights. */
    rtk_punctual_light point = {.type = RTK_LIGHT_POINT, .position = rtk_vec3_make(0.2f, 1.8f, 0.3f),
                                .intensity = rtk_rgb_make(2.0f, 2.0f, 2.0f)};
    rtk_status st = rtk_scene_add_punctual(s, &point);
    if (st == RTK_OK)
        st = rtk_scene_finish(s);
    if (st != RTK_OK) {
        rtk_scene_free(s);
        return st;
    }
    *out = s;
    return RTK_OK;
}

/* A builder that needs no plugin: one leaf over everything. Conformance
 * of an integrator must not depend on any accelerator plugin. */
static rtk_status single_leaf_build(void *state, rtk_build_args *a)
{
    (void)state;
    rtk_bvh_node *n = &a->nodes[0];
    for (int k = 0; k < 3; k++)
        n->lower[k] = INFINITY, n->upper[k] = -INFINITY;
    for (uint32_t i = 0; i < a->prim_count; i++) {
        const rtk_bounds *b = &a->prim_bounds[i];
        const float lo[3] = {b->lower.x, b->lower.y, b->lower.z}, hi[3] = {b->upper.x, b->upper.y, b->upper.z};
        for (int k = 0; k < 3; k++)
            n->lower[k] = fminf(n->lower[k], lo[k]), n->upper[k] = fmaxf(n->upper[k], hi[k]);
        a->prim_order[i] = i;
    }
    n->offset = 0;
    n->count = a->prim_count;
    a->node_count = 1;
    return RTK_OK;
}

static rtk_status no_state(const rtk_params *params, void **state)
{
    (void)params;
    *state = NULL;
    return RTK_OK;
}

static void no_destroy(void *state)
{
    (void)state;
}

static float unit_box_radius(const void *state)
{
    (void)state;
    return 0.5f;
}

static float unit_box_eval(const void *state, float dx, float dy)
{
    (void)state;
    return fabsf(dx) <= 0.5f && fabsf(dy) <= 0.5f ? 1.0f : 0.0f;
}

static double unit_box_integral(const void *state)
{
    (void)state;
    return 1.0;
}

static const rtk_accelerator_fns single_leaf_fns = {
    .size = sizeof(rtk_accelerator_fns), .create = no_state, .build = single_leaf_build, .destroy = no_destroy};
static const rtk_plugin single_leaf = {RTK_PLUGIN_HEADER,
                                       .kind = RTK_KIND_ACCELERATOR,
                                       .name = "conform-single-leaf",
                                       .version = "1",
                                       .summary = "",
                                       .functions = &single_leaf_fns};
static const rtk_filter_fns unit_box = {.size = sizeof(rtk_filter_fns),
                                        .create = no_state,
                                        .radius = unit_box_radius,
                                        .eval = unit_box_eval,
                                        .integral = unit_box_integral,
                                        .destroy = no_destroy};

static void conform_integrator(runner *r, const rtk_plugin *p)
{
    const rtk_integrator_fns *f = p->functions;
    uint32_t variants = variant_count(p);
    for (uint32_t vi = 0; vi < variants; vi++) {
        char label[128], name[256];
        void *state = NULL;
        if (!create_variant(r, p, vi, f->create, label, sizeof label, &state))
            continue;
        uint32_t needs = f->needs(state);
        snprintf(name, sizeof name, "needs only known flags [%s]", label);
        check(r, (needs & ~0x1fu) == 0, name, "needs 0x%x has unknown bits", needs);
        rtk_scene *scene = NULL;
        rtk_status st = make_room(needs, &scene);
        if (st == RTK_OK)
            st = rtk_bvh_build(scene, &single_leaf, NULL, 1);
        if (st != RTK_OK) {
            check(r, 0, "standard scene", "%s", rtk_error_message());
            f->destroy(state);
            continue;
        }
        if (f->prepare) {
            st = f->prepare(state, scene);
            snprintf(name, sizeof name, "prepare on the standard scene [%s]", label);
            check(r, st == RTK_OK, name, "%s", rtk_error_message());
        }
        if (st == RTK_OK) {
            rtk_camera_desc d = {rtk_vec3_make(0, 1, 0.95f), rtk_vec3_make(0, 0.8f, 0), rtk_vec3_make(0, 1, 0), 80.0f};
            rtk_camera cam;
            rtk_camera_init(&cam, &d, 24, 20);
            size_t count = (size_t)24 * 20 * RTK_FILM_CHANNELS;
            float *a = rtk_alloc(count * sizeof(float)), *b = rtk_alloc(count * sizeof(float));
            rtk_render_stats sa, sb;
            rtk_status s1 = a && b ? rtk_render_film(scene, &cam, f, state, &unit_box, NULL, 4, 7, 1, 0, a, &sa)
                                   : RTK_ERR_NOMEM;
            rtk_status s2 = s1 == RTK_OK ? rtk_render_film(scene, &cam, f, state, &unit_box, NULL, 4, 7, 2, 0, b, &sb)
                                         : s1;
            snprintf(name, sizeof name, "renders the standard scene [%s]", label);
            check(r, s1 == RTK_OK && s2 == RTK_OK, name, "%s", rtk_error_message());
            if (s1 == RTK_OK && s2 == RTK_OK) {
                size_t nonfinite = 0, lit = 0;
                for (size_t i = 0; i < count; i += RTK_FILM_CHANNELS)
                    for (int c = 0; c < 3; c++) {
                        if (!isfinite(a[i + (size_t)c]))
                            nonfinite++;
                        if (a[i + (size_t)c] > 0.0f)
                            lit++;
                    }
                snprintf(name, sizeof name, "output is finite [%s]", label);
                check(r, nonfinite == 0 && sa.bad_samples == 0, name, "%zu non-finite pixel values, %llu NaN/Inf samples",
                      nonfinite, (unsigned long long)sa.bad_samples);
                snprintf(name, sizeof name, "output is not all black on a lit scene [%s]", label);
                check(r, lit > 0, name, "every pixel is zero");
                snprintf(name, sizeof name, "same seed gives the same image on 1 and 2 threads [%s]", label);
                check(r, memcmp(a, b, count * sizeof(float)) == 0, name, "images differ");
                snprintf(name, sizeof name, "traces rays through the kernel [%s]", label);
                check(r, sa.rays > 0, name, "no ray was traced");
            }
            free(a);
            free(b);
        }
        rtk_scene_free(scene);
        f->destroy(state);
    }
}

RTK_API rtk_status rtk_conform(const char *path, FILE *out, int *passed, int *failed)
{
    runner r = {out, 0, 0};
    const rtk_plugin *p = NULL;
    rtk_status st = rtk_plugin_open(path, 0, &p);
    check(&r, st == RTK_OK, "loads as an rtk plugin", "%s", rtk_error_message());
    if (st == RTK_OK) {
        fprintf(out, "# %s %s %s (%s)\n", rtk_kind_name(p->kind), p->name, p->version, path);
        check_schema(&r, p);
        if (p->kind == RTK_KIND_ACCELERATOR)
            conform_accelerator(&r, p);
        else if (p->kind == RTK_KIND_FILTER)
            conform_filter(&r, p);
        else
            conform_integrator(&r, p);
    }
    fprintf(out, "%d passed, %d failed\n", r.passed, r.failed);
    fflush(out);
    if (passed)
        *passed = r.passed;
    if (failed)
        *failed = r.failed;
    return r.failed == 0 ? RTK_OK : RTK_ERR_PLUGIN;
}

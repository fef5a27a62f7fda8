/* The plugin conformance runner behind `rtk conform`: loads a plugin
 * exactly as the renderer does, checks its schema and runs the checks of
 * its kind (conform_accelerators.c, conform_filters.c,
 * conform_integrators.c). Every check prints one line ("ok" or "FAIL" and
 * the name, which carries the counts); lines starting with '#' are notes
 * (timings); the last line is "N passed, N failed". */
#include "conform.h"

#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <string.h>

void rtk_conform_check(rtk_conform_runner *r, int ok, const char *name, const char *fmt, ...)
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

rtk_params *rtk_conform_param_variant(const rtk_plugin *p, int index, char *label, size_t cap)
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
        if ((d->type == RTK_PARAM_INT || d->type == RTK_PARAM_FLOAT) && rtk_param_has_range(d)) {
            const double ends[2] = {d->min, d->max};
            for (int e = 0; e < 2; e++) {
                if (d->type == RTK_PARAM_INT && isinf(ends[e]))
                    continue; /* an open side has no end to try */
                if (d->type == RTK_PARAM_INT)
                    snprintf(values[n++], 64, "%lld",
                             ends[e] >= 9223372036854775807.0 ? LLONG_MAX : (long long)ends[e]);
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

uint32_t rtk_conform_variant_count(const rtk_plugin *p)
{
    uint32_t n = 1;
    char label[128];
    for (;;) {
        rtk_params *v = rtk_conform_param_variant(p, (int)n, label, sizeof label);
        if (!v)
            return n;
        rtk_params_destroy(v);
        n++;
    }
}

/* Creates an instance with parameter set vi, checking both steps; label
 * names the set. Returns 1 with *state set on success. */
static int create_variant(rtk_conform_runner *r, const rtk_plugin *p, uint32_t vi,
                          rtk_status (*create)(const rtk_params *, void **), char *label, size_t cap, void **state)
{
    char name[256];
    rtk_params *params = rtk_conform_param_variant(p, (int)vi, label, cap);
    if (!params) {
        snprintf(name, sizeof name, "parameter set %u is accepted", vi);
        rtk_conform_check(r, 0, name, "%s", rtk_error_message());
        return 0;
    }
    rtk_status st = create(params, state);
    snprintf(name, sizeof name, "create [%s]", label);
    rtk_conform_check(r, st == RTK_OK, name, "%s", rtk_error_message());
    rtk_params_destroy(params);
    return st == RTK_OK;
}

void rtk_conform_each_variant(rtk_conform_runner *r, const rtk_plugin *p,
                              rtk_status (*create)(const rtk_params *, void **), void (*destroy)(void *),
                              void (*each)(rtk_conform_runner *r, const rtk_plugin *p, void *state,
                                           const char *label))
{
    uint32_t variants = rtk_conform_variant_count(p);
    for (uint32_t vi = 0; vi < variants; vi++) {
        char label[128];
        void *state = NULL;
        if (!create_variant(r, p, vi, create, label, sizeof label, &state))
            continue;
        each(r, p, state, label);
        destroy(state);
    }
}

static void check_schema(rtk_conform_runner *r, const rtk_plugin *p)
{
    rtk_status st = rtk_params_check_schema(p);
    rtk_conform_check(r, st == RTK_OK, "schema is well-formed", "%s", rtk_error_message());
    int documented = 1;
    for (uint32_t i = 0; i < p->param_count; i++)
        if (!p->params[i].doc || !p->params[i].doc[0])
            documented = 0;
    rtk_conform_check(r, documented, "every parameter is documented", "a parameter has no doc line");
}

rtk_status rtk_conform_run(const char *path, const rtk_conform_options *options, FILE *out, int *passed,
                           int *failed)
{
    rtk_conform_runner r = {out, 0, 0, 0};
    const rtk_plugin *p = NULL;
    rtk_status st = rtk_plugin_open(path, 0, &p);
    rtk_conform_check(&r, st == RTK_OK, "loads as an rtk plugin", "%s", rtk_error_message());
    if (st == RTK_OK) {
        fprintf(out, "# %s %s %s (%s)\n", rtk_kind_name(p->kind), p->name, p->version, path);
        check_schema(&r, p);
        if (p->kind == RTK_KIND_ACCELERATOR)
            rtk_conform_accelerator(&r, p, options);
        else if (p->kind == RTK_KIND_FILTER)
            rtk_conform_filter(&r, p);
        else
            rtk_conform_integrator(&r, p);
    }
    fprintf(out, "%d passed, %d failed\n", r.passed, r.failed);
    fflush(out);
    if (passed)
        *passed = r.passed;
    if (failed)
        *failed = r.failed;
    return r.failed ? RTK_ERR_PLUGIN : r.skipped ? RTK_ERR_UNSUPPORTED : RTK_OK;
}

rtk_status rtk_conform(const char *path, FILE *out, int *passed, int *failed)
{
    return rtk_conform_run(path, NULL, out, passed, failed);
}

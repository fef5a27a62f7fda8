/* rtk sweep: speed against error (the files it writes are listed at
 * rtk_sweep in include/rtk/host.h).
 *
 * Every render goes through rtk_config_load + rtk_render, exactly as
 * `rtk render` with --set overrides: the base overrides, then the sweep's
 * own (film.output to a temporary EXR in the output directory, film.half
 * off, cache=off unless asked, threads), then the combination's axis
 * values, then film.spp and sampler.seed. The image is read back, removed,
 * and compared with the reference by rtk_diff_buffers over R, G, B.
 *
 * Statistics, per combination and spp, are means over the seeds. The
 * convergence slope is a least-squares fit of log(mean RMSE) (and of
 * log(mean relMSE)) against log(spp) over the upper half of the spp values.
 * The time to the target is rtk_sweep_time_to_error over (mean render
 * seconds, mean relMSE): build and load time are left out, being the same
 * for every sampler and filter, and reported beside it. */
#include "accel/accel.h"
#include "config/config.h"
#include "../tools.h"
#include "image/image.h"

#include <errno.h>
#include <math.h>
#include <spawn.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

/* The reference's seed: outside 1..seeds, so its noise is independent of every run's. */
#define SWEEP_REFERENCE_SEED 2654435761u
#define SWEEP_MAX_SPP (1u << 20)
#define SWEEP_MAX_SEEDS 100000u

extern char **environ;

/* One combination of axis values. */
typedef struct sweep_combo {
    char **sets;              /* axis_count overrides "key=value" */
    char label[512];          /* "sobol gaussian rays=4" */
    char params[1024];        /* the axes other than sampler/filter/accelerator/integrator plugin, ';'-joined */
    char scene[256], integrator[64], sampler[32], accelerator[64], filter[64];
    uint32_t width, height;
    uint32_t colour, style;   /* plot: value index on the first and second axis */
    size_t ref;               /* index into sweep.refs */
} sweep_combo;

/* A reference image and what made it. */
typedef struct sweep_ref {
    uint64_t hash;
    char *path;
    char filter[64];          /* "box", the combination's ("same"), or "given" */
    rtk_image image;
} sweep_ref;

/* One render's measurements: a CSV row. Rows are kept (and written)
 * combination-major, then by spp, then by seed. */
typedef struct sweep_run {
    uint32_t spp, seed, threads;
    double load_s, build_s, render_s;
    double cpu_s;             /* CPU seconds of every thread over the whole rtk_render call */
    uint64_t rays, bad_samples, excluded;
    double rmse, relmse, mape;
} sweep_run;

/* Means over the seeds of one combination at one spp. */
typedef struct sweep_point {
    double spp, render_s, build_s, rmse, relmse, mape;
} sweep_point;

/* Fit and time to target of one combination. */
typedef struct sweep_fit {
    double rmse_slope, relmse_slope, seconds;
    rtk_sweep_reach reach;
} sweep_fit;

/* State of one rtk_sweep call. */
typedef struct sweep {
    const char *path;
    rtk_registry *registry;
    rtk_sweep_options o;
    uint32_t default_spp[7];
    char *dir;                /* absolute output directory */
    char *config_text;
    size_t config_len;
    char *run_output;         /* temporary image of one run */
    char *fixed[4];           /* the sweep's own overrides */
    size_t fixed_count;
    sweep_combo *combos;
    size_t combo_count;
    sweep_ref *refs;
    size_t ref_count;
    sweep_run *runs;          /* combo-major, then spp, then seed */
    size_t run_count, runs_done;
    sweep_point *points;      /* combo_count x spp_count */
    sweep_fit *fits;
    uint64_t work_total, work_done;
    double t0;
} sweep;

rtk_status rtk_sweep_fit_slope(const double *x, const double *y, size_t n, double *slope)
{
    if (!x || !y || !slope)
        return rtk_error(RTK_ERR_INVALID, "rtk_sweep_fit_slope: no points given");
    if (n < 2)
        return rtk_error(RTK_ERR_INVALID, "a slope needs at least 2 points, not %zu", n);
    double mx = 0.0, my = 0.0;
    for (size_t i = 0; i < n; i++) {
        if (!(x[i] > 0.0 && isfinite(x[i]) && y[i] > 0.0 && isfinite(y[i])))
            return rtk_error(RTK_ERR_INVALID, "point %zu (%g, %g): a log-log fit needs finite values > 0", i, x[i],
                             y[i]);
        mx += log(x[i]);
        my += log(y[i]);
    }
    mx /= (double)n;
    my /= (double)n;
    double sxx = 0.0, sxy = 0.0;
    for (size_t i = 0; i < n; i++) {
        double dx = log(x[i]) - mx;
        sxx += dx * dx;
        sxy += dx * (log(y[i]) - my);
    }
    if (sxx == 0.0)
        return rtk_error(RTK_ERR_INVALID, "a slope needs x values that differ");
    *slope = sxy / sxx;
    return RTK_OK;
}

rtk_sweep_reach rtk_sweep_time_to_error(const double *seconds, const double *error, size_t n, double target,
                                                double *out)
{
    if (!seconds || !error || n == 0 || !(target > 0.0 && isfinite(target)))
        return RTK_SWEEP_NO_DATA;
    for (size_t i = 0; i < n; i++)
        if (!(seconds[i] > 0.0 && isfinite(seconds[i]) && error[i] >= 0.0 && isfinite(error[i])))
            return RTK_SWEEP_NO_DATA;
    if (error[0] <= target) {
        if (out)
            *out = seconds[0];
        return RTK_SWEEP_AT_FIRST;
    }
    for (size_t i = 0; i + 1 < n; i++) {
        if (error[i] <= target || error[i + 1] > target)
            continue;
        double t = seconds[i + 1];
        if (error[i + 1] > 0.0) {
            double f = (log(target) - log(error[i])) / (log(error[i + 1]) - log(error[i]));
            t = exp(log(seconds[i]) + f * (log(seconds[i + 1]) - log(seconds[i])));
        }
        if (out)
            *out = t;
        return RTK_SWEEP_REACHED;
    }
    return RTK_SWEEP_NOT_REACHED;
}

/* Prefixes the current error with context. */
static rtk_status with_context(rtk_status st, const char *fmt, ...) RTK_PRINTF(2, 3);
static rtk_status with_context(rtk_status st, const char *fmt, ...)
{
    char what[1024], msg[2048];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    snprintf(msg, sizeof msg, "%s", rtk_error_message());
    return rtk_error(st, "%s: %s", what, msg);
}

/* Allocated printf. [caller frees] */
static char *format(const char *fmt, ...) RTK_PRINTF(1, 2);
static char *format(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    char *s = NULL;
    int n = vasprintf(&s, fmt, ap);
    va_end(ap);
    if (n < 0) {
        rtk_error(RTK_ERR_NOMEM, "out of memory");
        return NULL;
    }
    return s;
}

/* mkdir -p. */
static rtk_status make_dirs(const char *dir)
{
    char *p = rtk_strdup(dir);
    if (!p)
        return RTK_ERR_NOMEM;
    rtk_status st = RTK_OK;
    for (char *s = p + 1;; s++) {
        if (*s != '/' && *s != '\0')
            continue;
        char c = *s;
        *s = '\0';
        struct stat sb;
        if (mkdir(p, 0777) != 0 && errno != EEXIST)
            st = rtk_error(RTK_ERR_IO, "cannot create directory %s: %s", p, strerror(errno));
        else if (stat(p, &sb) != 0 || !S_ISDIR(sb.st_mode))
            st = rtk_error(RTK_ERR_IO, "cannot use %s as the output directory: it is not a directory", p);
        *s = c;
        if (st != RTK_OK || c == '\0')
            break;
    }
    free(p);
    return st;
}

/* The whole file at path. [caller frees] */
static rtk_status read_text(const char *path, char **text, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return rtk_error(RTK_ERR_IO, "%s: cannot read config: %s", path, strerror(errno));
    char *buf = NULL;
    size_t n = 0, cap = 0;
    for (;;) {
        if (n + 4096 > cap) {
            cap = cap ? cap * 2 : 8192;
            char *grown = realloc(buf, cap);
            if (!grown) {
                free(buf);
                fclose(f);
                return rtk_error(RTK_ERR_NOMEM, "%s: out of memory reading the config", path);
            }
            buf = grown;
        }
        size_t got = fread(buf + n, 1, cap - n, f);
        n += got;
        if (got == 0)
            break;
    }
    int bad = ferror(f);
    fclose(f);
    if (bad) {
        free(buf);
        return rtk_error(RTK_ERR_IO, "%s: cannot read config", path);
    }
    *text = buf;
    *len = n;
    return RTK_OK;
}

/* 1 when key starts with prefix followed by '.'. */
static int under(const char *key, const char *group)
{
    size_t n = strlen(group);
    return strncmp(key, group, n) == 0 && key[n] == '.';
}

/* Loads the config with base overrides, the sweep's own, then extra. */
static rtk_status load_config(sweep *s, const char *const *extra, size_t extra_count, rtk_config **cfg)
{
    size_t n = s->o.override_count + s->fixed_count + extra_count;
    const char **all = rtk_calloc(n ? n : 1, sizeof *all);
    if (!all)
        return RTK_ERR_NOMEM;
    size_t k = 0;
    for (size_t i = 0; i < s->o.override_count; i++)
        all[k++] = s->o.overrides[i];
    for (size_t i = 0; i < s->fixed_count; i++)
        all[k++] = s->fixed[i];
    for (size_t i = 0; i < extra_count; i++)
        all[k++] = extra[i];
    rtk_config_options co;
    memset(&co, 0, sizeof co);
    co.size = sizeof co;
    co.allow_config_plugins = s->o.allow_config_plugins;
    co.allow_outside_files = s->o.allow_outside_files;
    co.oversubscribe = s->o.oversubscribe;
    co.overrides = all;
    co.override_count = n;
    rtk_status st = rtk_config_load(s->path, s->registry, &co, cfg);
    free(all);
    return st;
}

/* CPU seconds of the whole process (every thread) so far. */
static double cpu_now(void)
{
    struct timespec ts;
    if (clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts) != 0)
        return 0.0;
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Loads, renders to the image file the overrides name, reads it back;
 * *cpu_s gets the process's CPU seconds during rtk_render. */
static rtk_status render_image(sweep *s, const char *const *extra, size_t extra_count, const char *image, int progress,
                               rtk_render_report *report, rtk_image *out, double *cpu_s)
{
    rtk_config *cfg = NULL;
    rtk_status st = load_config(s, extra, extra_count, &cfg);
    if (st != RTK_OK)
        return st;
    rtk_render_options ro;
    memset(&ro, 0, sizeof ro);
    ro.size = sizeof ro;
    ro.progress = progress;
    ro.quiet = !progress;
    memset(report, 0, sizeof *report);
    report->size = sizeof *report;
    double c0 = cpu_now();
    st = rtk_render(cfg, &ro, report);
    *cpu_s = cpu_now() - c0;
    rtk_config_destroy(cfg);
    if (st == RTK_OK)
        st = rtk_image_read(image, NULL, 0, 1, out);
    return st;
}

/* Basename of a path. */
static const char *base_name(const char *path)
{
    const char *slash = strrchr(path, '/');
    return slash ? slash + 1 : path;
}

/* Axis values' indices of combination c (first axis slowest). */
static void combo_indices(const sweep *s, size_t c, size_t *idx)
{
    for (size_t a = s->o.axis_count; a-- > 0;) {
        idx[a] = c % s->o.axes[a].value_count;
        c /= s->o.axes[a].value_count;
    }
}

/* Appends text to buf (size) after its current contents, truncating. */
static void append(char *buf, size_t size, const char *sep, const char *text)
{
    size_t len = strlen(buf);
    if (len + 1 < size)
        snprintf(buf + len, size - len, "%s%s", len ? sep : "", text);
}

/* Checks each axis value alone, then builds and checks every combination. */
static rtk_status make_combos(sweep *s)
{
    size_t count = 1;
    for (size_t a = 0; a < s->o.axis_count; a++) {
        const rtk_sweep_axis *ax = &s->o.axes[a];
        const char *origin = ax->origin ? ax->origin : ax->key;
        if (!ax->key || !ax->key[0] || strchr(ax->key, '='))
            return rtk_error(RTK_ERR_INVALID, "%s: an axis needs a setting name like integrator.rays",
                             origin ? origin : "sweep");
        if (ax->value_count == 0 || !ax->values)
            return rtk_error(RTK_ERR_INVALID, "%s: no values given", origin);
        if (strcmp(ax->key, "film.spp") == 0 || strcmp(ax->key, "sampler.seed") == 0 ||
            strcmp(ax->key, "film.output") == 0)
            return rtk_error(RTK_ERR_INVALID, "%s: %s is set by the sweep itself (use --spp, --seeds)", origin,
                             ax->key);
        if (count > 100000 / ax->value_count)
            return rtk_error(RTK_ERR_INVALID, "too many combinations (more than 100000)");
        count *= ax->value_count;
        for (size_t v = 0; v < ax->value_count; v++) {
            const char *value = ax->values[v] ? ax->values[v] : "";
            if (!value[0])
                return rtk_error(RTK_ERR_INVALID, "%s: empty value", origin);
            char *set = format("%s=%s", ax->key, value);
            if (!set)
                return RTK_ERR_NOMEM;
            rtk_config *cfg = NULL;
            const char *one = set;
            rtk_status st = load_config(s, &one, 1, &cfg);
            rtk_config_destroy(cfg);
            free(set);
            if (st != RTK_OK)
                return with_context(st, "%s value '%s'", origin, value);
        }
    }
    s->combos = rtk_calloc(count, sizeof *s->combos);
    if (!s->combos)
        return RTK_ERR_NOMEM;
    s->combo_count = count;
    size_t idx[64];
    for (size_t c = 0; c < count; c++) {
        sweep_combo *cb = &s->combos[c];
        combo_indices(s, c, idx);
        cb->sets = rtk_calloc(s->o.axis_count ? s->o.axis_count : 1, sizeof *cb->sets);
        if (!cb->sets)
            return RTK_ERR_NOMEM;
        cb->colour = s->o.axis_count > 0 ? (uint32_t)idx[0] : 0;
        cb->style = s->o.axis_count > 1 ? (uint32_t)idx[1] : 0;
        for (size_t a = 0; a < s->o.axis_count; a++) {
            const rtk_sweep_axis *ax = &s->o.axes[a];
            const char *value = ax->values[idx[a]];
            if (!(cb->sets[a] = format("%s=%s", ax->key, value)))
                return RTK_ERR_NOMEM;
            int named = strcmp(ax->key, "sampler.type") == 0 || strcmp(ax->key, "filter.plugin") == 0 ||
                        strcmp(ax->key, "accelerator.plugin") == 0 || strcmp(ax->key, "integrator.plugin") == 0;
            if (named) {
                append(cb->label, sizeof cb->label, " ", value);
            } else {
                const char *dot = strrchr(ax->key, '.');
                char item[256];
                snprintf(item, sizeof item, "%s=%s", dot ? dot + 1 : ax->key, value);
                append(cb->label, sizeof cb->label, " ", item);
                append(cb->params, sizeof cb->params, ";", cb->sets[a]);
            }
        }
        rtk_config *cfg = NULL;
        rtk_status st = load_config(s, (const char *const *)cb->sets, s->o.axis_count, &cfg);
        if (st != RTK_OK)
            return with_context(st, "combination '%s'", cb->label[0] ? cb->label : "(the config)");
        if (!cb->label[0])
            snprintf(cb->label, sizeof cb->label, "%s %s", cfg->sampler_type, cfg->filter.plugin->name);
        snprintf(cb->scene, sizeof cb->scene, "%s", base_name(cfg->scene_path));
        snprintf(cb->integrator, sizeof cb->integrator, "%s", cfg->integrator.plugin->name);
        snprintf(cb->sampler, sizeof cb->sampler, "%s", cfg->sampler_type);
        snprintf(cb->accelerator, sizeof cb->accelerator, "%s", cfg->accelerator.plugin->name);
        snprintf(cb->filter, sizeof cb->filter, "%s", cfg->filter.plugin->name);
        cb->width = cfg->width;
        cb->height = cfg->height;
        rtk_config_destroy(cfg);
    }
    return RTK_OK;
}

/* The overrides that make combination c's reference (without film.output);
 * *n of them, pointing into sets and bufs. */
static size_t reference_sets(const sweep *s, const sweep_combo *cb, const char **sets, char bufs[3][64], int same)
{
    size_t n = 0;
    for (size_t a = 0; a < s->o.axis_count; a++) {
        const char *key = s->o.axes[a].key;
        if (!under(key, "sampler") && !under(key, "accelerator") && !under(key, "filter"))
            sets[n++] = cb->sets[a];
    }
    snprintf(bufs[0], 64, "film.spp=%u", s->o.reference_spp);
    snprintf(bufs[1], 64, "sampler.seed=%u", SWEEP_REFERENCE_SEED);
    sets[n++] = "sampler.type=independent";
    sets[n++] = bufs[0];
    sets[n++] = bufs[1];
    /* The filter last, so that "same" with filter.plugin=box hashes as
     * the default box reference and finds it in the cache. */
    if (!same) {
        snprintf(bufs[2], 64, "filter.plugin=%.48s", s->o.reference_filter);
        sets[n++] = bufs[2];
    }
    for (size_t a = 0; same && a < s->o.axis_count; a++)
        if (under(s->o.axes[a].key, "filter"))
            sets[n++] = cb->sets[a];
    return n;
}

/* Hash of what makes a reference: the config text, the base overrides,
 * the reference's overrides, and the scene file's size and time. */
static uint64_t reference_hash(const sweep *s, const char *const *sets, size_t n)
{
    static const char tag[] = "rtk sweep reference 1";
    uint64_t h = rtk_hash64(tag, sizeof tag, 0);
    h = rtk_hash64(s->config_text, s->config_len, h);
    for (size_t i = 0; i < s->o.override_count; i++)
        h = rtk_hash64(s->o.overrides[i], strlen(s->o.overrides[i]) + 1, h);
    h = rtk_hash64("|", 1, h);
    for (size_t i = 0; i < n; i++)
        h = rtk_hash64(sets[i], strlen(sets[i]) + 1, h);
    rtk_config *cfg = NULL;
    if (load_config((sweep *)s, sets, n, &cfg) == RTK_OK) {
        struct stat sb;
        if (stat(cfg->scene_path, &sb) == 0) {
            int64_t stamp[3] = {(int64_t)sb.st_size, (int64_t)sb.st_mtim.tv_sec, (int64_t)sb.st_mtim.tv_nsec};
            h = rtk_hash64(stamp, sizeof stamp, h);
        }
    }
    rtk_config_destroy(cfg);
    return h;
}

/* Checks that img fits combination cb. */
static rtk_status check_size(const sweep_ref *ref, const sweep_combo *cb)
{
    if ((uint32_t)ref->image.width == cb->width && (uint32_t)ref->image.height == cb->height)
        return RTK_OK;
    return rtk_error(RTK_ERR_INVALID, "reference %s is %dx%d, but combination '%s' renders %ux%u", ref->path,
                     ref->image.width, ref->image.height, cb->label, cb->width, cb->height);
}

/* Finds or renders the reference of every combination. */
static rtk_status make_references(sweep *s, FILE *out)
{
    s->refs = rtk_calloc(s->combo_count, sizeof *s->refs);
    if (!s->refs)
        return RTK_ERR_NOMEM;
    if (s->o.reference) {
        sweep_ref *r = &s->refs[0];
        s->ref_count = 1;
        if (!(r->path = rtk_strdup(s->o.reference)))
            return RTK_ERR_NOMEM;
        snprintf(r->filter, sizeof r->filter, "given");
        rtk_status st = rtk_image_read(r->path, NULL, 0, 1, &r->image);
        if (st != RTK_OK)
            return with_context(st, "reference %s", r->path);
        for (size_t c = 0; c < s->combo_count; c++)
            if ((st = check_size(r, &s->combos[c])) != RTK_OK)
                return st;
        if (out)
            fprintf(out, "reference  %s (given)\n", r->path);
        return RTK_OK;
    }
    int same = strcmp(s->o.reference_filter, "same") == 0;
    for (size_t c = 0; c < s->combo_count; c++) {
        sweep_combo *cb = &s->combos[c];
        const char *sets[80];
        char bufs[3][64];
        size_t n = reference_sets(s, cb, sets, bufs, same);
        uint64_t h = reference_hash(s, sets, n);
        size_t r = 0;
        while (r < s->ref_count && s->refs[r].hash != h)
            r++;
        cb->ref = r;
        if (r < s->ref_count)
            continue;
        sweep_ref *ref = &s->refs[s->ref_count++];
        ref->hash = h;
        snprintf(ref->filter, sizeof ref->filter, "%s", same ? cb->filter : s->o.reference_filter);
        if (!(ref->path = format("%s/reference-%016llx.exr", s->dir, (unsigned long long)h)))
            return RTK_ERR_NOMEM;
        rtk_status st;
        if (access(ref->path, F_OK) == 0) {
            st = rtk_image_read(ref->path, NULL, 0, 1, &ref->image);
            if (st != RTK_OK)
                return with_context(st, "cached reference %s (delete it to render it again)", ref->path);
            if ((st = check_size(ref, cb)) != RTK_OK)
                return st;
            if (out)
                fprintf(out, "reference  %s (cached, reused)\n", ref->path);
            continue;
        }
        char *output = format("film.output=%s", ref->path);
        if (!output)
            return RTK_ERR_NOMEM;
        sets[n++] = output;
        if (s->o.progress)
            fprintf(stderr, "reference %s: %u spp, independent sampler, %s filter\n", base_name(ref->path),
                    s->o.reference_spp, ref->filter);
        rtk_render_report report;
        double cpu_s;
        st = render_image(s, sets, n, ref->path, s->o.progress, &report, &ref->image, &cpu_s);
        free(output);
        if (st != RTK_OK)
            return with_context(st, "reference for '%s'", cb->label);
        if (out)
            fprintf(out, "reference  %s (rendered: %u spp, independent sampler, %s filter, seed %u, %.1f s)\n",
                    ref->path, s->o.reference_spp, ref->filter, SWEEP_REFERENCE_SEED, report.render_seconds);
    }
    return RTK_OK;
}

/* The progress line on stderr, weighted by spp: the run about to start. */
static void draw_progress(sweep *s, const sweep_combo *cb, uint32_t spp, uint32_t seed)
{
    if (!s->o.progress)
        return;
    int width = 30;
    double frac = s->work_total ? (double)s->work_done / (double)s->work_total : 1.0;
    char bar[64];
    for (int i = 0; i < width; i++)
        bar[i] = i < (int)(frac * width) ? '#' : '.';
    bar[width] = '\0';
    double elapsed = rtk_now() - s->t0;
    double left = frac > 0.0 ? elapsed * (1.0 - frac) / frac : 0.0;
    fprintf(stderr, "\r\033[Ksweep [%s] %3d%%  run %zu/%zu: %.60s, spp %u, seed %u  %.0f s, %.0f s left", bar,
            (int)(frac * 100.0), s->runs_done + 1, s->run_count, cb->label, spp, seed, elapsed, left);
    fflush(stderr);
}

/* One run: render, read back, remove, compare. */
static rtk_status run_one(sweep *s, const sweep_combo *cb, uint32_t spp, uint32_t seed, sweep_run *run)
{
    const char *sets[80];
    size_t n = 0;
    for (size_t a = 0; a < s->o.axis_count; a++)
        sets[n++] = cb->sets[a];
    char spp_set[64], seed_set[64];
    snprintf(spp_set, sizeof spp_set, "film.spp=%u", spp);
    snprintf(seed_set, sizeof seed_set, "sampler.seed=%u", seed);
    sets[n++] = spp_set;
    sets[n++] = seed_set;
    rtk_render_report report;
    rtk_image img;
    memset(&img, 0, sizeof img);
    double cpu_s = 0.0;
    rtk_status st = render_image(s, sets, n, s->run_output, 0, &report, &img, &cpu_s);
    remove(s->run_output);
    const sweep_ref *ref = &s->refs[cb->ref];
    if (st == RTK_OK && (img.width != ref->image.width || img.height != ref->image.height))
        st = rtk_error(RTK_ERR_INVALID, "the render is %dx%d but reference %s is %dx%d", img.width, img.height,
                       ref->path, ref->image.width, ref->image.height);
    rtk_diff_result d;
    memset(&d, 0, sizeof d);
    d.size = sizeof d;
    if (st == RTK_OK) {
        rtk_diff_options dopt;
        memset(&dopt, 0, sizeof dopt);
        dopt.size = sizeof dopt;
        dopt.colour_channels = 3;
        st = rtk_diff_buffers(img.rgba, ref->image.rgba, (uint32_t)img.width, (uint32_t)img.height, 4, NULL, &dopt,
                              &d);
    }
    free(img.rgba);
    if (st != RTK_OK) {
        return with_context(st, "combination '%s', spp %u, seed %u", cb->label, spp, seed);
    }
    run->spp = spp;
    run->seed = seed;
    run->threads = report.threads;
    run->load_s = report.load_seconds;
    run->build_s = report.build_seconds;
    run->render_s = report.render_seconds;
    run->cpu_s = cpu_s;
    run->rays = report.rays;
    run->bad_samples = report.bad_samples;
    run->excluded = d.overall.excluded;
    run->rmse = d.overall.rmse;
    run->relmse = d.overall.relmse;
    run->mape = d.overall.mape;
    return RTK_OK;
}

/* Means over seeds, slopes and times to the target. */
static rtk_status summarise(sweep *s)
{
    size_t ns = s->o.spp_count;
    s->points = rtk_calloc(s->combo_count * ns, sizeof *s->points);
    s->fits = rtk_calloc(s->combo_count, sizeof *s->fits);
    double *x = rtk_calloc(ns, sizeof *x), *y = rtk_calloc(ns, sizeof *y), *t = rtk_calloc(ns, sizeof *t);
    if (!s->points || !s->fits || !x || !y || !t) {
        free(x);
        free(y);
        free(t);
        return RTK_ERR_NOMEM;
    }
    size_t first = ns / 2;
    for (size_t c = 0; c < s->combo_count; c++) {
        sweep_point *p = &s->points[c * ns];
        for (size_t k = 0; k < ns; k++) {
            const sweep_run *r = &s->runs[(c * ns + k) * s->o.seeds];
            p[k].spp = s->o.spp[k];
            for (uint32_t j = 0; j < s->o.seeds; j++) {
                p[k].render_s += r[j].render_s / s->o.seeds;
                p[k].build_s += r[j].build_s / s->o.seeds;
                p[k].rmse += r[j].rmse / s->o.seeds;
                p[k].relmse += r[j].relmse / s->o.seeds;
                p[k].mape += r[j].mape / s->o.seeds;
            }
            x[k] = p[k].spp;
            t[k] = p[k].render_s;
        }
        sweep_fit *f = &s->fits[c];
        f->rmse_slope = f->relmse_slope = NAN;
        for (size_t k = 0; k < ns; k++)
            y[k] = p[k].rmse;
        if (ns - first >= 2 && rtk_sweep_fit_slope(x + first, y + first, ns - first, &f->rmse_slope) != RTK_OK)
            f->rmse_slope = NAN;
        for (size_t k = 0; k < ns; k++)
            y[k] = p[k].relmse;
        if (ns - first >= 2 && rtk_sweep_fit_slope(x + first, y + first, ns - first, &f->relmse_slope) != RTK_OK)
            f->relmse_slope = NAN;
        f->reach = rtk_sweep_time_to_error(t, y, ns, s->o.target_relmse, &f->seconds);
    }
    free(x);
    free(y);
    free(t);
    return RTK_OK;
}

/* Writes a CSV field, quoted when it holds a comma, quote or newline. */
static void csv_field(FILE *f, const char *v)
{
    if (!strpbrk(v, ",\"\n\r")) {
        fputs(v, f);
        return;
    }
    fputc('"', f);
    for (; *v; v++) {
        if (*v == '"')
            fputc('"', f);
        fputc(*v, f);
    }
    fputc('"', f);
}

/* sweep.csv: one row per run (columns in README.md). */
static rtk_status write_csv(sweep *s, const char *path)
{
    rtk_out_file af;
    rtk_status st = rtk_out_open(&af, path);
    if (st != RTK_OK)
        return st;
    FILE *f = af.f;
    fputs("scene,integrator,sampler,accelerator,filter,params,spp,seed,threads,build_s,render_s,rays,mrays_per_s,"
          "rmse,relmse,mape,nan_count,excluded,load_s,cpu_s,combination\n",
          f);
    for (size_t i = 0; i < s->run_count; i++) {
        const sweep_run *r = &s->runs[i];
        const sweep_combo *cb = &s->combos[i / (s->o.spp_count * s->o.seeds)];
        const char *text[] = {cb->scene, cb->integrator, cb->sampler, cb->accelerator, cb->filter, cb->params};
        for (size_t k = 0; k < sizeof text / sizeof text[0]; k++) {
            csv_field(f, text[k]);
            fputc(',', f);
        }
        double mrays = r->render_s > 0.0 ? (double)r->rays / r->render_s * 1e-6 : 0.0;
        fprintf(f, "%u,%u,%u,%.6g,%.6g,%llu,%.6g,%.9g,%.9g,%.9g,%llu,%llu,%.6g,%.6g,", r->spp, r->seed, r->threads,
                r->build_s, r->render_s, (unsigned long long)r->rays, mrays, r->rmse, r->relmse, r->mape,
                (unsigned long long)r->bad_samples, (unsigned long long)r->excluded, r->load_s, r->cpu_s);
        csv_field(f, cb->label);
        fputc('\n', f);
    }
    return rtk_out_close(&af, 1);
}

/* The time to the target as the table shows it. */
static void format_time(const sweep_fit *f, char *buf, size_t size)
{
    switch (f->reach) {
    case RTK_SWEEP_REACHED:
        snprintf(buf, size, "%.4g s", f->seconds);
        break;
    case RTK_SWEEP_AT_FIRST:
        snprintf(buf, size, "<= %.4g s", f->seconds);
        break;
    case RTK_SWEEP_NOT_REACHED:
        snprintf(buf, size, "not reached");
        break;
    default:
        snprintf(buf, size, "no data");
        break;
    }
}

/* The table, into f. */
static void write_table(const sweep *s, FILE *f)
{
    size_t ns = s->o.spp_count;
    size_t first = ns / 2;
    const sweep_combo *c0 = &s->combos[0];
    fprintf(f, "sweep      %s: %s, %s, %ux%u; %zu combination%s x %zu spp x %u seed%s = %zu runs\n", s->path,
            c0->scene, c0->integrator, c0->width, c0->height, s->combo_count, s->combo_count == 1 ? "" : "s", ns,
            s->o.seeds, s->o.seeds == 1 ? "" : "s", s->run_count);
    if (ns - first >= 2)
        fprintf(f, "slopes     least squares of log(mean RMSE), log(mean relMSE) against log(spp), spp %u..%u\n",
                s->o.spp[first], s->o.spp[ns - 1]);
    else
        fprintf(f, "slopes     not fitted: fewer than 2 spp values in the upper half (give 4 or more spp values)\n");
    fprintf(f, "time       render seconds to mean relMSE %g (means over seeds, log-log interpolated between spp;\n"
               "           build excluded, its mean shown); ratio = time / the first row's time\n",
            s->o.target_relmse);
    int w = 11;
    for (size_t c = 0; c < s->combo_count; c++) {
        int len = (int)strlen(s->combos[c].label);
        w = len > w ? len : w;
    }
    char target[32], at_max[32];
    snprintf(target, sizeof target, "time to %g", s->o.target_relmse);
    snprintf(at_max, sizeof at_max, "relMSE@%u", s->o.spp[ns - 1]);
    fprintf(f, "\n%-*s  %10s  %12s  %11s  %9s  %15s  %6s\n", w, "combination", "RMSE slope", "relMSE slope", at_max,
            "build s", target, "ratio");
    const sweep_fit *f0 = &s->fits[0];
    for (size_t c = 0; c < s->combo_count; c++) {
        const sweep_fit *fc = &s->fits[c];
        const sweep_point *last = &s->points[c * ns + ns - 1];
        char time[48], ratio[32] = "-";
        format_time(fc, time, sizeof time);
        if (fc->reach == RTK_SWEEP_REACHED && f0->reach == RTK_SWEEP_REACHED)
            snprintf(ratio, sizeof ratio, "%.2f", fc->seconds / f0->seconds);
        fprintf(f, "%-*s  %10.3f  %12.3f  %11.3e  %9.3g  %15s  %6s\n", w, s->combos[c].label, fc->rmse_slope,
                fc->relmse_slope, last->relmse, last->build_s, time, ratio);
    }
}

/* Writes text between single quotes for gnuplot ('' is a quote). */
static void gp_string(FILE *f, const char *v)
{
    fputc('\'', f);
    for (; *v; v++) {
        if (*v == '\'')
            fputc('\'', f);
        fputc(*v, f);
    }
    fputc('\'', f);
}

/* sweep.dat: per combination a block of means per spp, for gnuplot. */
static rtk_status write_data(const sweep *s, const char *path)
{
    rtk_out_file af;
    rtk_status st = rtk_out_open(&af, path);
    if (st != RTK_OK)
        return st;
    FILE *f = af.f;
    size_t ns = s->o.spp_count;
    fprintf(f, "# rtk sweep %s: means over %u seeds; one block (gnuplot index) per combination\n", s->path,
            s->o.seeds);
    for (size_t c = 0; c < s->combo_count; c++) {
        fprintf(f, "%s# %s\n# spp render_s build_s rmse relmse mape\n", c ? "\n\n" : "", s->combos[c].label);
        for (size_t k = 0; k < ns; k++) {
            const sweep_point *p = &s->points[c * ns + k];
            fprintf(f, "%g %.9g %.9g %.9g %.9g %.9g\n", p->spp, p->render_s, p->build_s, p->rmse, p->relmse, p->mape);
        }
    }
    return rtk_out_close(&af, 1);
}

/* One plot command over every combination: columns x:y of sweep.dat. */
static void gp_plot(const sweep *s, FILE *f, int x, int y)
{
    static const int points[] = {7, 5, 9, 11, 13, 15, 4, 6, 8, 10};
    fputs("plot ", f);
    for (size_t c = 0; c < s->combo_count; c++) {
        const sweep_combo *cb = &s->combos[c];
        fprintf(f, "%s'sweep.dat' index %zu using %d:%d with linespoints lw 1.5 lc %u pt %d dt %u title ",
                c ? ", \\\n     " : "", c, x, y, cb->colour + 1, points[cb->style % 10], cb->style % 5 + 1);
        gp_string(f, cb->label);
    }
}

/* sweep.gp: both panels, run from the output directory. */
static rtk_status write_script(const sweep *s, const char *path)
{
    rtk_out_file af;
    rtk_status st = rtk_out_open(&af, path);
    if (st != RTK_OK)
        return st;
    FILE *f = af.f;
    const sweep_combo *c0 = &s->combos[0];
    char title[1024];
    snprintf(title, sizeof title, "%s: %s, %s, %ux%u, means of %u seeds", base_name(s->path), c0->scene,
             c0->integrator, c0->width, c0->height, s->o.seeds);
    fputs("# rtk sweep: draws sweep.png from sweep.dat. Run it in this directory: gnuplot sweep.gp\n"
          "if (!exists('outfile')) outfile = 'sweep.png'\n"
          "set terminal pngcairo size 1400,600 font ',10'\n"
          "set output outfile\n"
          "set multiplot layout 1,2 title ",
          f);
    gp_string(f, title);
    fputs("\nset logscale xy\nset grid\nset key bottom left font ',8' spacing 0.9\n"
          "set format x '10^{%L}'\nset format y '10^{%L}'\n",
          f);
    fprintf(f, "set xlabel 'render seconds (build excluded)'\nset ylabel 'relMSE'\n"
               "set title 'relMSE against render time; dashed: target %g'\n",
            s->o.target_relmse);
    gp_plot(s, f, 2, 5);
    fprintf(f, ", \\\n     %g with lines lc 'black' dt 2 notitle\n", s->o.target_relmse);
    fputs("set xlabel 'samples per pixel'\nset ylabel 'RMSE'\n"
          "set title 'RMSE against spp; grey: slopes -1/2, -3/4, -1'\nset logscale x 2\nset format x '%g'\n",
          f);
    gp_plot(s, f, 1, 4);
    /* Guides through the first combination's point at the smallest spp. */
    const sweep_point *p0 = &s->points[0];
    static const double slopes[3] = {-0.5, -0.75, -1.0};
    static const char *const names[3] = {"-1/2", "-3/4", "-1"};
    for (int g = 0; g < 3; g++)
        fprintf(f, ", \\\n     %.9g * (x / %g) ** (%g) with lines lc 'gray50' dt %d title 'slope %s'", p0->rmse,
                p0->spp, slopes[g], g + 2, names[g]);
    fputs("\nunset multiplot\n", f);
    return rtk_out_close(&af, 1);
}

/* Runs gnuplot on the script; *missing = 1 when it is not installed. */
static rtk_status run_gnuplot(const sweep *s, const char *script, const char *png, int *missing)
{
    *missing = 0;
    char *tmp = format("%s/sweep.tmp.png", s->dir);
    char *dir_q = NULL;
    if (!tmp)
        return RTK_ERR_NOMEM;
    int slot = rtk_temp_register(tmp); /* SIGINT/SIGTERM remove it (output.h) */
    /* gnuplot -e "cd '<dir>'; outfile = 'sweep.tmp.png'" <dir>/sweep.gp */
    size_t len = strlen(s->dir) * 2 + 64;
    dir_q = rtk_alloc(len);
    if (!dir_q) {
        free(tmp);
        return RTK_ERR_NOMEM;
    }
    size_t k = 0;
    k += (size_t)snprintf(dir_q, len, "cd '");
    for (const char *p = s->dir; *p; p++) {
        if (*p == '\'')
            dir_q[k++] = '\'';
        dir_q[k++] = *p;
    }
    snprintf(dir_q + k, len - k, "'; outfile = 'sweep.tmp.png'");
    char *argv[] = {"gnuplot", "-e", dir_q, (char *)script, NULL};
    pid_t pid;
    int err = posix_spawnp(&pid, "gnuplot", NULL, NULL, argv, environ);
    rtk_status st = RTK_OK;
    if (err == ENOENT) {
        *missing = 1;
    } else if (err != 0) {
        st = rtk_error(RTK_ERR_IO, "cannot run gnuplot: %s", strerror(err));
    } else {
        int status = 0;
        while (waitpid(pid, &status, 0) < 0 && errno == EINTR)
            ;
        struct stat sb;
        if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
            st = rtk_error(RTK_ERR_IO, "gnuplot %s failed (exit status %d): %s not written", script,
                           WIFEXITED(status) ? WEXITSTATUS(status) : -1, png);
        else if (stat(tmp, &sb) != 0 || sb.st_size == 0)
            st = rtk_error(RTK_ERR_IO, "gnuplot %s wrote no image: %s not written", script, png);
        else if (rename(tmp, png) != 0)
            st = rtk_error(RTK_ERR_IO, "cannot write %s: %s", png, strerror(errno));
    }
    remove(tmp);
    rtk_temp_unregister(slot);
    free(tmp);
    free(dir_q);
    return st;
}

/* CSV, table, plot data and script, and the plot. */
static rtk_status write_outputs(sweep *s, FILE *out)
{
    char *csv = format("%s/sweep.csv", s->dir), *txt = format("%s/sweep.txt", s->dir);
    char *dat = format("%s/sweep.dat", s->dir), *gp = format("%s/sweep.gp", s->dir);
    char *png = format("%s/sweep.png", s->dir);
    rtk_status st = csv && txt && dat && gp && png ? RTK_OK : RTK_ERR_NOMEM;
    if (st == RTK_OK)
        st = write_csv(s, csv);
    rtk_out_file af;
    if (st == RTK_OK && (st = rtk_out_open(&af, txt)) == RTK_OK) {
        write_table(s, af.f);
        st = rtk_out_close(&af, 1);
    }
    if (st == RTK_OK)
        st = write_data(s, dat);
    if (st == RTK_OK)
        st = write_script(s, gp);
    if (st == RTK_OK && out) {
        write_table(s, out);
        fprintf(out, "\ncsv        %s (%zu rows)\ntable      %s\n", csv, s->runs_done, txt);
    }
    int missing = 0;
    if (st == RTK_OK && s->o.plot >= 0)
        st = run_gnuplot(s, gp, png, &missing);
    if (st == RTK_OK && (missing || s->o.plot < 0)) {
        /* An older plot would not match this CSV. */
        remove(png);
        if (missing && s->o.plot > 0)
            st = rtk_error(RTK_ERR_UNSUPPORTED,
                           "gnuplot not found on PATH, so %s was not drawn: install it (Debian: apt-get install "
                           "gnuplot-nox), then run: cd %s && gnuplot sweep.gp",
                           png, s->dir);
        else if (out)
            fprintf(out, "plot       not drawn (%s); to draw it: cd %s && gnuplot sweep.gp\n",
                    missing ? "gnuplot not found; Debian: apt-get install gnuplot-nox" : "asked for none", s->dir);
    } else if (st == RTK_OK && out) {
        fprintf(out, "plot       %s (script %s, data %s)\n", png, gp, dat);
    }
    free(csv);
    free(txt);
    free(dat);
    free(gp);
    free(png);
    return st;
}

/* Copies the caller's options (of options->size bytes), fills defaults and checks them. */
static rtk_status read_options(sweep *s, const rtk_sweep_options *options)
{
    if (options) {
        size_t size = options->size ? options->size : sizeof s->o;
        memcpy(&s->o, options, size < sizeof s->o ? size : sizeof s->o);
    }
    s->o.size = sizeof s->o;
    if (!s->o.spp || s->o.spp_count == 0) {
        for (uint32_t k = 0; k < 7; k++)
            s->default_spp[k] = 1u << k;
        s->o.spp = s->default_spp;
        s->o.spp_count = 7;
    }
    for (size_t k = 0; k < s->o.spp_count; k++) {
        if (s->o.spp[k] < 1 || s->o.spp[k] > SWEEP_MAX_SPP)
            return rtk_error(RTK_ERR_INVALID, "spp %u: give values in [1, %u]", s->o.spp[k], SWEEP_MAX_SPP);
        if (k > 0 && s->o.spp[k] <= s->o.spp[k - 1])
            return rtk_error(RTK_ERR_INVALID, "spp values must increase: %u after %u", s->o.spp[k], s->o.spp[k - 1]);
    }
    if (s->o.seeds == 0)
        s->o.seeds = 4;
    if (s->o.seeds > SWEEP_MAX_SEEDS)
        return rtk_error(RTK_ERR_INVALID, "%u seeds: at most %u", s->o.seeds, SWEEP_MAX_SEEDS);
    if (s->o.target_relmse == 0.0)
        s->o.target_relmse = 1e-3;
    if (!(s->o.target_relmse > 0.0 && isfinite(s->o.target_relmse)))
        return rtk_error(RTK_ERR_INVALID, "target relMSE %g: give a finite number > 0", s->o.target_relmse);
    if (s->o.axis_count > 64)
        return rtk_error(RTK_ERR_INVALID, "%zu axes: at most 64", s->o.axis_count);
    if (s->o.axis_count && !s->o.axes)
        return rtk_error(RTK_ERR_INVALID, "rtk_sweep: axis_count %zu but no axes", s->o.axis_count);
    if (s->o.override_count && !s->o.overrides)
        return rtk_error(RTK_ERR_INVALID, "rtk_sweep: override_count %zu but no overrides", s->o.override_count);
    if (!s->o.out_dir || !s->o.out_dir[0])
        s->o.out_dir = "sweep";
    if (!s->o.reference_filter || !s->o.reference_filter[0])
        s->o.reference_filter = "box";
    if (strlen(s->o.reference_filter) > 48)
        return rtk_error(RTK_ERR_INVALID, "reference filter '%.64s...': name too long", s->o.reference_filter);
    uint32_t largest = s->o.spp[s->o.spp_count - 1];
    if (s->o.reference_spp == 0) {
        uint64_t r = (uint64_t)largest * 64;
        s->o.reference_spp = (uint32_t)(r < 4096 ? 4096 : (r > 65536 ? 65536 : r));
    }
    if (s->o.reference_spp > SWEEP_MAX_SPP)
        return rtk_error(RTK_ERR_INVALID, "reference spp %u: at most %u", s->o.reference_spp, SWEEP_MAX_SPP);
    if (!s->o.reference && s->o.reference_spp <= largest)
        rtk_log(RTK_LOG_WARN, "the reference's %u spp is not above the largest swept spp (%u): the errors measure "
                              "the reference's noise as much as the runs'",
                s->o.reference_spp, largest);
    return RTK_OK;
}

/* Frees everything, removing the run image if one is left. */
static void sweep_free(sweep *s)
{
    free(s->dir);
    free(s->config_text);
    if (s->run_output)
        remove(s->run_output);
    rtk_temp_unregister_path(s->run_output);
    free(s->run_output);
    for (size_t i = 0; i < s->fixed_count; i++)
        free(s->fixed[i]);
    for (size_t c = 0; s->combos && c < s->combo_count; c++) {
        for (size_t a = 0; s->combos[c].sets && a < s->o.axis_count; a++)
            free(s->combos[c].sets[a]);
        free(s->combos[c].sets);
    }
    free(s->combos);
    for (size_t r = 0; s->refs && r < s->ref_count; r++) {
        free(s->refs[r].path);
        free(s->refs[r].image.rgba);
    }
    free(s->refs);
    free(s->runs);
    free(s->points);
    free(s->fits);
}

rtk_status rtk_sweep(const char *path, rtk_registry *registry, const rtk_sweep_options *options, FILE *out)
{
    if (!path || !path[0])
        return rtk_error(RTK_ERR_INVALID, "no config file given");
    if (!registry)
        return rtk_error(RTK_ERR_INVALID, "%s: no plugin registry to resolve plugins with", path);
    sweep s;
    memset(&s, 0, sizeof s);
    s.path = path;
    s.registry = registry;
    rtk_status st = read_options(&s, options);
    if (st == RTK_OK)
        st = read_text(path, &s.config_text, &s.config_len);
    if (st == RTK_OK)
        st = make_dirs(s.o.out_dir);
    if (st == RTK_OK && !(s.dir = realpath(s.o.out_dir, NULL)))
        st = rtk_error(RTK_ERR_IO, "cannot use output directory %s: %s", s.o.out_dir, strerror(errno));
    if (st == RTK_OK && !(s.run_output = format("%s/.sweep-run-%ld.exr", s.dir, (long)getpid())))
        st = RTK_ERR_NOMEM;
    if (st == RTK_OK)
        rtk_temp_register(s.run_output); /* SIGINT/SIGTERM remove it (output.h) */
    if (st == RTK_OK && (!(s.fixed[s.fixed_count++] = format("film.output=%s", s.run_output)) ||
                         !(s.fixed[s.fixed_count++] = format("film.half=false")) ||
                         (!s.o.bvh_cache && !(s.fixed[s.fixed_count++] = format("cache=off"))) ||
                         (s.o.threads && !(s.fixed[s.fixed_count++] = format("threads=%u", s.o.threads)))))
        st = RTK_ERR_NOMEM;
    if (st == RTK_OK)
        st = make_combos(&s);
    if (st == RTK_OK) {
        s.run_count = s.combo_count * s.o.spp_count * s.o.seeds;
        if (!(s.runs = rtk_calloc(s.run_count, sizeof *s.runs)))
            st = RTK_ERR_NOMEM;
    }
    if (st == RTK_OK)
        st = make_references(&s, out);
    s.t0 = rtk_now();
    for (size_t k = 0; k < s.o.spp_count; k++)
        s.work_total += (uint64_t)s.o.spp[k] * s.o.seeds * s.combo_count;
    /* Combinations innermost, so that a machine busy with other work
     * slows every combination alike rather than the ones run then. */
    for (size_t k = 0; st == RTK_OK && k < s.o.spp_count; k++)
        for (uint32_t j = 1; st == RTK_OK && j <= s.o.seeds; j++)
            for (size_t c = 0; st == RTK_OK && c < s.combo_count; c++) {
                draw_progress(&s, &s.combos[c], s.o.spp[k], j);
                st = run_one(&s, &s.combos[c], s.o.spp[k], j, &s.runs[(c * s.o.spp_count + k) * s.o.seeds + j - 1]);
                if (st == RTK_OK) {
                    s.runs_done++;
                    s.work_done += s.o.spp[k];
                }
            }
    if (s.o.progress && s.run_count)
        fputs("\r\033[K", stderr);
    if (st == RTK_OK)
        st = summarise(&s);
    if (st == RTK_OK)
        st = write_outputs(&s, out);
    sweep_free(&s);
    return st;
}

/* rtk: the command-line front end. render, plugins, conform, bench, diff, sweep. */
#include <rtk/host.h>

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static const char usage_text[] =
    "usage: rtk render CONFIG [options]   render the scene a config describes\n"
    "       rtk plugins [NAME]            list plugins, or show one plugin's parameters\n"
    "       rtk conform PLUGIN            run the conformance checks on a plugin (.so path or name)\n"
    "       rtk bench MESH.obj|CONFIG.cfg [options]\n"
    "                                     time accelerators on BENCH.md's standard recipe\n"
    "       rtk diff A B [options]        compare image A with the reference B (any format\n"
    "                                     OpenImageIO reads): RMSE, MSE, relMSE, MAPE, SMAPE,\n"
    "                                     PSNR and mean error A - B per channel and overall\n"
    "       rtk sweep CONFIG [options]    speed against error: render every combination of the\n"
    "                                     axes at each spp and seed, compare with a reference,\n"
    "                                     write CSV, table and plot (see sweep options)\n"
    "\n"
    "render options:\n"
    "  --set KEY=VALUE          override a config setting, e.g. --set integrator.rays=64\n"
    "  -o, --output FILE        shorthand for --set film.output=FILE\n"
    "  --threads N              shorthand for --set threads=N\n"
    "  --no-cache               neither load nor save a cached BVH (--set cache=off)\n"
    "  --allow-config-plugins   trust the config's plugin_path and plugins given as paths\n"
    "  -q, --quiet              no progress bar and no report\n"
    "bench options:\n"
    "  --accel A,B,...          accelerators to compare, NAME or NAME:KEY=VALUE:...\n"
    "                           (default: the config's, or every accelerator found)\n"
    "  --threads N,M,...        thread counts (default: 1 and every core)\n"
    "  --width W --height H     image size (default: the config's, or 1024x768)\n"
    "  --camera EX,EY,EZ,LX,LY,LZ,FOV  eye, look-at, vertical fov (default: the recipe's)\n"
    "  --runs N                 builds and timed passes, median reported (default 5)\n"
    "  --csv FILE               also write one row per accelerator x threads\n"
    "diff options:\n"
    "  --epsilon E              e in relMSE (a-b)^2/(b^2+e), MAPE |a-b|/(|b|+e) and\n"
    "                           SMAPE 2|a-b|/(|a|+|b|+e); a number > 0 (default 0.01)\n"
    "  --error-image FILE       also write the per-pixel error: .exr gets floats |A - B| per\n"
    "                           channel, other formats a heat map of the relative error\n"
    "                           (grey <= 0.001, blue 0.01, yellow 0.1, red >= 1, magenta NaN/Inf)\n"
    "  --csv                    print CSV: a header, then one row per channel and overall\n"
    "  PSNR takes 1.0 as the peak. NaN/Inf samples are counted and left out. Exit status:\n"
    "  0 compared, 1 the error image could not be written, 2 usage or input error\n"
    "  (a file missing or unreadable, the sizes differ)\n"
    "sweep options (each LIST is comma-separated; every value is applied as --set KEY=VALUE):\n"
    "  --samplers LIST          sampler.type values, e.g. independent,stratified,sobol\n"
    "  --filters LIST           filter.plugin values, e.g. box,gaussian,mitchell\n"
    "  --accelerators LIST      accelerator.plugin values, e.g. sah,lbvh\n"
    "  --param KEY=LIST         any setting, e.g. integrator.rays=1,4 (may repeat)\n"
    "                           combinations: every tuple, in the order the axes are given\n"
    "  --spp LIST               increasing samples per pixel (default 1,2,4,8,16,32,64)\n"
    "  --seeds K                runs per combination and spp, seeds 1..K (default 4)\n"
    "  --threads N              render threads (default: the config's)\n"
    "  --target-relmse E        error target of the time-to-error column (default 1e-3)\n"
    "  --out DIR                sweep.csv, sweep.txt, sweep.dat, sweep.gp, sweep.png and the\n"
    "                           cached reference go here (default ./sweep)\n"
    "  --reference FILE         compare with this image instead of rendering a reference\n"
    "  --reference-spp N        the rendered reference's spp (default 64 x the largest spp,\n"
    "                           at least 4096, at most 65536); independent sampler, seed\n"
    "                           2654435761; cached in DIR under a hash of the config text,\n"
    "                           the overrides and the spp, and reused while it matches\n"
    "  --reference-filter F     the reference's filter (default box); 'same': each\n"
    "                           combination's own filter, one reference per filter\n"
    "  --plot / --no-plot       plotting needs gnuplot: --plot fails without it; by default\n"
    "                           a missing gnuplot leaves the script and data, exit 0\n"
    "  --bvh-cache              use the config's BVH cache (default off: build_s is a build)\n"
    "  --set KEY=VALUE          override a config setting in every render (may repeat)\n"
    "  -q, --quiet              no progress bar\n"
    "  Prints per combination the RMSE and relMSE convergence slopes (log-log least squares\n"
    "  over the upper half of the spp values) and the render time to the target relMSE\n"
    "  (log-log interpolation between measured points; 'not reached' past them). Exit\n"
    "  status: 0 done, 1 a render, file or plot failed, 2 usage error\n"
    "options for every command:\n"
    "  --plugin-path DIR        also search DIR for plugins (may repeat)\n"
    "  -v, --verbose            print debug messages\n"
    "  -h, --help               this text\n";

static int usage_error(const char *fmt, const char *arg)
{
    fprintf(stderr, "rtk: ");
    fprintf(stderr, fmt, arg);
    fprintf(stderr, "\n\n%s", usage_text);
    return 2;
}

static const char *type_name(rtk_param_type t)
{
    switch (t) {
    case RTK_PARAM_INT:
        return "int";
    case RTK_PARAM_FLOAT:
        return "float";
    case RTK_PARAM_BOOL:
        return "bool";
    case RTK_PARAM_STRING:
        return "string";
    }
    return "?";
}

static void print_param(const rtk_param_desc *d)
{
    char def[64], range[96] = "";
    if (d->required)
        snprintf(def, sizeof def, "(required)");
    else if (d->type == RTK_PARAM_STRING)
        snprintf(def, sizeof def, "\"%s\"", d->def_string ? d->def_string : "");
    else if (d->type == RTK_PARAM_BOOL)
        snprintf(def, sizeof def, "%s", d->def != 0.0 ? "true" : "false");
    else
        snprintf(def, sizeof def, "%g", d->def);
    if (d->type == RTK_PARAM_STRING && d->choices)
        snprintf(range, sizeof range, "one of %s", d->choices);
    else if ((d->type == RTK_PARAM_INT || d->type == RTK_PARAM_FLOAT) && d->min != d->max)
        snprintf(range, sizeof range, "[%g, %g]", d->min, d->max);
    printf("  %-14s %-7s default %-10s %-18s %s\n", d->name, type_name(d->type), def, range, d->doc ? d->doc : "");
}

static int cmd_plugins(rtk_registry *reg, const char *name)
{
    size_t n = rtk_registry_count(reg);
    int shown = 0, problems = 0;
    for (size_t i = 0; i < n; i++) {
        const rtk_plugin_info *info = rtk_registry_at(reg, i);
        const rtk_plugin *p = info->plugin;
        if (name) {
            if (!p || strcmp(p->name, name) != 0)
                continue;
            printf("%s %s %s: %s\n  file: %s\n", rtk_kind_name(p->kind), p->name, p->version, p->summary, info->path);
            if (info->problem)
                printf("  refused: %s\n", info->problem);
            if (p->param_count == 0)
                printf("  no parameters\n");
            else
                printf("  parameters:\n");
            for (uint32_t k = 0; k < p->param_count; k++)
                print_param(&p->params[k]);
            shown++;
            continue;
        }
        if (!p) {
            problems++;
            continue;
        }
        printf("%-12s %-12s %-6s %s%s\n", rtk_kind_name(p->kind), p->name, p->version, p->summary,
               info->problem ? "  [refused, see below]" : "");
        for (uint32_t k = 0; k < p->param_count; k++)
            print_param(&p->params[k]);
        shown++;
    }
    if (!name) {
        for (size_t i = 0; i < n; i++) {
            const rtk_plugin_info *info = rtk_registry_at(reg, i);
            if (info->problem)
                fprintf(stderr, "rtk: warning: refused %s\n", info->problem);
        }
        if (shown == 0)
            fprintf(stderr, "rtk: no plugins found (set RTK_PLUGIN_PATH or use --plugin-path)\n");
        return shown ? 0 : 1;
    }
    if (shown == 0) {
        fprintf(stderr, "rtk: no plugin named '%s'; `rtk plugins` lists them all\n", name);
        return 1;
    }
    (void)problems;
    return 0;
}

/* Splits a comma-separated list in place into items (at most cap). */
static size_t split_list(char *list, char **items, size_t cap)
{
    size_t n = 0;
    for (char *tok = strtok(list, ","); tok && n < cap; tok = strtok(NULL, ","))
        items[n++] = tok;
    return n;
}

/* Parses an unsigned decimal in [lo, hi]; 0 on failure. */
static int parse_uint(const char *s, unsigned long lo, unsigned long hi, uint32_t *out)
{
    char *end;
    unsigned long v = strtoul(s, &end, 10);
    if (end == s || *end || s[0] == '-' || v < lo || v > hi)
        return 0;
    *out = (uint32_t)v;
    return 1;
}

/* rtk bench: args are everything after the word "bench". */
static int cmd_bench(rtk_registry *reg, int argc, char **argv, int quiet)
{
    const char *path = NULL;
    char *accel_items[64], *thread_items[64];
    const char *accels[64];
    uint32_t threads[64];
    rtk_bench_options o;
    memset(&o, 0, sizeof o);
    o.size = sizeof o;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        int takes_value = strcmp(a, "--accel") == 0 || strcmp(a, "--threads") == 0 || strcmp(a, "--width") == 0 ||
                          strcmp(a, "--height") == 0 || strcmp(a, "--camera") == 0 || strcmp(a, "--runs") == 0 ||
                          strcmp(a, "--csv") == 0 || strcmp(a, "--plugin-path") == 0;
        if (takes_value && i + 1 >= argc)
            return usage_error("%s needs a value", a);
        char *v = takes_value ? argv[++i] : NULL;
        if (strcmp(a, "-h") == 0 || strcmp(a, "--help") == 0) {
            fputs(usage_text, stdout);
            return 0;
        } else if (strcmp(a, "-q") == 0 || strcmp(a, "--quiet") == 0) {
            quiet = 1;
        } else if (strcmp(a, "-v") == 0 || strcmp(a, "--verbose") == 0) {
            rtk_log_set_level(RTK_LOG_DEBUG);
        } else if (strcmp(a, "--allow-config-plugins") == 0) {
            o.allow_config_plugins = 1;
        } else if (strcmp(a, "--plugin-path") == 0) {
            rtk_registry_add_dir(reg, v, "--plugin-path");
        } else if (strcmp(a, "--accel") == 0) {
            o.accelerator_count = split_list(v, accel_items, 64);
            for (size_t k = 0; k < o.accelerator_count; k++)
                accels[k] = accel_items[k];
            o.accelerators = accels;
        } else if (strcmp(a, "--threads") == 0) {
            o.threads_count = split_list(v, thread_items, 64);
            for (size_t k = 0; k < o.threads_count; k++)
                if (!parse_uint(thread_items[k], 1, 1024, &threads[k]))
                    return usage_error("--threads: '%s' is not a thread count in [1, 1024]", thread_items[k]);
            o.threads = threads;
        } else if (strcmp(a, "--width") == 0 || strcmp(a, "--height") == 0) {
            if (!parse_uint(v, 1, 16384, a[2] == 'w' ? &o.width : &o.height))
                return usage_error("%s needs a size in [1, 16384]", a);
        } else if (strcmp(a, "--runs") == 0) {
            if (!parse_uint(v, 1, 1000, &o.runs))
                return usage_error("%s needs a count in [1, 1000]", a);
        } else if (strcmp(a, "--csv") == 0) {
            o.csv = v;
        } else if (strcmp(a, "--camera") == 0) {
            double c[7];
            int n = 0;
            const char *p = v;
            for (; n < 7; n++) {
                char *end;
                c[n] = strtod(p, &end);
                if (end == p || (*end != ',' && *end != '\0'))
                    break;
                p = *end ? end + 1 : end;
            }
            if (n != 7 || *p)
                return usage_error("--camera needs 7 numbers EX,EY,EZ,LX,LY,LZ,FOV, not '%s'", v);
            memcpy(o.eye, c, sizeof o.eye);
            memcpy(o.look_at, c + 3, sizeof o.look_at);
            o.fov_deg = c[6];
            o.has_camera = 1;
        } else if (a[0] == '-' && a[1] != '\0') {
            return usage_error("unknown bench option '%s'", a);
        } else if (!path) {
            path = a;
        } else {
            return usage_error("unexpected argument '%s'", a);
        }
    }
    if (!path)
        return usage_error("%s needs a mesh (.obj) or a config (.cfg)", "bench");
    if ((o.width == 0) != (o.height == 0))
        return usage_error("%s: give both --width and --height", "bench");
    o.progress = !quiet && isatty(STDERR_FILENO);
    if (rtk_bench(path, reg, &o, stdout) != RTK_OK) {
        fprintf(stderr, "rtk: error: %s\n", rtk_error_message());
        return 1;
    }
    return 0;
}

/* A metric value as rtk diff prints it: %.9g, or nan / inf / -inf. */
static void print_number(double v)
{
    if (isnan(v))
        fputs("nan", stdout);
    else if (isinf(v))
        fputs(v > 0 ? "inf" : "-inf", stdout);
    else
        printf("%.9g", v);
}

/* One line of rtk diff's text output: key, then "NAME value" for each
 * channel and overall; the value is the uint64_t or double at offset. */
static void print_diff_line(const rtk_diff_result *r, const char *key, size_t offset, int is_count)
{
    printf("%-20s", key);
    for (uint32_t c = 0; c <= r->channel_count; c++) {
        const rtk_diff_channel *ch = c < r->channel_count ? &r->channels[c] : &r->overall;
        const char *field = (const char *)ch + offset;
        printf(" %s ", ch->name);
        if (is_count) {
            uint64_t n;
            memcpy(&n, field, sizeof n);
            printf("%llu", (unsigned long long)n);
        } else {
            double v;
            memcpy(&v, field, sizeof v);
            print_number(v);
        }
    }
    putchar('\n');
}

static void print_diff_csv(const rtk_diff_result *r)
{
    printf("channel,samples,excluded,nonfinite_test,nonfinite_reference,rmse,mse,relmse,mape,smape,psnr,"
           "mean_error,epsilon,psnr_peak\n");
    for (uint32_t c = 0; c <= r->channel_count; c++) {
        const rtk_diff_channel *ch = c < r->channel_count ? &r->channels[c] : &r->overall;
        printf("%s,%llu,%llu,%llu,%llu", ch->name, (unsigned long long)ch->samples,
               (unsigned long long)ch->excluded, (unsigned long long)ch->nonfinite_a,
               (unsigned long long)ch->nonfinite_b);
        const double v[] = {ch->rmse, ch->mse, ch->relmse, ch->mape, ch->smape, ch->psnr, ch->mean_error,
                            r->epsilon, r->peak};
        for (size_t k = 0; k < sizeof v / sizeof v[0]; k++) {
            putchar(',');
            print_number(v[k]);
        }
        putchar('\n');
    }
}

static void print_diff_text(const rtk_diff_result *r, const char *test, const char *reference)
{
    printf("%-20s %s\n%-20s %s\n", "test", test, "reference", reference);
    printf("%-20s %ux%u\n", "size", r->width, r->height);
    printf("%-20s ", "epsilon");
    print_number(r->epsilon);
    printf("\n%-20s ", "psnr_peak");
    print_number(r->peak);
    printf("\n%-20s", "overall_channels");
    for (uint32_t c = 0; c < r->colour_channels; c++)
        printf(" %s", r->channels[c].name);
    putchar('\n');
    static const struct {
        const char *key;
        size_t offset;
        int is_count;
    } lines[] = {
        {"samples", offsetof(rtk_diff_channel, samples), 1},
        {"excluded", offsetof(rtk_diff_channel, excluded), 1},
        {"nonfinite_test", offsetof(rtk_diff_channel, nonfinite_a), 1},
        {"nonfinite_reference", offsetof(rtk_diff_channel, nonfinite_b), 1},
        {"rmse", offsetof(rtk_diff_channel, rmse), 0},
        {"mse", offsetof(rtk_diff_channel, mse), 0},
        {"relmse", offsetof(rtk_diff_channel, relmse), 0},
        {"mape", offsetof(rtk_diff_channel, mape), 0},
        {"smape", offsetof(rtk_diff_channel, smape), 0},
        {"psnr", offsetof(rtk_diff_channel, psnr), 0},
        {"mean_error", offsetof(rtk_diff_channel, mean_error), 0},
    };
    for (size_t k = 0; k < sizeof lines / sizeof lines[0]; k++)
        print_diff_line(r, lines[k].key, lines[k].offset, lines[k].is_count);
}

/* rtk diff: args are everything after the word "diff". */
static int cmd_diff(int argc, char **argv)
{
    const char *files[2] = {NULL, NULL};
    int csv = 0;
    rtk_diff_options o;
    memset(&o, 0, sizeof o);
    o.size = sizeof o;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        int takes_value = strcmp(a, "--epsilon") == 0 || strcmp(a, "--error-image") == 0;
        if (takes_value && i + 1 >= argc)
            return usage_error("%s needs a value", a);
        const char *v = takes_value ? argv[++i] : NULL;
        if (strcmp(a, "-h") == 0 || strcmp(a, "--help") == 0) {
            fputs(usage_text, stdout);
            return 0;
        } else if (strcmp(a, "-v") == 0 || strcmp(a, "--verbose") == 0) {
            rtk_log_set_level(RTK_LOG_DEBUG);
        } else if (strcmp(a, "--csv") == 0) {
            csv = 1;
        } else if (strcmp(a, "--error-image") == 0) {
            o.error_image = v;
        } else if (strcmp(a, "--epsilon") == 0) {
            char *end;
            o.epsilon = strtod(v, &end);
            if (end == v || *end || !(o.epsilon > 0.0) || isinf(o.epsilon))
                return usage_error("--epsilon needs a finite number > 0, not '%s'", v);
        } else if (a[0] == '-' && a[1] != '\0') {
            return usage_error("unknown diff option '%s'", a);
        } else if (!files[0]) {
            files[0] = a;
        } else if (!files[1]) {
            files[1] = a;
        } else {
            return usage_error("unexpected argument '%s'", a);
        }
    }
    if (!files[1])
        return usage_error("%s needs two images: the one to check, then the reference", "diff");
    rtk_diff_result r;
    memset(&r, 0, sizeof r);
    r.size = sizeof r;
    rtk_status st = rtk_diff_files(files[0], files[1], &o, &r);
    if (!r.compared) {
        fprintf(stderr, "rtk: error: %s\n", rtk_error_message());
        return 2;
    }
    if (csv)
        print_diff_csv(&r);
    else
        print_diff_text(&r, files[0], files[1]);
    uint64_t excluded = 0, in_test = 0, in_reference = 0;
    for (uint32_t c = 0; c < r.channel_count; c++) {
        excluded += r.channels[c].excluded;
        in_test += r.channels[c].nonfinite_a;
        in_reference += r.channels[c].nonfinite_b;
    }
    if (excluded)
        fprintf(stderr,
                "rtk: warning: %llu samples with NaN or Inf left out of the metrics (%llu in '%s', %llu in "
                "'%s'); see the excluded line\n",
                (unsigned long long)excluded, (unsigned long long)in_test, files[0],
                (unsigned long long)in_reference, files[1]);
    if (st != RTK_OK) {
        fprintf(stderr, "rtk: error: %s\n", rtk_error_message());
        return 1;
    }
    return 0;
}

#define SWEEP_MAX_AXES 64
#define SWEEP_MAX_VALUES 256

/* rtk sweep: args are everything after the word "sweep"; base holds the
 * --set overrides given before it. */
static int cmd_sweep(rtk_registry *reg, int argc, char **argv, const char *const *base, size_t base_count, int quiet,
                     int allow)
{
    const char *path = NULL;
    static rtk_sweep_axis axes[SWEEP_MAX_AXES];
    static char *values[SWEEP_MAX_AXES][SWEEP_MAX_VALUES];
    static char origins[SWEEP_MAX_AXES][216];
    static uint32_t spp[SWEEP_MAX_VALUES];
    char *spp_items[SWEEP_MAX_VALUES];
    const char **overrides = calloc(base_count + (size_t)argc + 1, sizeof *overrides);
    if (!overrides) {
        fprintf(stderr, "rtk: out of memory\n");
        return 1;
    }
    int status = 0;
    rtk_sweep_options o;
    memset(&o, 0, sizeof o);
    o.size = sizeof o;
    o.allow_config_plugins = allow;
    o.axes = axes;
    o.overrides = overrides;
    for (size_t k = 0; k < base_count; k++)
        overrides[o.override_count++] = base[k];
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        static const char *const valued[] = {"--samplers", "--filters", "--accelerators", "--param", "--spp",
                                             "--seeds", "--threads", "--target-relmse", "--out", "--reference",
                                             "--reference-spp", "--reference-filter", "--set", "--plugin-path"};
        int takes_value = 0;
        for (size_t k = 0; k < sizeof valued / sizeof valued[0]; k++)
            takes_value |= strcmp(a, valued[k]) == 0;
        if (takes_value && i + 1 >= argc) {
            status = usage_error("%s needs a value", a);
            goto out;
        }
        char *v = takes_value ? argv[++i] : NULL;
        const char *axis_key = strcmp(a, "--samplers") == 0       ? "sampler.type"
                               : strcmp(a, "--filters") == 0      ? "filter.plugin"
                               : strcmp(a, "--accelerators") == 0 ? "accelerator.plugin"
                                                                  : NULL;
        if (strcmp(a, "-h") == 0 || strcmp(a, "--help") == 0) {
            fputs(usage_text, stdout);
            goto out;
        } else if (strcmp(a, "-q") == 0 || strcmp(a, "--quiet") == 0) {
            quiet = 1;
        } else if (strcmp(a, "-v") == 0 || strcmp(a, "--verbose") == 0) {
            rtk_log_set_level(RTK_LOG_DEBUG);
        } else if (strcmp(a, "--allow-config-plugins") == 0) {
            o.allow_config_plugins = 1;
        } else if (strcmp(a, "--plugin-path") == 0) {
            rtk_registry_add_dir(reg, v, "--plugin-path");
        } else if (strcmp(a, "--set") == 0) {
            overrides[o.override_count++] = v;
        } else if (axis_key || strcmp(a, "--param") == 0) {
            if (o.axis_count == SWEEP_MAX_AXES) {
                status = usage_error("at most %s axes", "64");
                goto out;
            }
            rtk_sweep_axis *ax = &axes[o.axis_count];
            ax->origin = a;
            ax->key = axis_key;
            char *list = v;
            if (!axis_key) {
                char *eq = strchr(v, '=');
                if (!eq || eq == v || !eq[1]) {
                    status = usage_error("--param needs KEY=V1,V2,..., e.g. integrator.rays=1,4, not '%s'", v);
                    goto out;
                }
                *eq = '\0';
                ax->key = v;
                list = eq + 1;
                snprintf(origins[o.axis_count], sizeof origins[0], "--param %.200s", v);
                ax->origin = origins[o.axis_count];
            }
            ax->value_count = split_list(list, values[o.axis_count], SWEEP_MAX_VALUES);
            if (ax->value_count == 0) {
                status = usage_error("%s needs at least one value", a);
                goto out;
            }
            ax->values = (const char *const *)values[o.axis_count];
            o.axis_count++;
        } else if (strcmp(a, "--spp") == 0) {
            o.spp_count = split_list(v, spp_items, SWEEP_MAX_VALUES);
            for (size_t k = 0; k < o.spp_count; k++)
                if (!parse_uint(spp_items[k], 1, 1u << 20, &spp[k])) {
                    status = usage_error("--spp: '%s' is not a sample count in [1, 1048576]", spp_items[k]);
                    goto out;
                }
            o.spp = spp;
        } else if (strcmp(a, "--seeds") == 0) {
            if (!parse_uint(v, 1, 100000, &o.seeds)) {
                status = usage_error("--seeds needs a count in [1, 100000], not '%s'", v);
                goto out;
            }
        } else if (strcmp(a, "--threads") == 0) {
            if (!parse_uint(v, 1, 1024, &o.threads)) {
                status = usage_error("--threads needs a thread count in [1, 1024], not '%s'", v);
                goto out;
            }
        } else if (strcmp(a, "--reference-spp") == 0) {
            if (!parse_uint(v, 1, 1u << 20, &o.reference_spp)) {
                status = usage_error("--reference-spp needs a sample count in [1, 1048576], not '%s'", v);
                goto out;
            }
        } else if (strcmp(a, "--target-relmse") == 0) {
            char *end;
            o.target_relmse = strtod(v, &end);
            if (end == v || *end || !(o.target_relmse > 0.0) || isinf(o.target_relmse)) {
                status = usage_error("--target-relmse needs a finite number > 0, not '%s'", v);
                goto out;
            }
        } else if (strcmp(a, "--out") == 0) {
            o.out_dir = v;
        } else if (strcmp(a, "--reference") == 0) {
            o.reference = v;
        } else if (strcmp(a, "--reference-filter") == 0) {
            o.reference_filter = v;
        } else if (strcmp(a, "--plot") == 0) {
            o.plot = 1;
        } else if (strcmp(a, "--no-plot") == 0) {
            o.plot = -1;
        } else if (strcmp(a, "--bvh-cache") == 0) {
            o.bvh_cache = 1;
        } else if (a[0] == '-' && a[1] != '\0') {
            status = usage_error("unknown sweep option '%s'", a);
            goto out;
        } else if (!path) {
            path = a;
        } else {
            status = usage_error("unexpected argument '%s'", a);
            goto out;
        }
    }
    if (!path) {
        status = usage_error("%s needs a config file", "sweep");
        goto out;
    }
    o.progress = !quiet && isatty(STDERR_FILENO);
    if (rtk_sweep(path, reg, &o, stdout) != RTK_OK) {
        fflush(stdout);
        fprintf(stderr, "rtk: error: %s\n", rtk_error_message());
        status = 1;
    }
out:
    free(overrides);
    return status;
}

static int cmd_conform(rtk_registry *reg, const char *what)
{
    const char *path = what;
    if (!strchr(what, '/')) {
        /* A bare name: the first plugin of any kind with that name. */
        path = NULL;
        size_t n = rtk_registry_count(reg);
        for (size_t i = 0; i < n && !path; i++) {
            const rtk_plugin_info *info = rtk_registry_at(reg, i);
            if (info->plugin && strcmp(info->plugin->name, what) == 0)
                path = info->path;
        }
        if (!path) {
            fprintf(stderr, "rtk: no plugin named '%s'; give a path to the .so or see `rtk plugins`\n", what);
            return 1;
        }
    }
    int passed = 0, failed = 0;
    rtk_status st = rtk_conform(path, stdout, &passed, &failed);
    return st == RTK_OK ? 0 : 1;
}

int main(int argc, char **argv)
{
    const char *command = NULL, *target = NULL;
    const char **overrides = calloc((size_t)argc * 2 + 1, sizeof *overrides);
    char **owned = calloc((size_t)argc + 1, sizeof *owned);
    size_t override_count = 0, owned_count = 0;
    int quiet = 0, allow = 0, status = 0;
    rtk_registry *reg = NULL;
    if (!overrides || !owned || rtk_registry_create(&reg) != RTK_OK) {
        fprintf(stderr, "rtk: out of memory\n");
        return 1;
    }
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "-h") == 0 || strcmp(a, "--help") == 0) {
            fputs(usage_text, stdout);
            goto out;
        } else if (strcmp(a, "--version") == 0) {
            printf("rtk, plugin ABI %d.%d\n", RTK_ABI_MAJOR, RTK_ABI_MINOR);
            goto out;
        } else if (strcmp(a, "-q") == 0 || strcmp(a, "--quiet") == 0) {
            quiet = 1;
        } else if (strcmp(a, "-v") == 0 || strcmp(a, "--verbose") == 0) {
            rtk_log_set_level(RTK_LOG_DEBUG);
        } else if (strcmp(a, "--allow-config-plugins") == 0) {
            allow = 1;
        } else if (strcmp(a, "--no-cache") == 0) {
            overrides[override_count++] = "cache=off";
        } else if (strcmp(a, "--set") == 0 || strcmp(a, "--plugin-path") == 0 || strcmp(a, "-o") == 0 ||
                   strcmp(a, "--output") == 0 || strcmp(a, "--threads") == 0) {
            if (i + 1 >= argc) {
                status = usage_error("%s needs a value", a);
                goto out;
            }
            const char *v = argv[++i];
            if (strcmp(a, "--set") == 0) {
                overrides[override_count++] = v;
            } else if (strcmp(a, "--plugin-path") == 0) {
                rtk_registry_add_dir(reg, v, "--plugin-path");
            } else {
                /* -o names a file relative to the current directory, not
                 * to the config's (where config paths are relative to). */
                int output = strcmp(a, "--threads") != 0;
                char cwd[4096] = "";
                if (output && v[0] != '/' && !getcwd(cwd, sizeof cwd)) {
                    fprintf(stderr, "rtk: cannot read the current directory for -o %s\n", v);
                    status = 1;
                    goto out;
                }
                size_t len = strlen(cwd) + strlen(v) + 32;
                char *s = malloc(len);
                if (!s) {
                    status = 1;
                    goto out;
                }
                if (!output)
                    snprintf(s, len, "threads=%s", v);
                else if (cwd[0])
                    snprintf(s, len, "film.output=%s/%s", cwd, v);
                else
                    snprintf(s, len, "film.output=%s", v);
                owned[owned_count++] = s;
                overrides[override_count++] = s;
            }
        } else if (a[0] == '-' && a[1] != '\0') {
            status = usage_error("unknown option '%s'", a);
            goto out;
        } else if (!command) {
            command = a;
            if (strcmp(a, "bench") == 0) {
                /* bench has options of its own (--threads takes a list). */
                status = cmd_bench(reg, argc - i - 1, argv + i + 1, quiet);
                goto out;
            }
            if (strcmp(a, "diff") == 0) {
                status = cmd_diff(argc - i - 1, argv + i + 1);
                goto out;
            }
            if (strcmp(a, "sweep") == 0) {
                /* sweep has options of its own (lists, --threads N). */
                status = cmd_sweep(reg, argc - i - 1, argv + i + 1, overrides, override_count, quiet, allow);
                goto out;
            }
        } else if (!target) {
            target = a;
        } else {
            status = usage_error("unexpected argument '%s'", a);
            goto out;
        }
    }
    if (!command) {
        fputs(usage_text, stderr);
        status = 2;
    } else if (strcmp(command, "plugins") == 0) {
        status = cmd_plugins(reg, target);
    } else if (strcmp(command, "conform") == 0) {
        if (!target)
            status = usage_error("%s needs a plugin path or name", "conform");
        else
            status = cmd_conform(reg, target);
    } else if (strcmp(command, "render") == 0) {
        if (!target) {
            status = usage_error("%s needs a config file", "render");
            goto out;
        }
        rtk_config_options copts;
        memset(&copts, 0, sizeof copts);
        copts.size = sizeof copts;
        copts.allow_config_plugins = allow;
        copts.overrides = overrides;
        copts.override_count = override_count;
        rtk_config *cfg = NULL;
        if (rtk_config_load(target, reg, &copts, &cfg) != RTK_OK) {
            fprintf(stderr, "rtk: error: %s\n", rtk_error_message());
            status = 1;
            goto out;
        }
        rtk_render_options ropts;
        memset(&ropts, 0, sizeof ropts);
        ropts.size = sizeof ropts;
        ropts.quiet = quiet;
        ropts.progress = !quiet && isatty(STDERR_FILENO);
        rtk_render_report report;
        memset(&report, 0, sizeof report);
        report.size = sizeof report;
        if (rtk_render(cfg, &ropts, &report) != RTK_OK) {
            fprintf(stderr, "rtk: error: %s\n", rtk_error_message());
            status = 1;
        } else if (!quiet) {
            rtk_render_report_print(&report, stdout);
        }
        rtk_config_destroy(cfg);
    } else {
        status = usage_error("unknown command '%s'", command);
    }
out:
    for (size_t i = 0; i < owned_count; i++)
        free(owned[i]);
    free(owned);
    free(overrides);
    rtk_registry_destroy(reg);
    return status;
}

/* rtk: the command-line front end. render, plugins, conform, bench. */
#include <rtk/host.h>

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

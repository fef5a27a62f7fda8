/* rtk: the command-line front end: render, plugins, conform, bench, diff,
 * sweep, help and version. Each command's options are one table, which
 * its parser, its help (rtk help CMD) and its "did you mean" all read. */
#include <rtk/host.h>

#include "tools.h"

#include <math.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#ifndef RTK_VERSION
#define RTK_VERSION "(unknown version)"
#endif

/* One command-line option. */
typedef struct cli_option {
    const char *name;  /* "--threads"; the first member, as rtk_suggest reads it */
    const char *alias; /* "-o", or NULL */
    const char *value; /* what it takes ("N"), or NULL for a flag */
    const char *help;  /* lines separated by '\n' */
} cli_option;

typedef struct cli_command cli_command;

/* Runs a command on the arguments other than its name; returns the exit status. */
typedef int (*cli_run_fn)(const cli_command *cmd, rtk_registry *reg, int argc, char **argv);

/* One command: its usage, its options (ending with a NULL name) and what runs it. */
struct cli_command {
    const char *name;          /* "render"; the first member, as rtk_suggest reads it */
    const char *args;          /* "CONFIG [options]" */
    const char *summary;       /* one line, for the overview and the help */
    const cli_option *options;
    const char *notes;         /* help after the options, or NULL */
    cli_run_fn run;
};

static const cli_option common_options[] = {
    {"--plugin-path", NULL, "DIR", "also search DIR for plugins (may repeat)"},
    {"--verbose", "-v", NULL, "print debug messages"},
    {"--help", "-h", NULL, "the command's usage and options"},
    {"--version", NULL, NULL, "rtk's release and plugin ABI versions"},
    {NULL, NULL, NULL, NULL},
};

static const cli_option render_options[] = {
    {"--set", NULL, "KEY=VALUE",
     "override a config setting (may repeat), e.g. --set integrator.rays=64.\n"
     "KEY is a dotted path; missing groups are made (--set integrator.plugin=ao).\n"
     "VALUE is a number (inf too), true or false, text (quotes optional), or an\n"
     "array [A,B,...] of numbers or of strings: --set camera.position=[0,1,4],\n"
     "--set film.aovs=[albedo,normal] or, quoted for the shell,\n"
     "--set 'film.aovs=[\"albedo\",\"normal\"]'. Lists of groups (lights,\n"
     "instances) are written in the config file only"},
    {"--output", "-o", "FILE", "shorthand for --set film.output=FILE, FILE relative to the current directory"},
    {"--threads", NULL, "N", "shorthand for --set threads=N; above the cores this process may use\n"
                             "(online, in its CPU affinity and cgroup quota), capped to them with a\n"
                             "warning unless --oversubscribe"},
    {"--oversubscribe", NULL, NULL, "run as many threads as asked for even beyond the cores\n"
                                    "this process may use (they then take turns); the config's oversubscribe = true; does the same"},
    {"--no-cache", NULL, NULL, "neither load nor save a cached BVH (--set cache=off)"},
    {"--allow-config-plugins", NULL, NULL, "trust the config's plugin_path and plugins given as paths"},
    {"--allow-outside-files", NULL, NULL, "let the scene read files outside its own and the config's folders"},
    {"--quiet", "-q", NULL, "no progress bar and no report"},
    {NULL, NULL, NULL, NULL},
};

static const cli_option no_options[] = {{NULL, NULL, NULL, NULL}};

static const cli_option bench_options[] = {
    {"--accel", NULL, "A,B,...", "accelerators to compare, NAME or NAME:KEY=VALUE:...\n"
                                 "(default: the config's, or every accelerator found)"},
    {"--threads", NULL, "N,M,...", "thread counts (default: 1 and every core this process may use);\n"
                                   "counts above those cores are capped to them with a warning unless\n"
                                   "--oversubscribe"},
    {"--oversubscribe", NULL, NULL, "run thread counts beyond the cores this process may use as given"},
    {"--width", NULL, "W", "image width (default: the config's, or 1024); give --height too"},
    {"--height", NULL, "H", "image height (default: the config's, or 768)"},
    {"--camera", NULL, "EX,EY,EZ,LX,LY,LZ,FOV", "eye, look-at, vertical fov (default: the recipe's)"},
    {"--runs", NULL, "N", "builds and timed passes, median reported (default 5)"},
    {"--csv", NULL, "FILE", "also write one row per accelerator x threads"},
    {"--allow-config-plugins", NULL, NULL, "trust the config's plugin_path and plugins given as paths"},
    {"--allow-outside-files", NULL, NULL, "let the scene read files outside its own and the config's folders"},
    {"--quiet", "-q", NULL, "no progress bar"},
    {NULL, NULL, NULL, NULL},
};

static const cli_option diff_options[] = {
    {"--epsilon", NULL, "E", "e in relMSE (a-b)^2/(b^2+e), MAPE |a-b|/(|b|+e) and\n"
                             "SMAPE 2|a-b|/(|a|+|b|+e); a number > 0 (default 0.01)"},
    {"--error-image", NULL, "FILE", "also write the per-pixel error: .exr gets floats |A - B| per\n"
                                    "channel, other formats a heat map of the relative error\n"
                                    "(grey <= 0.001, blue 0.01, yellow 0.1, red >= 1, magenta NaN/Inf)"},
    {"--csv", NULL, NULL, "print CSV: a header, then one row per channel and overall"},
    {NULL, NULL, NULL, NULL},
};

static const cli_option sweep_options[] = {
    {"--samplers", NULL, "LIST", "sampler.type values, e.g. independent,stratified,sobol"},
    {"--filters", NULL, "LIST", "filter.plugin values, e.g. box,gaussian,mitchell"},
    {"--accelerators", NULL, "LIST", "accelerator.plugin values, e.g. sah,lbvh"},
    {"--param", NULL, "KEY=LIST", "any setting, e.g. integrator.rays=1,4 (may repeat);\n"
                                  "combinations: every tuple, in the order the axes are given"},
    {"--spp", NULL, "LIST", "increasing samples per pixel (default 1,2,4,8,16,32,64)"},
    {"--seeds", NULL, "K", "runs per combination and spp, seeds 1..K (default 4)"},
    {"--threads", NULL, "N", "render threads (default: the config's); above the cores this\n"
                             "process may use, capped to them with a warning unless --oversubscribe"},
    {"--oversubscribe", NULL, NULL, "run as many threads as asked for even beyond the cores this process may use"},
    {"--target-relmse", NULL, "E", "error target of the time-to-error column (default 1e-3)"},
    {"--out", NULL, "DIR", "sweep.csv, sweep.txt, sweep.dat, sweep.gp, sweep.png and the\n"
                           "cached reference go here (default ./sweep)"},
    {"--reference", NULL, "FILE", "compare with this image instead of rendering a reference"},
    {"--reference-spp", NULL, "N", "the rendered reference's spp (default 64 x the largest spp,\n"
                                   "at least 4096, at most 65536); independent sampler, seed\n"
                                   "2654435761; cached in DIR under a hash of the config text,\n"
                                   "the overrides and the spp, and reused while it matches"},
    {"--reference-filter", NULL, "F", "the reference's filter (default box); 'same': each\n"
                                      "combination's own filter, one reference per filter"},
    {"--plot", NULL, NULL, "plot with gnuplot, and fail without it"},
    {"--no-plot", NULL, NULL, "write the plot's script and data only (by default a missing\n"
                              "gnuplot leaves them, exit 0)"},
    {"--bvh-cache", NULL, NULL, "use the config's BVH cache (default off: build_s is a build)"},
    {"--set", NULL, "KEY=VALUE", "override a config setting in every render (may repeat; as in\n"
                                 "rtk render --help)"},
    {"--allow-config-plugins", NULL, NULL, "trust the config's plugin_path and plugins given as paths"},
    {"--allow-outside-files", NULL, NULL, "let the scene read files outside its own and the config's folders"},
    {"--quiet", "-q", NULL, "no progress bar"},
    {NULL, NULL, NULL, NULL},
};

static int run_render(const cli_command *cmd, rtk_registry *reg, int argc, char **argv);
static int run_plugins(const cli_command *cmd, rtk_registry *reg, int argc, char **argv);
static int run_conform(const cli_command *cmd, rtk_registry *reg, int argc, char **argv);
static int run_bench(const cli_command *cmd, rtk_registry *reg, int argc, char **argv);
static int run_diff(const cli_command *cmd, rtk_registry *reg, int argc, char **argv);
static int run_sweep(const cli_command *cmd, rtk_registry *reg, int argc, char **argv);
static int run_help(const cli_command *cmd, rtk_registry *reg, int argc, char **argv);
static int run_version(const cli_command *cmd, rtk_registry *reg, int argc, char **argv);

static const cli_command commands[] = {
    {"render", "CONFIG [options]", "render the scene a config describes", render_options, NULL, run_render},
    {"plugins", "[NAME] [options]", "list plugins, or show one plugin's parameters", no_options, NULL, run_plugins},
    {"conform", "PLUGIN [options]", "run the conformance checks on a plugin (.so path or name)", no_options, NULL,
     run_conform},
    {"bench", "MESH.obj|CONFIG.cfg [options]", "time accelerators on the standard recipe (docs/bench-vs-embree.md)", bench_options,
     "With -v (--verbose) the report ends with each build's phases: median ms over the\n"
     "runs, share of the build, whether each ran on one thread or several, and on more\n"
     "than one thread the serial fraction (time in one-thread phases over the same\n"
     "accelerator's one-thread build; give 1 among --threads), then the speed-up over\n"
     "that build and the CPU time against its CPU time",
     run_bench},
    {"diff", "A B [options]", "compare an image with a reference: RMSE, relMSE, PSNR and more per channel",
     diff_options,
     "Compares image A with the reference B (PNG, JPEG, OpenEXR, Radiance HDR, TIFF, BMP,\n"
     "TGA, PNM or PFM): RMSE, MSE, relMSE, MAPE, SMAPE, PSNR and mean error A - B per\n"
     "channel and overall.\n"
     "PSNR takes 1.0 as the peak. NaN/Inf samples are counted and left out. Exit status:\n"
     "0 compared, 1 the error image could not be written, 2 usage or input error\n"
     "(a file missing or unreadable, the sizes differ)",
     run_diff},
    {"sweep", "CONFIG [options]", "speed against error: render combinations of settings, compare with a reference",
     sweep_options,
     "Renders every combination of the axes at each spp and seed, compares each image\n"
     "with a reference, and writes CSV, table and plot.\n"
     "Each LIST is comma-separated; every value is applied as --set KEY=VALUE.\n"
     "Prints per combination the RMSE and relMSE convergence slopes (log-log least squares\n"
     "over the upper half of the spp values) and the render time to the target relMSE\n"
     "(log-log interpolation between measured points; 'not reached' past them). Exit\n"
     "status: 0 done, 1 a render, file or plot failed, 2 usage error",
     run_sweep},
    {"help", "[COMMAND]", "this overview, or a command's usage and options", no_options, NULL, run_help},
    {"version", "", "rtk's release and plugin ABI versions (also rtk --version)", no_options, NULL, run_version},
};
#define COMMAND_COUNT (sizeof commands / sizeof commands[0])

static const cli_command *find_command(const char *name)
{
    for (size_t i = 0; i < COMMAND_COUNT; i++) {
        if (strcmp(commands[i].name, name) == 0)
            return &commands[i];
    }
    return NULL;
}

/* Prints text, its lines after the first indented by indent spaces. */
static void print_indented(FILE *f, const char *text, int indent)
{
    for (const char *p = text; *p; p++) {
        fputc(*p, f);
        if (*p == '\n')
            fprintf(f, "%*s", indent, "");
    }
    fputc('\n', f);
}

static void print_options(FILE *f, const cli_option *options)
{
    for (const cli_option *o = options; o->name; o++) {
        char left[64];
        snprintf(left, sizeof left, "%s%s%s%s%s", o->alias ? o->alias : "", o->alias ? ", " : "", o->name,
                 o->value ? " " : "", o->value ? o->value : "");
        fprintf(f, "  %-24s ", left);
        if (strlen(left) > 24)
            fprintf(f, "\n  %-24s ", "");
        print_indented(f, o->help, 27);
    }
}

static void print_version(void)
{
    printf("rtk %s (plugin ABI %d.%d)\n", RTK_VERSION, RTK_ABI_MAJOR, RTK_ABI_MINOR);
}

/* The overview: commands, and where their options are. */
static void print_overview(FILE *f)
{
    fprintf(f, "usage: rtk COMMAND [options]\n\ncommands:\n");
    for (size_t i = 0; i < COMMAND_COUNT; i++)
        fprintf(f, "  %-9s %s\n", commands[i].name, commands[i].summary);
    fprintf(f, "\n'rtk help COMMAND' (or rtk COMMAND --help) shows a command's usage and options.\n"
               "\noptions for every command:\n");
    print_options(f, common_options);
}

/* A command's help: usage, what it does, its options, the common ones. */
static void print_command_help(const cli_command *cmd)
{
    printf("usage: rtk %s%s%s\n%s\n", cmd->name, cmd->args[0] ? " " : "", cmd->args, cmd->summary);
    if (cmd->options[0].name) {
        printf("\noptions:\n");
        print_options(stdout, cmd->options);
    }
    printf("\noptions for every command:\n");
    print_options(stdout, common_options);
    if (cmd->notes) {
        putchar('\n');
        print_indented(stdout, cmd->notes, 0);
    }
}

/* Prints "rtk: MESSAGE", then cmd's usage line (or the commands), and
 * returns 2, the exit status of a usage error. */
static int usage_error(const cli_command *cmd, const char *fmt, ...) RTK_PRINTF(2, 3);
static int usage_error(const cli_command *cmd, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fputs("rtk: ", stderr);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    if (cmd)
        fprintf(stderr, "\nusage: rtk %s%s%s\n'rtk help %s' lists its options\n", cmd->name, cmd->args[0] ? " " : "",
                cmd->args, cmd->name);
    else
        fprintf(stderr, "\n'rtk help' lists the commands\n");
    return 2;
}

/* The option of cmd (or a common one) arg names: "--name", its alias, or
 * "--name=value" (*inline_value then points at the value). */
static const cli_option *lookup_option(const cli_command *cmd, const char *arg, const char **inline_value)
{
    const cli_option *lists[2] = {cmd ? cmd->options : no_options, common_options};
    const char *eq = strncmp(arg, "--", 2) == 0 ? strchr(arg, '=') : NULL;
    size_t len = eq ? (size_t)(eq - arg) : strlen(arg);
    *inline_value = NULL;
    for (int l = 0; l < 2; l++) {
        for (const cli_option *o = lists[l]; o->name; o++) {
            if ((strlen(o->name) == len && strncmp(o->name, arg, len) == 0) || (!eq && o->alias && strcmp(o->alias, arg) == 0)) {
                *inline_value = eq ? eq + 1 : NULL;
                return o;
            }
        }
    }
    return NULL;
}

/* The usage error for an option cmd (NULL: any command) does not have,
 * with the closest one it has. */
static int unknown_option(const cli_command *cmd, const char *arg)
{
    const char *names[192];
    size_t n = 0;
    const cli_option *lists[COMMAND_COUNT + 1];
    size_t list_count = 0;
    lists[list_count++] = common_options;
    for (size_t k = 0; k < COMMAND_COUNT; k++)
        if (!cmd || cmd == &commands[k])
            lists[list_count++] = commands[k].options;
    for (size_t l = 0; l < list_count; l++) {
        for (const cli_option *o = lists[l]; o->name && n + 2 <= sizeof names / sizeof names[0]; o++) {
            names[n++] = o->name;
            if (o->alias)
                names[n++] = o->alias;
        }
    }
    char word[64];
    snprintf(word, sizeof word, "%.*s", (int)strcspn(arg, "="), arg);
    const char *near = rtk_suggest(word, names, n, sizeof names[0]);
    if (near)
        return usage_error(cmd, "unknown option '%s'%s%s (did you mean '%s'?)", word, cmd ? " for " : "",
                           cmd ? cmd->name : "", near);
    return usage_error(cmd, "unknown option '%s'%s%s", word, cmd ? " for " : "", cmd ? cmd->name : "");
}

/* One parsed argument: an option with its value, or an operand. */
typedef struct cli_arg {
    const cli_option *opt; /* NULL for an operand */
    const char *value;     /* the option's value (NULL for a flag), or the operand */
} cli_arg;

/* Reads the next argument of cmd from argv at *i into *out, taking the
 * common options itself (--plugin-path, -v, -h, --version). Returns 1 for
 * an argument, 0 at the end, 2 after a usage error it printed, -1 after
 * help or the version (exit status 0). */
static int next_arg(const cli_command *cmd, rtk_registry *reg, int argc, char **argv, int *i, cli_arg *out)
{
    for (; *i < argc; ++*i) {
        const char *a = argv[*i];
        out->opt = NULL;
        out->value = a;
        if (a[0] != '-' || a[1] == '\0') {
            ++*i;
            return 1;
        }
        const char *inline_value;
        const cli_option *o = lookup_option(cmd, a, &inline_value);
        if (!o)
            return unknown_option(cmd, a);
        if (!o->value && inline_value)
            return usage_error(cmd, "%s takes no value", o->name);
        if (o->value && !inline_value && *i + 1 >= argc)
            return usage_error(cmd, "%s needs a value: %s %s", a, a, o->value);
        const char *v = !o->value ? NULL : inline_value ? inline_value : argv[++*i];
        if (strcmp(o->name, "--help") == 0) {
            print_command_help(cmd);
            return -1;
        } else if (strcmp(o->name, "--version") == 0) {
            print_version();
            return -1;
        } else if (strcmp(o->name, "--verbose") == 0) {
            rtk_log_set_level(RTK_LOG_DEBUG);
        } else if (strcmp(o->name, "--plugin-path") == 0) {
            rtk_registry_add_dir(reg, v, "--plugin-path");
        } else {
            out->opt = o;
            out->value = v;
            ++*i;
            return 1;
        }
    }
    return 0;
}

/* Parses the arguments of a command that takes at most one operand and
 * no options of its own into *operand (NULL when none is given); returns
 * -1 to go on, else the exit status (after help, or a usage error). */
static int parse_operand(const cli_command *cmd, rtk_registry *reg, int argc, char **argv, const char **operand)
{
    *operand = NULL;
    cli_arg a;
    int i = 0, got;
    while ((got = next_arg(cmd, reg, argc, argv, &i, &a)) == 1) {
        if (*operand)
            return usage_error(cmd, "unexpected argument '%s'", a.value);
        *operand = a.value;
    }
    return got == 0 ? -1 : got < 0 ? 0 : got;
}

/* Whether arg is the option named name. */
static int is(const cli_arg *arg, const char *name)
{
    return arg->opt && strcmp(arg->opt->name, name) == 0;
}

/* Splits the comma-separated list of option name in place into items, at
 * most cap of them, none empty; 0, or the status of the usage error it
 * printed. */
static int split_list(const cli_command *cmd, const char *name, char *list, char **items, size_t cap, size_t *count)
{
    size_t n = 0;
    for (char *p = list;; n++) {
        char *comma = strchr(p, ',');
        if (comma)
            *comma = '\0';
        if (!*p)
            return usage_error(cmd, "%s: item %zu of its list is empty; give A,B,... without empty items", name, n + 1);
        if (n == cap)
            return usage_error(cmd, "%s: more than %zu items in its list", name, cap);
        items[n] = p;
        if (!comma)
            break;
        p = comma + 1;
    }
    *count = n + 1;
    return 0;
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
    else if ((d->type == RTK_PARAM_INT || d->type == RTK_PARAM_FLOAT) && rtk_param_has_range(d))
        snprintf(range, sizeof range, "[%g, %g]", d->min, d->max);
    printf("  %-14s %-7s default %-10s %-18s %s\n", d->name, rtk_param_type_name(d->type), def, range,
           d->doc ? d->doc : "");
}

/* rtk plugins [NAME] */
static int run_plugins(const cli_command *cmd, rtk_registry *reg, int argc, char **argv)
{
    const char *name;
    int status = parse_operand(cmd, reg, argc, argv, &name);
    if (status >= 0)
        return status;
    size_t n = rtk_registry_count(reg);
    int shown = 0;
    for (size_t k = 0; k < n; k++) {
        const rtk_plugin_info *info = rtk_registry_at(reg, k);
        const rtk_plugin *p = info->plugin;
        if (name) {
            if (!p || strcmp(p->name, name) != 0)
                continue;
            printf("%s %s %s: %s\n  file: %s\n", rtk_kind_name(p->kind), p->name, p->version, p->summary, info->path);
            if (info->problem)
                printf("  refused: %s\n", info->problem);
            printf(p->param_count == 0 ? "  no parameters\n" : "  parameters:\n");
            for (uint32_t j = 0; j < p->param_count; j++)
                print_param(&p->params[j]);
            shown++;
            continue;
        }
        if (!p)
            continue;
        printf("%-12s %-12s %-6s %s%s\n", rtk_kind_name(p->kind), p->name, p->version, p->summary,
               info->problem ? "  [refused, see below]" : "");
        for (uint32_t j = 0; j < p->param_count; j++)
            print_param(&p->params[j]);
        shown++;
    }
    if (!name) {
        for (size_t k = 0; k < n; k++) {
            const rtk_plugin_info *info = rtk_registry_at(reg, k);
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
    return 0;
}

/* "--threads N" for rtk_threads_limit's warning, the count capped unless oversubscribe. */
static uint32_t limit_threads(uint32_t n, int oversubscribe)
{
    char origin[48];
    snprintf(origin, sizeof origin, "--threads %u", n);
    return rtk_threads_limit(n, oversubscribe, origin);
}

/* rtk render CONFIG */
static int run_render(const cli_command *cmd, rtk_registry *reg, int argc, char **argv)
{
    const char *target = NULL;
    /* Each override, how messages name it, and the strings made here. */
    const char **overrides = calloc((size_t)argc + 2, sizeof *overrides);
    const char **labels = calloc((size_t)argc + 2, sizeof *labels);
    char **made = calloc((size_t)argc * 2 + 2, sizeof *made);
    char threads_entry[32] = "", threads_label[32] = "";
    size_t override_count = 0, made_count = 0;
    uint32_t threads = 0;
    int quiet = 0, status = 0;
    rtk_config_options copts;
    memset(&copts, 0, sizeof copts);
    copts.size = sizeof copts;
    if (!overrides || !labels || !made) {
        fprintf(stderr, "rtk: out of memory\n");
        status = 1;
        goto out;
    }
    cli_arg a;
    int i = 0, got;
    while ((got = next_arg(cmd, reg, argc, argv, &i, &a)) == 1) {
        if (!a.opt && !target) {
            target = a.value;
        } else if (!a.opt) {
            status = usage_error(cmd, "unexpected argument '%s' (one config per render)", a.value);
            goto out;
        } else if (is(&a, "--set")) {
            overrides[override_count++] = a.value;
        } else if (is(&a, "--output")) {
            /* -o names a file relative to the current directory, not to
             * the config's (where config paths are relative to). */
            char cwd[4096] = "";
            if (a.value[0] != '/' && !getcwd(cwd, sizeof cwd)) {
                fprintf(stderr, "rtk: cannot read the current directory for -o %s\n", a.value);
                status = 1;
                goto out;
            }
            size_t len = strlen(cwd) + strlen(a.value) + 32;
            char *entry = malloc(len), *label = malloc(len);
            if (entry)
                made[made_count++] = entry;
            if (label)
                made[made_count++] = label;
            if (!entry || !label) {
                fprintf(stderr, "rtk: out of memory\n");
                status = 1;
                goto out;
            }
            snprintf(entry, len, "film.output=%s%s%s", cwd, cwd[0] ? "/" : "", a.value);
            snprintf(label, len, "-o %s", a.value);
            labels[override_count] = label;
            overrides[override_count++] = entry;
        } else if (is(&a, "--threads")) {
            if (!parse_uint(a.value, 1, 1024, &threads)) {
                status = usage_error(cmd, "--threads needs a thread count in [1, 1024], not '%s'", a.value);
                goto out;
            }
            labels[override_count] = threads_label;
            overrides[override_count++] = threads_entry;
        } else if (is(&a, "--oversubscribe")) {
            copts.oversubscribe = 1;
        } else if (is(&a, "--no-cache")) {
            labels[override_count] = "--no-cache";
            overrides[override_count++] = "cache=off";
        } else if (is(&a, "--allow-config-plugins")) {
            copts.allow_config_plugins = 1;
        } else if (is(&a, "--allow-outside-files")) {
            copts.allow_outside_files = 1;
        } else if (is(&a, "--quiet")) {
            quiet = 1;
        }
    }
    if (got != 0) {
        status = got < 0 ? 0 : got;
        goto out;
    }
    if (!target) {
        status = usage_error(cmd, "render needs a config file");
        goto out;
    }
    if (threads) {
        snprintf(threads_entry, sizeof threads_entry, "threads=%u", limit_threads(threads, copts.oversubscribe));
        snprintf(threads_label, sizeof threads_label, "--threads %u", threads);
    }
    copts.overrides = overrides;
    copts.override_labels = labels;
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
out:
    for (size_t k = 0; k < made_count; k++)
        free(made[k]);
    free(made);
    free(labels);
    free(overrides);
    return status;
}

/* rtk bench MESH.obj|CONFIG.cfg */
static int run_bench(const cli_command *cmd, rtk_registry *reg, int argc, char **argv)
{
    const char *path = NULL;
    char *accel_items[64], *thread_items[64];
    const char *accels[64];
    uint32_t threads[64];
    int quiet = 0;
    rtk_bench_options o;
    memset(&o, 0, sizeof o);
    o.size = sizeof o;
    cli_arg a;
    int i = 0, got;
    while ((got = next_arg(cmd, reg, argc, argv, &i, &a)) == 1) {
        char *v = (char *)a.value; /* argv's own storage, split in place */
        if (!a.opt && !path) {
            path = v;
        } else if (!a.opt) {
            return usage_error(cmd, "unexpected argument '%s'", v);
        } else if (is(&a, "--quiet")) {
            quiet = 1;
        } else if (is(&a, "--allow-config-plugins")) {
            o.allow_config_plugins = 1;
        } else if (is(&a, "--allow-outside-files")) {
            o.allow_outside_files = 1;
        } else if (is(&a, "--oversubscribe")) {
            o.oversubscribe = 1;
        } else if (is(&a, "--accel")) {
            if ((got = split_list(cmd, "--accel", v, accel_items, 64, &o.accelerator_count)) != 0)
                return got;
            for (size_t k = 0; k < o.accelerator_count; k++)
                accels[k] = accel_items[k];
            o.accelerators = accels;
        } else if (is(&a, "--threads")) {
            if ((got = split_list(cmd, "--threads", v, thread_items, 64, &o.threads_count)) != 0)
                return got;
            for (size_t k = 0; k < o.threads_count; k++)
                if (!parse_uint(thread_items[k], 1, 1024, &threads[k]))
                    return usage_error(cmd, "--threads: '%s' is not a thread count in [1, 1024]", thread_items[k]);
            o.threads = threads;
        } else if (is(&a, "--width") || is(&a, "--height")) {
            if (!parse_uint(v, 1, 16384, is(&a, "--width") ? &o.width : &o.height))
                return usage_error(cmd, "%s needs a size in [1, 16384], not '%s'", a.opt->name, v);
        } else if (is(&a, "--runs")) {
            if (!parse_uint(v, 1, 1000, &o.runs))
                return usage_error(cmd, "--runs needs a count in [1, 1000], not '%s'", v);
        } else if (is(&a, "--csv")) {
            o.csv = v;
        } else if (is(&a, "--camera")) {
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
                return usage_error(cmd, "--camera needs 7 numbers EX,EY,EZ,LX,LY,LZ,FOV, not '%s'", v);
            memcpy(o.eye, c, sizeof o.eye);
            memcpy(o.look_at, c + 3, sizeof o.look_at);
            o.fov_deg = c[6];
            o.has_camera = 1;
        }
    }
    if (got != 0)
        return got < 0 ? 0 : got;
    if (!path)
        return usage_error(cmd, "bench needs a mesh (.obj) or a config (.cfg)");
    if ((o.width == 0) != (o.height == 0))
        return usage_error(cmd, "bench: give both --width and --height");
    /* Counts above the cores are capped; a count the capping repeats runs once. */
    size_t kept = 0;
    for (size_t k = 0; k < o.threads_count; k++) {
        uint32_t t = limit_threads(threads[k], o.oversubscribe);
        int seen = 0;
        for (size_t j = 0; j < kept; j++)
            seen |= threads[j] == t;
        if (!seen)
            threads[kept++] = t;
    }
    o.threads_count = kept;
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


/* rtk diff A B */
static int run_diff(const cli_command *cmd, rtk_registry *reg, int argc, char **argv)
{
    const char *files[2] = {NULL, NULL};
    int csv = 0;
    rtk_diff_options o;
    memset(&o, 0, sizeof o);
    o.size = sizeof o;
    cli_arg a;
    int i = 0, got;
    while ((got = next_arg(cmd, reg, argc, argv, &i, &a)) == 1) {
        if (!a.opt && !files[0]) {
            files[0] = a.value;
        } else if (!a.opt && !files[1]) {
            files[1] = a.value;
        } else if (!a.opt) {
            return usage_error(cmd, "unexpected argument '%s'", a.value);
        } else if (is(&a, "--csv")) {
            csv = 1;
        } else if (is(&a, "--error-image")) {
            o.error_image = a.value;
        } else if (is(&a, "--epsilon")) {
            char *end;
            o.epsilon = strtod(a.value, &end);
            if (end == a.value || *end || !(o.epsilon > 0.0) || isinf(o.epsilon))
                return usage_error(cmd, "--epsilon needs a finite number > 0, not '%s'", a.value);
        }
    }
    if (got != 0)
        return got < 0 ? 0 : got;
    if (!files[1])
        return usage_error(cmd, "diff needs two images: the one to check, then the reference");
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

/* rtk sweep CONFIG */
static int run_sweep(const cli_command *cmd, rtk_registry *reg, int argc, char **argv)
{
    const char *path = NULL;
    static rtk_sweep_axis axes[SWEEP_MAX_AXES];
    static char *values[SWEEP_MAX_AXES][SWEEP_MAX_VALUES];
    static char origins[SWEEP_MAX_AXES][216];
    static uint32_t spp[SWEEP_MAX_VALUES];
    char *spp_items[SWEEP_MAX_VALUES];
    int quiet = 0;
    const char **overrides = calloc((size_t)argc + 1, sizeof *overrides);
    if (!overrides) {
        fprintf(stderr, "rtk: out of memory\n");
        return 1;
    }
    int status = 0;
    rtk_sweep_options o;
    memset(&o, 0, sizeof o);
    o.size = sizeof o;
    o.axes = axes;
    o.overrides = overrides;
    cli_arg a;
    int i = 0, got;
    while ((got = next_arg(cmd, reg, argc, argv, &i, &a)) == 1) {
        char *v = (char *)a.value; /* argv's own storage, split in place */
        const char *axis_key = is(&a, "--samplers")       ? "sampler.type"
                               : is(&a, "--filters")      ? "filter.plugin"
                               : is(&a, "--accelerators") ? "accelerator.plugin"
                                                          : NULL;
        if (!a.opt && !path) {
            path = v;
        } else if (!a.opt) {
            status = usage_error(cmd, "unexpected argument '%s'", v);
            goto out;
        } else if (is(&a, "--quiet")) {
            quiet = 1;
        } else if (is(&a, "--allow-config-plugins")) {
            o.allow_config_plugins = 1;
        } else if (is(&a, "--allow-outside-files")) {
            o.allow_outside_files = 1;
        } else if (is(&a, "--oversubscribe")) {
            o.oversubscribe = 1;
        } else if (is(&a, "--set")) {
            overrides[o.override_count++] = v;
        } else if (axis_key || is(&a, "--param")) {
            if (o.axis_count == SWEEP_MAX_AXES) {
                status = usage_error(cmd, "at most %d axes", SWEEP_MAX_AXES);
                goto out;
            }
            rtk_sweep_axis *ax = &axes[o.axis_count];
            ax->origin = a.opt->name;
            ax->key = axis_key;
            char *list = v;
            if (!axis_key) {
                char *eq = strchr(v, '=');
                if (!eq || eq == v || !eq[1]) {
                    status = usage_error(cmd, "--param needs KEY=V1,V2,..., e.g. integrator.rays=1,4, not '%s'", v);
                    goto out;
                }
                *eq = '\0';
                ax->key = v;
                list = eq + 1;
                snprintf(origins[o.axis_count], sizeof origins[0], "--param %.200s", v);
                ax->origin = origins[o.axis_count];
            }
            if ((status = split_list(cmd, a.opt->name, list, values[o.axis_count], SWEEP_MAX_VALUES,
                                     &ax->value_count)) != 0)
                goto out;
            ax->values = (const char *const *)values[o.axis_count];
            o.axis_count++;
        } else if (is(&a, "--spp")) {
            if ((status = split_list(cmd, "--spp", v, spp_items, SWEEP_MAX_VALUES, &o.spp_count)) != 0)
                goto out;
            for (size_t k = 0; k < o.spp_count; k++)
                if (!parse_uint(spp_items[k], 1, 1u << 20, &spp[k])) {
                    status = usage_error(cmd, "--spp: '%s' is not a sample count in [1, 1048576]", spp_items[k]);
                    goto out;
                }
            o.spp = spp;
        } else if (is(&a, "--seeds")) {
            if (!parse_uint(v, 1, 100000, &o.seeds)) {
                status = usage_error(cmd, "--seeds needs a count in [1, 100000], not '%s'", v);
                goto out;
            }
        } else if (is(&a, "--threads")) {
            if (!parse_uint(v, 1, 1024, &o.threads)) {
                status = usage_error(cmd, "--threads needs a thread count in [1, 1024], not '%s'", v);
                goto out;
            }
        } else if (is(&a, "--reference-spp")) {
            if (!parse_uint(v, 1, 1u << 20, &o.reference_spp)) {
                status = usage_error(cmd, "--reference-spp needs a sample count in [1, 1048576], not '%s'", v);
                goto out;
            }
        } else if (is(&a, "--target-relmse")) {
            char *end;
            o.target_relmse = strtod(v, &end);
            if (end == v || *end || !(o.target_relmse > 0.0) || isinf(o.target_relmse)) {
                status = usage_error(cmd, "--target-relmse needs a finite number > 0, not '%s'", v);
                goto out;
            }
        } else if (is(&a, "--out")) {
            o.out_dir = v;
        } else if (is(&a, "--reference")) {
            o.reference = v;
        } else if (is(&a, "--reference-filter")) {
            o.reference_filter = v;
        } else if (is(&a, "--plot")) {
            o.plot = 1;
        } else if (is(&a, "--no-plot")) {
            o.plot = -1;
        } else if (is(&a, "--bvh-cache")) {
            o.bvh_cache = 1;
        }
    }
    if (got != 0) {
        status = got < 0 ? 0 : got;
        goto out;
    }
    if (!path) {
        status = usage_error(cmd, "sweep needs a config file");
        goto out;
    }
    if (o.threads)
        o.threads = limit_threads(o.threads, o.oversubscribe);
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

/* rtk conform PLUGIN */
static int run_conform(const cli_command *cmd, rtk_registry *reg, int argc, char **argv)
{
    const char *what;
    int status = parse_operand(cmd, reg, argc, argv, &what);
    if (status >= 0)
        return status;
    if (!what)
        return usage_error(cmd, "conform needs a plugin path or name");
    const char *path = what;
    if (!strchr(what, '/')) {
        /* A bare name: the first plugin of any kind with that name. */
        path = NULL;
        size_t n = rtk_registry_count(reg);
        for (size_t k = 0; k < n && !path; k++) {
            const rtk_plugin_info *info = rtk_registry_at(reg, k);
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
    return st == RTK_OK ? 0 : st == RTK_ERR_UNSUPPORTED ? 77 : 1; /* 77: skipped (meson's and automake's code) */
}

/* The usage error for a command that does not exist, with the closest one. */
static int unknown_command(const char *name)
{
    const char *near = rtk_suggest(name, &commands[0].name, COMMAND_COUNT, sizeof commands[0]);
    char list[256] = "";
    size_t used = 0;
    for (size_t k = 0; k < COMMAND_COUNT; k++)
        used += (size_t)snprintf(list + used, sizeof list - used, "%s%s", k ? ", " : "", commands[k].name);
    if (near)
        return usage_error(NULL, "unknown command '%s' (did you mean '%s'?); commands: %s", name, near, list);
    return usage_error(NULL, "unknown command '%s'; commands: %s", name, list);
}

/* rtk help [COMMAND] */
static int run_help(const cli_command *cmd, rtk_registry *reg, int argc, char **argv)
{
    const char *about;
    int status = parse_operand(cmd, reg, argc, argv, &about);
    if (status >= 0)
        return status;
    if (!about) {
        print_overview(stdout);
        return 0;
    }
    const cli_command *c = find_command(about);
    if (!c)
        return unknown_command(about);
    print_command_help(c);
    return 0;
}

/* rtk version */
static int run_version(const cli_command *cmd, rtk_registry *reg, int argc, char **argv)
{
    const char *extra;
    int status = parse_operand(cmd, reg, argc, argv, &extra);
    if (status >= 0)
        return status;
    if (extra)
        return usage_error(cmd, "unexpected argument '%s'", extra);
    print_version();
    return 0;
}

/* Index in argv of the command word: the first argument that is neither
 * an option nor the value of one given before it (rtk -q render ...), or
 * argc when there is none; *status is set for an unknown option there. */
static int find_command_word(int argc, char **argv, int *status)
{
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (a[0] != '-' || a[1] == '\0')
            return i;
        const char *inline_value;
        const cli_option *o = NULL;
        for (size_t k = 0; k < COMMAND_COUNT && !o; k++)
            o = lookup_option(&commands[k], a, &inline_value);
        if (!o) {
            *status = unknown_option(NULL, a);
            return argc;
        }
        if (o->value && !inline_value)
            i++;
    }
    return argc;
}

static atomic_flag interrupted = ATOMIC_FLAG_INIT;

/* SIGINT/SIGTERM: librtk removes its temporaries and says what was
 * interrupted, then rtk dies of the signal itself, so that a shell reads
 * 128 + sig (130, 143) and stops a loop running rtk. */
static void on_interrupt(int sig)
{
    if (atomic_flag_test_and_set(&interrupted))
        for (;;)
            pause(); /* a second signal, on another thread, waits for the first */
    rtk_interrupt_cleanup(sig);
    signal(sig, SIG_DFL);
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, sig);
    pthread_sigmask(SIG_UNBLOCK, &set, NULL);
    raise(sig);
    _exit(128 + sig);
}

/* Handles SIGINT and SIGTERM, except one the process ignores (nohup,
 * background jobs keep ignoring it). */
static void install_interrupt_handlers(void)
{
    static const int sigs[] = {SIGINT, SIGTERM};
    for (size_t i = 0; i < sizeof sigs / sizeof *sigs; i++) {
        struct sigaction old, sa;
        if (sigaction(sigs[i], NULL, &old) != 0 || (!(old.sa_flags & SA_SIGINFO) && old.sa_handler == SIG_IGN))
            continue;
        memset(&sa, 0, sizeof sa);
        sa.sa_handler = on_interrupt;
        sigemptyset(&sa.sa_mask);
        sigaddset(&sa.sa_mask, SIGINT);
        sigaddset(&sa.sa_mask, SIGTERM);
        if (sigaction(sigs[i], &sa, NULL) != 0)
            fprintf(stderr, "rtk: warning: cannot handle signal %d; an interrupt may leave temporary files\n", sigs[i]);
    }
}

int main(int argc, char **argv)
{
    rtk_registry *reg = NULL;
    char **rest = calloc((size_t)argc + 1, sizeof *rest);
    if (!rest || rtk_registry_create(&reg) != RTK_OK) {
        fprintf(stderr, "rtk: out of memory\n");
        free(rest);
        return 1;
    }
    install_interrupt_handlers();
    int status = 0;
    int word = find_command_word(argc, argv, &status);
    if (status == 0 && word == argc) {
        /* No command: rtk --version, rtk --help, else the overview as a usage error. */
        int version = 0, help = 0;
        for (int i = 1; i < argc; i++) {
            version |= strcmp(argv[i], "--version") == 0;
            help |= strcmp(argv[i], "-h") == 0 || strcmp(argv[i], "--help") == 0;
        }
        if (version)
            print_version();
        else
            print_overview(help ? stdout : stderr);
        status = version || help ? 0 : 2;
    } else if (status == 0) {
        const cli_command *cmd = find_command(argv[word]);
        if (!cmd) {
            status = unknown_command(argv[word]);
        } else {
            /* The command's arguments: those before its name, then those after. */
            int n = 0;
            for (int i = 1; i < argc; i++)
                if (i != word)
                    rest[n++] = argv[i];
            status = cmd->run(cmd, reg, n, rest);
        }
    }
    free(rest);
    rtk_registry_destroy(reg);
    return status;
}

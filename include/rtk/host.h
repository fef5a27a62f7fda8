/* The embedding API of librtk: what the `rtk` command, the tests and any
 * program that drives renders call. Plugins never need this header.
 * Functions run on the calling thread unless marked otherwise. */
#ifndef RTK_HOST_H
#define RTK_HOST_H

#include <stdio.h>
#include <rtk/rtk.h>

RTK_EXTERN_C_BEGIN

/* Lines above this level are not printed (default RTK_LOG_INFO). */
RTK_API void rtk_log_set_level(rtk_log_level level);

/* The set of plugins a run may use: the build tree or the installed plugin
 * directory (whichever matches the running librtk), then each directory in
 * RTK_PLUGIN_PATH, then any added with rtk_registry_add_dir. */
typedef struct rtk_registry rtk_registry;

/* One plugin file found while scanning. */
typedef struct rtk_plugin_info {
    const char *path;         /* absolute path of the .so */
    const rtk_plugin *plugin; /* its descriptor, NULL if it was refused */
    const char *problem;      /* why it was refused, NULL if it is usable */
} rtk_plugin_info;

/* New registry with the default directories. [caller frees] */
RTK_API rtk_status rtk_registry_create(rtk_registry **out);
RTK_API void rtk_registry_destroy(rtk_registry *registry);

/* Adds a directory to search; origin says where it came from, for messages
 * ("config plugin_path", "--plugin-path"). */
RTK_API void rtk_registry_add_dir(rtk_registry *registry, const char *dir, const char *origin);

/* Number of plugin files found, scanning the directories on first use. */
RTK_API size_t rtk_registry_count(rtk_registry *registry);

/* The i-th plugin file found, sorted by kind then name. */
RTK_API const rtk_plugin_info *rtk_registry_at(rtk_registry *registry, size_t i);

/* Finds a usable plugin of the given kind by name. On failure the error
 * lists the directories searched and the plugins of that kind that exist. */
RTK_API rtk_status rtk_registry_find(rtk_registry *registry, rtk_plugin_kind kind,
                                     const char *name, const rtk_plugin **out);

/* Loads one plugin file and checks its descriptor (entry point, ABI,
 * kind when expected != 0, function table, schema). The library stays
 * loaded for the life of the process. */
RTK_API rtk_status rtk_plugin_open(const char *path, rtk_plugin_kind expected,
                                   const rtk_plugin **out);

/* Name of a kind: "integrator", "accelerator", "filter". */
RTK_API const char *rtk_kind_name(rtk_plugin_kind kind);

/* A loaded, validated config (opaque). */
typedef struct rtk_config rtk_config;

/* How far to trust a config. */
typedef struct rtk_config_options {
    uint32_t size;                /* sizeof(rtk_config_options) */
    int allow_config_plugins;     /* honour plugin_path and plugins given as paths */
    const char *const *overrides; /* "integrator.rays=64" ... */
    size_t override_count;
    int allow_outside_files;      /* let the scene read files outside its and the config's folders */
    int oversubscribe;            /* let threads exceed the online cores (see rtk_threads_limit) */
} rtk_config_options;

/* Parses path, applies overrides, resolves the plugins through registry
 * and validates every value against the schemas. Errors name the file and
 * line. [caller frees with rtk_config_destroy] */
RTK_API rtk_status rtk_config_load(const char *path, rtk_registry *registry,
                                   const rtk_config_options *options, rtk_config **out);
RTK_API void rtk_config_destroy(rtk_config *config);

/* The number of threads to run when wanted are asked for (0: one per
 * core): wanted itself up to the number of online cores; above it, the
 * core count, with a warning (once per process) that names origin
 * ("--threads 999", "scene.cfg:3") and how to keep wanted, unless
 * oversubscribe. */
RTK_API uint32_t rtk_threads_limit(uint32_t wanted, int oversubscribe, const char *origin);

/* The name closest to word by edit distance among count names, or NULL
 * when none is close enough to be a typo of it: for "did you mean"
 * messages. The names lie stride bytes apart from names[0], so an array of
 * structs whose first member is the name serves as well as an array of
 * strings (stride sizeof(const char *)); NULL entries are skipped. */
RTK_API const char *rtk_suggest(const char *word, const char *const *names, size_t count, size_t stride);

/* Options of one render. */
typedef struct rtk_render_options {
    uint32_t size;  /* sizeof(rtk_render_options) */
    int quiet;      /* no progress bar */
    int progress;   /* draw a progress bar on stderr (caller checks isatty) */
} rtk_render_options;

/* What a render did, for the closing report. */
typedef struct rtk_render_report {
    uint32_t size;           /* sizeof(rtk_render_report), set by the caller */
    double load_seconds, build_seconds, render_seconds, write_seconds;
    uint64_t rays;           /* rays traced (camera, shadow, secondary) */
    uint64_t invalid_rays;   /* rays rejected as NaN/zero/empty */
    uint64_t bad_samples;    /* NaN/Inf radiance samples dropped */
    uint32_t triangles;
    uint32_t width, height, spp, threads;
    uint32_t bvh_nodes, bvh_depth;
    double mean[3];          /* mean linear RGB of the image */
    size_t peak_rss_bytes;   /* peak resident memory of the process */
    char output[1024];       /* the file written */
    int bvh_from_cache;      /* 1: the BVH was loaded from bvh_cache_file */
    char bvh_cache_file[1024]; /* cache file loaded or written, "" when none */
    uint32_t instances;      /* placed meshes (two-level instancing), 0 when none */
    uint32_t meshes;         /* distinct instanced meshes */
    uint64_t placed_triangles; /* triangles the instances place (each counted per instance) */
    size_t geometry_bytes;   /* vertices, triangles, normals, uvs; each mesh once */
    size_t bvh_bytes;        /* every BVH: the scene's, each mesh's once */
    size_t instance_bytes;   /* instance records and the top-level BVH */
    uint32_t textures;       /* images the scene's materials refer to */
    uint32_t textures_decoded; /* of those, decoded (integrator reads textures, or alpha cutouts) */
} rtk_render_report;

/* Loads the scene, builds the BVH, renders and writes the image(s). */
RTK_API rtk_status rtk_render(const rtk_config *config, const rtk_render_options *options,
                              rtk_render_report *report);

/* Prints the closing report to f. */
RTK_API void rtk_render_report_print(const rtk_render_report *report, FILE *f);

/* Runs the conformance checks for a plugin file, one line per check to out,
 * then "N passed, N failed". Returns RTK_OK only when every check passed. */
RTK_API rtk_status rtk_conform(const char *path, FILE *out, int *passed, int *failed);

/* What `rtk bench` measures; zero fields mean the defaults. */
typedef struct rtk_bench_options {
    uint32_t size;                    /* sizeof(rtk_bench_options) */
    const char *const *accelerators;  /* "sah", "embree:quality=low"; NULL: the config's, or every one found */
    size_t accelerator_count;
    const uint32_t *threads;          /* thread counts to run; NULL: 1 and every core */
    size_t threads_count;
    uint32_t width, height;           /* 0: the config's film, else 1024 x 768 */
    int has_camera;                   /* 1: the camera below, else the config's or the recipe's */
    double eye[3], look_at[3];        /* world up is +y */
    double fov_deg;                   /* vertical */
    uint32_t runs;                    /* builds and timed passes, the median reported; 0: 5 */
    const char *csv;                  /* also write one row per accelerator x threads here */
    int progress;                     /* progress on stderr (the caller checks isatty) */
    int allow_config_plugins;         /* as in rtk_config_options */
    int allow_outside_files;          /* as in rtk_config_options */
    int oversubscribe;                /* as in rtk_config_options */
} rtk_bench_options;

/* Benchmarks accelerators on a mesh (.obj, read as the standard recipe
 * says, docs/bench-vs-embree.md) or a config's scene (.cfg) with the recipe's primary and
 * AO rays: builds each through the kernel, traces on each thread count,
 * prints a table (and ratios to embree when it is among them) to out. */
RTK_API rtk_status rtk_bench(const char *path, rtk_registry *registry, const rtk_bench_options *options,
                             FILE *out);

/* Image comparison behind `rtk diff` (kernel/diff.c). a is the image under
 * test, b the reference. Over the N sample pairs of a channel where both
 * values are finite, with e = epsilon:
 *   mean_error = sum(a - b) / N            mse = sum((a - b)^2) / N
 *   rmse = sqrt(mse)                       relmse = sum((a - b)^2 / (b^2 + e)) / N
 *   mape = sum(|a - b| / (|b| + e)) / N    smape = sum(2 |a - b| / (|a| + |b| + e)) / N
 *   psnr = 10 log10(peak^2 / mse), peak 1.0 (+inf when mse = 0)
 * Sums are kept in double; every metric is NaN when N = 0. */
#define RTK_DIFF_EPSILON 1e-2
#define RTK_DIFF_MAX_CHANNELS 16

/* Metrics of one channel, or of the colour channels pooled. */
typedef struct rtk_diff_channel {
    char name[32];
    uint64_t samples;      /* pairs compared (N) */
    uint64_t excluded;     /* pairs left out because a or b is NaN or Inf */
    uint64_t nonfinite_a;  /* samples where a is NaN or Inf */
    uint64_t nonfinite_b;  /* samples where b is NaN or Inf */
    double mean_error, mse, rmse, relmse, mape, smape, psnr;
} rtk_diff_channel;

/* How to compare; zero fields mean the defaults. */
typedef struct rtk_diff_options {
    uint32_t size;              /* sizeof(rtk_diff_options) */
    double epsilon;             /* > 0; 0: RTK_DIFF_EPSILON */
    uint32_t colour_channels;   /* the first N channels are pooled into overall; 0: up to 3 */
    const char *error_image;    /* also write the per-pixel error here (see rtk_diff_buffers) */
} rtk_diff_options;

/* What a comparison found. */
typedef struct rtk_diff_result {
    uint32_t size;              /* sizeof(rtk_diff_result), set by the caller */
    int compared;               /* 1 once the metrics are filled in */
    uint32_t width, height;
    uint32_t channel_count;
    uint32_t colour_channels;   /* channels [0, colour_channels) make overall */
    double epsilon;
    double peak;                /* PSNR peak: 1.0 */
    rtk_diff_channel channels[RTK_DIFF_MAX_CHANNELS];
    rtk_diff_channel overall;   /* every finite pair of the colour channels, pooled */
} rtk_diff_result;

/* Compares a with b, each width x height pixels of channel_count
 * interleaved floats (rows from the top); names (may be NULL: R, G, B, A,
 * C4, ...) label the channels. The error image, when asked for, is written
 * through rtk_image_write (temporary file, then rename): for .exr, plain
 * floats |a - b| per channel; for any other extension, a heat map of the
 * pixel's mean relative error |a - b| / (|b| + e) over the colour channels
 * on a log ramp: grey <= 1e-3, blue 1e-2, yellow 1e-1, red >= 1, magenta
 * where a value is NaN or Inf. */
RTK_API rtk_status rtk_diff_buffers(const float *a, const float *b, uint32_t width, uint32_t height,
                                    uint32_t channel_count, const char *const *names,
                                    const rtk_diff_options *options, rtk_diff_result *out);

/* Reads two image files (any format OpenImageIO reads; 8/16-bit data
 * decoded to linear, greyscale replicated to RGB, missing alpha = 1) and
 * compares R, G, B, A with overall over R, G, B. Errors name the file and
 * the reason, or both files and both sizes when the sizes differ. */
RTK_API rtk_status rtk_diff_files(const char *test, const char *reference,
                                  const rtk_diff_options *options, rtk_diff_result *out);

/* Speed against error behind `rtk sweep` (kernel/sweep.c). A sweep renders
 * every combination of its axes at each spp and seed through rtk_render,
 * compares each image with a reference, and writes into out_dir:
 *   sweep.csv  one row per run          sweep.txt  the table printed to out
 *   sweep.dat  means over seeds, per combination and spp (gnuplot data)
 *   sweep.gp   the gnuplot script       sweep.png  its plot
 *   reference-HASH.exr  the rendered reference, reused while HASH matches
 * each through a temporary sibling and a rename. */

/* One axis: a setting and its values, each applied as an override
 * "key=value" (rtk render's --set) on top of the config. */
typedef struct rtk_sweep_axis {
    const char *key;              /* "sampler.type", "filter.plugin", "integrator.rays", ... */
    const char *const *values;
    size_t value_count;
    const char *origin;           /* where it came from, for messages ("--samplers"); NULL: key */
} rtk_sweep_axis;

/* What to sweep; zero fields mean the defaults. */
typedef struct rtk_sweep_options {
    uint32_t size;                        /* sizeof(rtk_sweep_options) */
    const rtk_sweep_axis *axes;           /* combinations: every tuple, the first axis varying slowest */
    size_t axis_count;                    /* 0: the config alone */
    const uint32_t *spp;                  /* increasing; NULL: 1, 2, 4, ..., 64 */
    size_t spp_count;
    uint32_t seeds;                       /* runs per combination and spp, seeds 1..N; 0: 4 */
    uint32_t threads;                     /* 0: the config's */
    double target_relmse;                 /* time-to-error target; 0: 1e-3 */
    const char *out_dir;                  /* created when missing; NULL: "sweep" */
    const char *reference;                /* image to compare with; NULL: render one (see reference_spp) */
    uint32_t reference_spp;               /* 0: 64 x the largest spp, at least 4096, at most 65536 */
    const char *reference_filter;         /* the reference's filter; NULL: "box"; "same": each combination's */
    const char *const *overrides;         /* "key=value" applied before the axes, to every render */
    size_t override_count;
    int allow_config_plugins;             /* as in rtk_config_options */
    int plot;                             /* 0: run gnuplot when found; 1: required (error if missing); -1: script only */
    int bvh_cache;                        /* 1: keep the config's BVH cache; 0: cache=off, so build_s is a build */
    int progress;                         /* progress bar on stderr (the caller checks isatty) */
    int allow_outside_files;              /* as in rtk_config_options */
    int oversubscribe;                    /* as in rtk_config_options */
} rtk_sweep_options;

/* Runs the sweep of the config at path: validates every axis value and
 * combination first (an error names the axis and value), renders or reuses
 * the reference (independent sampler, options->reference_filter, its own
 * seed, reference_spp; the axes under sampler., accelerator. and, with a
 * box reference, filter. left out), then the runs, and prints per
 * combination the convergence slopes and the time to target_relmse to out
 * (may be NULL). Nothing half-written is left behind on failure. */
RTK_API rtk_status rtk_sweep(const char *path, rtk_registry *registry, const rtk_sweep_options *options,
                             FILE *out);

/* Least-squares slope of log y against log x over n >= 2 points; every x
 * and y finite and > 0, the x not all equal. */
RTK_API rtk_status rtk_sweep_fit_slope(const double *x, const double *y, size_t n, double *slope);

/* Where a target error falls among measured points. */
typedef enum rtk_sweep_reach {
    RTK_SWEEP_REACHED = 0,     /* between two points: log-log interpolated */
    RTK_SWEEP_NOT_REACHED = 1, /* every error is above the target */
    RTK_SWEEP_AT_FIRST = 2,    /* the first point is already at or below it: its seconds, an upper bound */
    RTK_SWEEP_NO_DATA = 3      /* n = 0, or a value not finite, or seconds <= 0, or error < 0 */
} rtk_sweep_reach;

/* Seconds to reach target (> 0) along points (seconds[i], error[i]) in run
 * order (increasing spp): the first step from an error above target to one
 * at or below it, interpolated linearly in log(seconds) against
 * log(error); an error of 0 at the step's end gives that point's seconds.
 * *out is set for REACHED and AT_FIRST. Never extrapolates. */
RTK_API rtk_sweep_reach rtk_sweep_time_to_error(const double *seconds, const double *error, size_t n,
                                                double target, double *out);

/* For a program's SIGINT/SIGTERM handler: removes rtk's temporary files
 * (the previous outputs stay as they were) and prints one line to stderr
 * saying what was interrupted ("rtk: interrupted by SIGINT while rendering;
 * 'out.png' was not written"). It returns; ending the process is the
 * program's choice (the rtk command re-raises the signal, so that a shell
 * reads 130 or 143). librtk never installs signal handlers itself.
 * [async-signal-safe] */
RTK_API void rtk_interrupt_cleanup(int sig);

RTK_EXTERN_C_END

#endif

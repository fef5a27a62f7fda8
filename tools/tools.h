/* The tools built on librtk, in the rtk_tools library the `rtk` command and
 * the tests link: the plugin conformance runner (conform/), the accelerator
 * benchmark (bench/), image comparison (diff/) and the speed-against-error
 * sweep (sweep/). They are not part of librtk.so. */
#ifndef RTK_TOOLS_H
#define RTK_TOOLS_H

#include <stdio.h>
#include <rtk/host.h>

RTK_EXTERN_C_BEGIN

/* Runs the conformance checks for a plugin file, one line per check to out,
 * then "N passed, N failed". Returns RTK_OK when every check passed,
 * RTK_ERR_UNSUPPORTED when none failed but some could not run here (a
 * "skip" line says why: a device accelerator without its device). */
rtk_status rtk_conform(const char *path, FILE *out, int *passed, int *failed);

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
rtk_status rtk_bench(const char *path, rtk_registry *registry, const rtk_bench_options *options,
                     FILE *out);

/* Image comparison behind `rtk diff` (tools/diff/diff.c). a is the image under
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
rtk_status rtk_diff_buffers(const float *a, const float *b, uint32_t width, uint32_t height,
                            uint32_t channel_count, const char *const *names,
                            const rtk_diff_options *options, rtk_diff_result *out);

/* Reads two image files (the formats rtk_image_read decodes; 8/16-bit data
 * decoded to linear, greyscale replicated to RGB, missing alpha = 1) and
 * compares R, G, B, A with overall over R, G, B. Errors name the file and
 * the reason, or both files and both sizes when the sizes differ. */
rtk_status rtk_diff_files(const char *test, const char *reference,
                          const rtk_diff_options *options, rtk_diff_result *out);

/* Speed against error behind `rtk sweep` (tools/sweep/sweep.c). A sweep renders
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
rtk_status rtk_sweep(const char *path, rtk_registry *registry, const rtk_sweep_options *options,
                     FILE *out);

/* Least-squares slope of log y against log x over n >= 2 points; every x
 * and y finite and > 0, the x not all equal. */
rtk_status rtk_sweep_fit_slope(const double *x, const double *y, size_t n, double *slope);

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
rtk_sweep_reach rtk_sweep_time_to_error(const double *seconds, const double *error, size_t n,
                                        double target, double *out);

RTK_EXTERN_C_END

#endif

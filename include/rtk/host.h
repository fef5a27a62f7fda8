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
    int oversubscribe;            /* let threads exceed the cores this process may use (see rtk_threads_limit) */
    const char *const *override_labels; /* NULL, or per override how messages name it ("-o out.png"; NULL entry: "--set ENTRY") */
} rtk_config_options;

/* Parses path, applies overrides, resolves the plugins through registry
 * and validates every value against the schemas. Errors name the file and
 * line. [caller frees with rtk_config_destroy] */
RTK_API rtk_status rtk_config_load(const char *path, rtk_registry *registry,
                                   const rtk_config_options *options, rtk_config **out);
RTK_API void rtk_config_destroy(rtk_config *config);

/* The number of threads to run when wanted are asked for (0: one per
 * core): wanted itself up to the number of cores this process may use (online,
 * in its CPU affinity and its cgroup's CPU quota); above it, the
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
    int on_device;           /* 1: a device accelerator traced the batches (device below) */
    rtk_device_report device; /* its report after the render (the tree's upload is the build's) */
} rtk_render_report;

/* Loads the scene, builds the BVH, renders and writes the image(s). */
RTK_API rtk_status rtk_render(const rtk_config *config, const rtk_render_options *options,
                              rtk_render_report *report);

/* Prints the closing report to f. */
RTK_API void rtk_render_report_print(const rtk_render_report *report, FILE *f);

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

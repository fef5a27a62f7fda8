/* The plugin ABI: one exported entry point per shared object returning a
 * const descriptor. Every struct crossing the boundary starts with its size
 * and only ever grows at the end; the kernel refuses a different ABI major
 * and a minor newer than its own. */
#ifndef RTK_PLUGIN_H
#define RTK_PLUGIN_H

#include <rtk/params.h>

RTK_EXTERN_C_BEGIN

/* 3.0: rtk_hit and rtk_light_sample carry the instance hit, and
 * rtk_scene_light_pdf takes the hit (two-level instancing).
 * 3.1: ray differentials and texture footprints (rtk_ray_differential,
 * rtk_ctx_camera_differential, rtk_surface_at_footprint,
 * rtk_differential_reflect, rtk_differential_refract); rtk_plugin.conform
 * (the exact-test profile of an integrator).
 * 3.2: teams of threads on the kernel's workers (rtk_team_run,
 * rtk_team_sync; rtk/parallel.h); rtk_accelerator_fns.build_flags
 * (RTK_BUILD_NO_VERTICES, RTK_BUILD_NO_BOUNDS, and later
 * RTK_BUILD_SPARSE_NODES, a hint older 3.2 kernels ignore);
 * rtk_build_args.indices, positions, vertex_count, scratch and
 * scratch_bytes; rtk_plugin.conform is a comma-separated list of the
 * profile names docs/conform.md gives (a 3.1 descriptor's one name keeps
 * its 3.1 meaning).
 * 3.3: rtk_shadow_ray (rtk/lights.h), the shadow ray between two points
 * offset each along its own surface's normal; BSDFs (rtk/bsdf.h:
 * rtk_bsdf_eval, rtk_bsdf_sample, rtk_bsdf_pdf, rtk_bsdf_flags;
 * rtk_surface_bsdf, a hit's material as a BSDF);
 * rtk_sample_seek (rtk/sampler.h), draws by dimension; all lights as one
 * service (rtk/lights.h: rtk_sample_incident_light, rtk_incident_light_pdf,
 * rtk_scene_environment, rtk_spot_falloff).
 * 3.4: ray batches (rtk_trace_batch, rtk_occluded_batch;
 * rtk_integrator_fns.li_batch with rtk_ctx_select;
 * rtk_accelerator_fns.closest_batch and any_batch); build phases
 * (rtk_build_args.phase_log, rtk_build_phase).
 * 3.5: device accelerators (rtk_accelerator_fns.attach and report,
 * rtk_device_tree, rtk_device_instance, rtk_device_report).
 * 3.6: device programs (rtk_integrator_fns.device_program,
 * rtk_device_program; rtk_accelerator_fns.shade, rtk_shade_batch;
 * rtk_device_tree.normals; rtk_device_report.samples, shade_seconds).
 * 3.7: device programs that sample lights and shade instances
 * (rtk_device_tree.materials, lights, punctual, punctual_count, frames;
 * rtk_device_frame).
 * 3.8: device programs that read textures (rtk_device_tree.uvs, uvs1,
 * textures, texture_count).
 * 3.9: device programs that read trilinear textures (rtk_device_tree.texture_levels,
 * rtk_device_texture.levels, rtk_shade_batch.diffs). */
#define RTK_ABI_MAJOR 3
#define RTK_ABI_MINOR 9

/* Name of the one symbol a plugin exports. */
#define RTK_PLUGIN_ENTRY_NAME "rtk_plugin_entry"

/* The plugin kinds; each has its function table in its own header. */
typedef enum rtk_plugin_kind {
    RTK_KIND_INTEGRATOR = 1,  /* rtk_integrator_fns, rtk/integrator.h */
    RTK_KIND_ACCELERATOR = 2, /* rtk_accelerator_fns, rtk/accelerator.h */
    RTK_KIND_FILTER = 3       /* rtk_filter_fns, rtk/filter.h */
} rtk_plugin_kind;

/* What a plugin is; returned by its entry point, never freed. */
typedef struct rtk_plugin {
    uint32_t size;                /* sizeof(rtk_plugin) the plugin was built with */
    uint16_t abi_major, abi_minor;
    rtk_plugin_kind kind;
    const char *name;             /* name used in configs; equals the file name */
    const char *version;          /* the plugin's own version, e.g. "1.0" */
    const char *summary;          /* one line for `rtk plugins` */
    const rtk_param_desc *params; /* parameter schema */
    uint32_t param_count;
    const void *functions;        /* the kind's function table */
    /* 3.1: integrators: the known-answer profiles rtk conform runs after
     * the generic checks, comma-separated profile names that say what the
     * integrator computes, e.g. "ambient-occlusion"; NULL: generic checks
     * only. docs/conform.md lists the profiles and the parameters each sets,
     * which the plugin must declare; the others stay at their defaults. */
    const char *conform;
} rtk_plugin;

/* Signature of the entry point. */
typedef const rtk_plugin *(*rtk_plugin_entry_fn)(void);

/* Fills the descriptor's ABI fields: `{ RTK_PLUGIN_HEADER, .kind = ... }`. */
#define RTK_PLUGIN_HEADER .size = sizeof(rtk_plugin), .abi_major = RTK_ABI_MAJOR, .abi_minor = RTK_ABI_MINOR

/* Number of entries of a static schema array. */
#define RTK_COUNTOF(a) ((uint32_t)(sizeof(a) / sizeof((a)[0])))

/* Defines the plugin's entry point returning &descriptor. */
#define RTK_PLUGIN_ENTRY(descriptor) \
    RTK_EXTERN_C_BEGIN RTK_EXPORT const rtk_plugin *rtk_plugin_entry(void); RTK_EXTERN_C_END \
    const rtk_plugin *rtk_plugin_entry(void) { return &(descriptor); }

RTK_EXTERN_C_END

#endif

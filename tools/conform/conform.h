/* The conformance runner's private header: the options tests use to run
 * the accelerator checks at other sizes (tests/accel/hard traces the icosphere
 * with a million rays), the stand-ins integrator checks render with, and
 * what the runner's files share: the check bookkeeping and parameter sets
 * (conform.c), one entry per plugin kind (conform_accelerators.c,
 * conform_filters.c, conform_integrators.c) and the integrators'
 * known-answer profiles (conform_profiles.c). The public entry point is
 * rtk_conform (tools/tools.h). */
#ifndef RTK_CONFORM_H
#define RTK_CONFORM_H

#include "render/render.h"
#include "../tools.h"

RTK_EXTERN_C_BEGIN

/* Groups of accelerator checks. The first four, INSTANCES and BATCH run for
 * every parameter set of the plugin (BATCH's large scenes for its defaults
 * only), the others for its defaults. */
typedef enum rtk_conform_case {
    RTK_CONFORM_BASIC = 1u << 0,       /* small meshes against brute force */
    RTK_CONFORM_DEGENERATE = 1u << 1,  /* copies, concentric, one point, dense cube: depth, leaves */
    RTK_CONFORM_SIGNED_ZERO = 1u << 2, /* axis-aligned rays with +-0 components at box faces */
    RTK_CONFORM_REPEAT = 1u << 3,      /* same answers built twice, on 1 and 2 threads, as one leaf */
    RTK_CONFORM_ICOSPHERE = 1u << 4,   /* closed 81,920-triangle sphere: vertices and shared edges */
    RTK_CONFORM_INSIDE = 1u << 5,      /* cameras inside closed meshes see no background */
    RTK_CONFORM_GRAZING = 1u << 6,     /* rays parallel and at 1e-7..1e-2 rad to quads */
    RTK_CONFORM_SURFACE = 1u << 7,     /* secondary rays from offset origins, scales 1e-3..1e4 */
    RTK_CONFORM_FAR_BOX = 1u << 8,     /* closed boxes at 1e6 and 1e7 seen from inside */
    RTK_CONFORM_TINY = 1u << 9,        /* triangles with edges of 1e-3..1e-8 */
    RTK_CONFORM_FANS = 1u << 10,       /* 1000-needle sliver fans */
    RTK_CONFORM_INSTANCES = 1u << 11,  /* a mesh placed 60 times: both levels against brute force */
    RTK_CONFORM_BATCH = 1u << 12,      /* ray batches = single rays, bit for bit */
    RTK_CONFORM_ALL = (1u << 13) - 1u
} rtk_conform_case;

/* What to run; a zero field means the default. */
typedef struct rtk_conform_options {
    uint32_t cases;          /* RTK_CONFORM_* bits; 0: all */
    uint32_t icosphere_rays; /* rays per icosphere placement; 0: 100,000 */
    uint32_t ray_scale;      /* multiplies the ray counts of the other cases; 0: 1 */
    int defaults_only;       /* 1: only the plugin's default parameters */
} rtk_conform_options;

/* Stand-ins for integrator checks, which must not depend on any plugin
 * but the one under test (conform_integrators.c): an accelerator that
 * makes one leaf over everything, and a box filter of radius 1/2, so that
 * each sample counts in the pixel it falls in only. */
extern const rtk_plugin rtk_conform_one_leaf;
extern const rtk_filter_fns rtk_conform_pixel_box;

/* rtk_conform with options (NULL: all checks at their default sizes);
 * options only concern accelerators. */
rtk_status rtk_conform_run(const char *path, const rtk_conform_options *options, FILE *out, int *passed,
                           int *failed);

/* Where check lines go and what they count. */
typedef struct rtk_conform_runner {
    FILE *out;
    int passed, failed;
    int skipped; /* checks left out because this machine cannot run them (a device accelerator without its device) */
} rtk_conform_runner;

/* One check line: "ok    name", or "FAIL  name: " and the printf-style
 * detail; counted into r. */
void rtk_conform_check(rtk_conform_runner *r, int ok, const char *name, const char *fmt, ...) RTK_PRINTF(4, 5);

/* Parameter sets to try: index 0 the defaults, then each numeric parameter
 * at its bounds, each choice, each bool flipped, one at a time; label gets
 * the set's name ("defaults", "rays=4096"). NULL past the end. [caller
 * destroys] */
rtk_params *rtk_conform_param_variant(const rtk_plugin *p, int index, char *label, size_t cap);

/* The number of parameter sets rtk_conform_param_variant yields for p. */
uint32_t rtk_conform_variant_count(const rtk_plugin *p);

/* For each of p's parameter sets: creates an instance (a check line for
 * the set and one for create), runs each on it, destroys it. */
void rtk_conform_each_variant(rtk_conform_runner *r, const rtk_plugin *p,
                              rtk_status (*create)(const rtk_params *, void **), void (*destroy)(void *),
                              void (*each)(rtk_conform_runner *r, const rtk_plugin *p, void *state,
                                           const char *label));

/* A uniform float in [lo, hi) from rng. */
static inline float rtk_conform_frand(rtk_pcg32 *rng, float lo, float hi)
{
    return lo + (hi - lo) * rtk_pcg32_float(rng);
}

/* Scene makers of the integrator checks and profiles (conform_integrators.c).
 * A diffuse material: albedo, grey emission le. */
rtk_material rtk_conform_diffuse(rtk_rgb albedo, float le);
/* Adds m to s; its id (RTK_INVALID_ID when out of memory). */
uint32_t rtk_conform_add_material(rtk_scene *s, rtk_material m);
/* Quad o, o+e1, o+e1+e2, o+e2 as two triangles; its front side is e1 x e2.
 * with_uv: each triangle's corners get uv (0,0), (1,0), (1,1). */
void rtk_conform_add_quad(rtk_scene *s, rtk_vec3 o, rtk_vec3 e1, rtk_vec3 e2, uint32_t material, int with_uv);

/* The checks of each kind, after the schema checks; o (may be NULL) only
 * concerns accelerators. */
void rtk_conform_accelerator(rtk_conform_runner *r, const rtk_plugin *p, const rtk_conform_options *o);
void rtk_conform_filter(rtk_conform_runner *r, const rtk_plugin *p);
void rtk_conform_integrator(rtk_conform_runner *r, const rtk_plugin *p);
/* The check line name for two renders of the same film (RTK_FILM_CHANNELS
 * values a pixel): a through `way`, through_li through li; every value
 * and the counts of rays and invalid rays must be equal. */
void rtk_conform_same_films(rtk_conform_runner *r, const char *name, const char *way, const float *a,
                            const rtk_render_stats *sa, const float *through_li, const rtk_render_stats *sb,
                            size_t count);
/* When integrator f (instance state) has a device program: the kernel
 * knows it, and job (the standard room, built as scene) rendered through
 * it equals the render through li, for each sampler (conform_programs.c).
 * through_program and through_li hold count film values. */
void rtk_conform_device_program(rtk_conform_runner *r, const rtk_integrator_fns *f, void *state, rtk_scene *scene,
                                rtk_film_render *job, float *through_program, float *through_li, size_t count,
                                const char *label);

/* Runs the exact tests of the profile integrator p declares
 * (rtk_plugin.conform), one line per check to out, counting into *passed
 * and *failed; a note when p declares none. */
void rtk_conform_profile(const rtk_plugin *p, FILE *out, int *passed, int *failed);

RTK_EXTERN_C_END

#endif

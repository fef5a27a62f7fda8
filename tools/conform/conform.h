/* The accelerator conformance checks by group, for callers that want some
 * of them at a different size than `rtk conform` runs them (tests/hard
 * traces the icosphere with a million rays), and the integrator profiles'
 * exact tests (conform_integrators.c). Kernel-internal: the public entry
 * point stays rtk_conform (include/rtk/host.h). */
#ifndef RTK_CONFORM_HARD_H
#define RTK_CONFORM_HARD_H

#include "render/render.h"
#include "../tools.h"

RTK_EXTERN_C_BEGIN

/* Groups of accelerator checks. The first four and INSTANCES run for every
 * parameter set of the plugin, the others for its defaults. */
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
    RTK_CONFORM_ALL = (1u << 12) - 1u
} rtk_conform_case;

/* What to run; a zero field means the default. */
typedef struct rtk_conform_options {
    uint32_t cases;          /* RTK_CONFORM_* bits; 0: all */
    uint32_t icosphere_rays; /* rays per icosphere placement; 0: 100,000 */
    uint32_t ray_scale;      /* multiplies the ray counts of the other cases; 0: 1 */
    int defaults_only;       /* 1: only the plugin's default parameters */
} rtk_conform_options;

/* Stand-ins for integrator checks, which must not depend on any plugin
 * but the one under test (conform.c): an accelerator that makes one leaf
 * over everything, and a box filter of radius 1/2, so that each sample
 * counts in the pixel it falls in only. */
extern const rtk_plugin rtk_conform_one_leaf;
extern const rtk_filter_fns rtk_conform_pixel_box;

/* rtk_conform with options (NULL: all checks at their default sizes);
 * options only concern accelerators. */
rtk_status rtk_conform_run(const char *path, const rtk_conform_options *options, FILE *out, int *passed,
                           int *failed);

/* Runs the exact tests of the profile integrator p declares
 * (rtk_plugin.conform), one line per check to out, counting into *passed
 * and *failed; a note when p declares none. */
void rtk_conform_profile(const rtk_plugin *p, FILE *out, int *passed, int *failed);

RTK_EXTERN_C_END

#endif

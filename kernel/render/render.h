/* Rendering: sample generators and the per-thread context (sampler.c),
 * the film (film.h) and the render loop (render.c). */
#ifndef RTK_KERNEL_RENDER_H
#define RTK_KERNEL_RENDER_H

#include "../scene/scene.h"
#include "../accel/accel.h"
#include "film.h"

RTK_EXTERN_C_BEGIN

/* ---- sampler (sampler.c; the generators themselves in sample.h) ---- */

/* The generator a config names ("independent", "stratified", "sobol"); 0 if none. */
int rtk_sampler_type_from_name(const char *name, rtk_sampler_type *type);

/* ---- render context (render.c) ---- */

struct rtk_ctx {
    const rtk_scene *scene;
    uint64_t rays;
    uint64_t invalid_rays;
    /* Sampler state (sampler.c): the generator, set once per context (a
     * zeroed one with only gen.seed set is the independent generator), and
     * the current sample, set by rtk_ctx_start_sample. */
    rtk_sample_gen gen;
    rtk_sample_pos pos;
    /* The current sample's camera ray (render.c), for its differentials:
     * the film position it went through; camera NULL when there is none. */
    const rtk_camera *camera;
    float film_x, film_y;
    rtk_ray camera_ray;        /* that ray itself, as li received it */
    /* Inside li_batch (render.c): the batch's camera rays and every
     * sample's state but the current one's, which lives in the fields
     * above (rtk_ctx_select swaps them); batch_count 0 outside. */
    const rtk_ray *batch_rays;
    struct rtk_sample_state *batch;
    uint32_t batch_count, batch_current;
};

/* One sample's position in its stream and its camera ray: the fields of
 * rtk_ctx that rtk_ctx_select saves and restores. */
typedef struct rtk_sample_state {
    rtk_sample_pos pos;
    float film_x, film_y;
    rtk_ray camera_ray;
} rtk_sample_state;

/* Saves ctx's current sample into *st / makes *st ctx's current sample. */
void rtk_ctx_save_sample(const rtk_ctx *ctx, rtk_sample_state *st);
void rtk_ctx_load_sample(rtk_ctx *ctx, const rtk_sample_state *st);

/* Picks ctx's generator, seed and samples per pixel (0 taken as 1). A
 * zeroed ctx with only seed set is the independent generator. */
RTK_KERNEL_API void rtk_ctx_set_sampler(rtk_ctx *ctx, rtk_sampler_type type, uint64_t seed, uint32_t spp);
/* Starts sample `sample` of pixel `pixel` and resets the dimension counter. */
RTK_KERNEL_API void rtk_ctx_start_sample(rtk_ctx *ctx, uint64_t pixel, uint64_t sample);

RTK_EXTERN_C_END

#endif

/* Rendering: sample generators and the per-thread context (sampler.c),
 * the film (film.h) and the render loop (render.c). */
#ifndef RTK_KERNEL_RENDER_H
#define RTK_KERNEL_RENDER_H

#include "../scene/scene.h"
#include "../accel/accel.h"

RTK_EXTERN_C_BEGIN

/* ---- sampler (sampler.c) ---- */

/* PCG32 state (O'Neill 2014). */
typedef struct rtk_pcg32 {
    uint64_t state, inc;
} rtk_pcg32;

RTK_KERNEL_API void rtk_pcg32_seed(rtk_pcg32 *rng, uint64_t initstate, uint64_t initseq);
RTK_KERNEL_API uint32_t rtk_pcg32_next(rtk_pcg32 *rng);
/* Uniform float in [0, 1) from the top 24 bits. */
RTK_KERNEL_API float rtk_pcg32_float(rtk_pcg32 *rng);

/* Sample generators of a config's sampler.type. Zero is independent, so a
 * zeroed rtk_ctx draws PCG32 numbers. */
typedef enum rtk_sampler_type {
    RTK_SAMPLER_INDEPENDENT = 0,
    RTK_SAMPLER_STRATIFIED = 1,
    RTK_SAMPLER_SOBOL = 2
} rtk_sampler_type;

/* The generator a config names ("independent", "stratified", "sobol"); 0 if none. */
int rtk_sampler_type_from_name(const char *name, rtk_sampler_type *type);
/* Nested uniform (Owen) scramble of a 64-bit fraction by hashing (Burley
 * 2020): bit k of the result depends on bits k..63 of x and the seed, so
 * every aligned block of 2^m values maps onto an aligned block. */
uint64_t rtk_owen_scramble(uint64_t x, uint64_t seed);
/* Unscrambled Sobol point index, dimension 0 (van der Corput) or 1, as a
 * 32-bit fraction; index bits past 31 reach dimension 1. */
uint32_t rtk_sobol_sample(uint64_t index, uint32_t dim);
/* The float of a 32-bit fraction, truncated: at most 0x1.fffffep-1. */
float rtk_sampler_float(uint32_t bits);
/* A float in [k/n, (k+1)/n) (for n <= 2^24, where each such range holds
 * floats), near (k + jitter 2^-32) / n, below 1. */
float rtk_sampler_stratum(uint32_t k, uint32_t n, uint32_t jitter);

/* ---- render context (render.c) ---- */

struct rtk_ctx {
    const rtk_scene *scene;
    rtk_pcg32 rng;
    uint64_t seed;
    uint64_t rays;
    uint64_t invalid_rays;
    /* Sampler state (sampler.c): the generator, set once per context... */
    rtk_sampler_type sampler;
    uint32_t spp;              /* samples per pixel the strata are made for */
    uint32_t grid_x, grid_y;   /* stratified 2D grid, grid_x * grid_y = spp */
    /* ... and the current sample, set by rtk_ctx_start_sample. */
    uint64_t pixel, sample;
    uint64_t sample_hash;      /* of (seed, pixel, stratified pass) */
    uint32_t pass_sample;      /* stratified: sample index within its pass of spp */
    uint32_t dim;              /* dimensions drawn so far in this sample */
    uint32_t dim_base;         /* the first dimension li draws (after the camera's) */
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
    rtk_pcg32 rng;
    uint64_t pixel, sample, sample_hash;
    uint32_t pass_sample, dim, dim_base;
    float film_x, film_y;
    rtk_ray camera_ray;
} rtk_sample_state;

/* Saves ctx's current sample into *st / makes *st ctx's current sample. */
void rtk_ctx_save_sample(const rtk_ctx *ctx, rtk_sample_state *st);
void rtk_ctx_load_sample(rtk_ctx *ctx, const rtk_sample_state *st);

/* Picks ctx's generator, seed and samples per pixel (0 taken as 1). A
 * zeroed ctx with only seed set is the independent generator. */
void rtk_ctx_set_sampler(rtk_ctx *ctx, rtk_sampler_type type, uint64_t seed, uint32_t spp);
/* Starts sample `sample` of pixel `pixel` and resets the dimension counter. */
RTK_KERNEL_API void rtk_ctx_start_sample(rtk_ctx *ctx, uint64_t pixel, uint64_t sample);


#include "film.h"

RTK_EXTERN_C_END

#endif

/* Film accumulation (film.c). Tiles are private to one thread; merging
 * into the film is the caller's to serialise, in a fixed tile order. */
#ifndef RTK_FILM_H
#define RTK_FILM_H

#include "internal.h"

/* Channels the renderer accumulates: RGB, albedo RGB, normal XYZ, depth. */
#define RTK_FILM_CHANNELS 10

/* Counters of one render. */
typedef struct rtk_render_stats {
    uint64_t rays, invalid_rays, bad_samples;
} rtk_render_stats;

/* Renders scene through camera into pixels (RTK_FILM_CHANNELS floats per
 * pixel, resolved) on threads; the integrator must be prepared. */
rtk_status rtk_render_film(const rtk_scene *scene, const rtk_camera *camera, const rtk_integrator_fns *ifn,
                           const void *istate, const rtk_filter_fns *ffn, const void *fstate, uint32_t spp,
                           uint64_t seed, uint32_t threads, int progress, float *pixels, rtk_render_stats *stats);

/* One tile's padded accumulation buffer. */
typedef struct rtk_film_tile {
    int x0, y0, w, h; /* film position of the buffer's first pixel, size */
    uint32_t channels;
    double *sum, *weight;
} rtk_film_tile;

rtk_status rtk_film_init(rtk_film *film, uint32_t width, uint32_t height, uint32_t channels);
void rtk_film_free(rtk_film *film);
/* Buffer for pixels [x0, x1) x [y0, y1) padded by the filter radius. */
rtk_status rtk_film_tile_init(rtk_film_tile *tile, const rtk_film *film, uint32_t x0, uint32_t y0, uint32_t x1,
                              uint32_t y1, float radius);
void rtk_film_tile_free(rtk_film_tile *tile);
/* Adds a sample at film position (fx, fy) to every pixel whose centre is
 * within radius, weighted by the filter. */
void rtk_film_tile_splat(rtk_film_tile *tile, const rtk_film *film, float fx, float fy, const float *values,
                         const rtk_filter_fns *filter, const void *fstate, float radius);
void rtk_film_merge(rtk_film *film, const rtk_film_tile *tile);
/* Weighted averages, channels floats per pixel. */
void rtk_film_resolve(const rtk_film *film, float *out);

#endif

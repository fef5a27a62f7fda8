/* The pieces of `rtk bench` (bench.c) that tests check one by one: the
 * standard recipe (docs/bench-vs-embree.md) for meshes, cameras, primary and AO rays.
 * All set-up arithmetic is double precision without FMA contraction
 * (bench.c is compiled with -ffp-contract=off), then rounded to float, so
 * every tracer that follows the recipe traces bit-identical primary rays. */
#ifndef RTK_BENCH_H
#define RTK_BENCH_H

#include "render/render.h"
#include "../tools.h"

RTK_EXTERN_C_BEGIN

/* Reads an OBJ the recipe's way: `v x y z` with strtof; faces `i`, `i/j`,
 * `i//k`, `i/j/k`, negative indices relative; polygons fanned (0, i, i+1),
 * so faces of fewer than 3 vertices give none (one warning counts them);
 * every other statement ignored. Nothing is dropped (degenerate triangles
 * stay), bounds cover every vertex. Errors name file:line.
 * [caller frees with rtk_scene_free] */
rtk_status rtk_bench_read_obj(const char *path, rtk_scene **out);

/* A pinhole camera in double precision. */
typedef struct rtk_bench_camera {
    double eye[3], fwd[3], right[3], up[3];
    double th; /* tan of half the vertical field of view */
} rtk_bench_camera;

/* The recipe's camera for a bounding box: from the centre along
 * normalize(1, 0.6, 1.4) at 1.6 diagonals, 45 degrees vertical fov. */
void rtk_bench_camera_recipe(rtk_bounds bounds, rtk_bench_camera *cam);
/* A camera at eye looking at look_at with world up (fwd x up gives
 * right, right x fwd the camera's up), fov_deg vertical. Errors when the
 * view direction is zero or parallel to up, or fov is outside (0, 180). */
rtk_status rtk_bench_camera_look(const double eye[3], const double look_at[3], const double up[3],
                                 double fov_deg, rtk_bench_camera *cam);

/* The width * height primary rays, row-major from the top row. */
void rtk_bench_primary_rays(const rtk_bench_camera *cam, uint32_t width, uint32_t height, rtk_ray *rays);

/* FNV-1a-64 over the float bits of (ox, oy, oz, dx, dy, dz) of each ray. */
uint64_t rtk_bench_ray_hash(const rtk_ray *rays, size_t count);

/* The k AO rays of the pixel with index `pixel` whose primary ray hit
 * (hit->prim, hit->t); diag is the scene's bounding-box diagonal. */
void rtk_bench_ao_rays(const rtk_scene *scene, const rtk_ray *primary, const rtk_hit *hit, uint64_t pixel,
                       double diag, uint32_t k, rtk_ray *out);

/* Diagonal of the scene's bounding box, in double. */
double rtk_bench_diag(rtk_bounds bounds);

RTK_EXTERN_C_END

#endif

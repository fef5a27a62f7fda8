/* The pinhole camera (camera.c). */
#ifndef RTK_KERNEL_CAMERA_H
#define RTK_KERNEL_CAMERA_H

#include "../core/core.h"

RTK_EXTERN_C_BEGIN

/* A pinhole camera as configured. */
typedef struct rtk_camera_desc {
    rtk_vec3 position, look_at, up;
    float fov_deg; /* vertical field of view */
} rtk_camera_desc;

/* Ready-to-use pinhole camera. */
typedef struct rtk_camera {
    rtk_vec3 eye, forward, right, up; /* right/up scaled by the image plane half-size */
    uint32_t width, height;
} rtk_camera;

/* Camera looking at the bounds' centre from the front-right-above, framing
 * the bounding sphere at the given vertical fov. */
rtk_camera_desc rtk_camera_frame(rtk_bounds bounds, float fov_deg, float aspect);
/* Checks desc (finite, eye != look_at, up not parallel, 0 < fov < 180). */
RTK_KERNEL_API rtk_status rtk_camera_init(rtk_camera *cam, const rtk_camera_desc *desc, uint32_t width, uint32_t height);
/* Ray through film position (fx, fy) in pixels, (0,0) the top-left corner. */
RTK_KERNEL_API rtk_ray rtk_camera_ray(const rtk_camera *cam, float fx, float fy);
/* The same, inline and in plain C that nvcc compiles too (RTK_HD): a GPU's
 * camera rays are the kernel's bit for bit (tests/cuda). */
RTK_HD static inline rtk_ray rtk_camera_ray_at(const rtk_camera *cam, float fx, float fy)
{
    float sx = 2.0f * fx / (float)cam->width - 1.0f;
    float sy = 1.0f - 2.0f * fy / (float)cam->height;
    rtk_vec3 dir = rtk_vec3_add(cam->forward,
                                rtk_vec3_add(rtk_vec3_scale(cam->right, sx), rtk_vec3_scale(cam->up, sy)));
    rtk_ray r;
    r.org = cam->eye;
    r.dir = rtk_vec3_normalize(dir);
    r.tmin = 0.0f;
    r.tmax = INFINITY;
    return r;
}
/* Differentials of that ray: the rays through (fx + 1, fy) and (fx, fy + 1). */
void rtk_camera_differential(const rtk_camera *cam, float fx, float fy, rtk_ray_differential *out);

RTK_EXTERN_C_END

#endif

/* Pinhole camera: from the config, from a file, or framed automatically. */
#include "scene.h"

#include <math.h>

static int finite3(rtk_vec3 v)
{
    return isfinite(v.x) && isfinite(v.y) && isfinite(v.z);
}

rtk_camera_desc rtk_camera_frame(rtk_bounds b, float fov_deg, float aspect)
{
    rtk_camera_desc d;
    d.up = rtk_vec3_make(0.0f, 1.0f, 0.0f);
    d.fov_deg = fov_deg;
    if (!(b.lower.x <= b.upper.x && b.lower.y <= b.upper.y && b.lower.z <= b.upper.z)) {
        d.look_at = rtk_vec3_make(0.0f, 0.0f, 0.0f);
        d.position = rtk_vec3_make(0.0f, 0.0f, 1.0f);
        return d;
    }
    double cx = 0.5 * ((double)b.lower.x + b.upper.x);
    double cy = 0.5 * ((double)b.lower.y + b.upper.y);
    double cz = 0.5 * ((double)b.lower.z + b.upper.z);
    double ex = (double)b.upper.x - b.lower.x, ey = (double)b.upper.y - b.lower.y,
           ez = (double)b.upper.z - b.lower.z;
    double radius = 0.5 * sqrt(ex * ex + ey * ey + ez * ez);
    if (!(radius > 0.0))
        radius = fabs(cx) + fabs(cy) + fabs(cz) > 0.0 ? 1e-3 * (fabs(cx) + fabs(cy) + fabs(cz)) : 1.0;
    /* The sphere fits the narrower of the two fields of view. */
    double half_v = 0.5 * fov_deg * M_PI / 180.0;
    double half_h = atan(tan(half_v) * (aspect > 0.0f ? aspect : 1.0));
    double half = half_v < half_h ? half_v : half_h;
    double dist = radius / sin(half) * 1.05;
    double dx = 0.45, dy = 0.35, dz = 1.0;
    double len = sqrt(dx * dx + dy * dy + dz * dz);
    d.look_at = rtk_vec3_make((float)cx, (float)cy, (float)cz);
    d.position = rtk_vec3_make((float)(cx + dist * dx / len), (float)(cy + dist * dy / len),
                               (float)(cz + dist * dz / len));
    return d;
}

rtk_status rtk_camera_init(rtk_camera *cam, const rtk_camera_desc *d, uint32_t width, uint32_t height)
{
    if (!finite3(d->position) || !finite3(d->look_at) || !finite3(d->up) || !isfinite(d->fov_deg))
        return rtk_error(RTK_ERR_INVALID, "camera: position, look_at, up and fov must be finite");
    if (!(d->fov_deg > 0.0f && d->fov_deg < 180.0f))
        return rtk_error(RTK_ERR_INVALID, "camera: fov = %g is outside (0, 180) degrees", d->fov_deg);
    if (width == 0 || height == 0)
        return rtk_error(RTK_ERR_INVALID, "camera: film size %ux%u is empty", width, height);
    double fx = (double)d->look_at.x - d->position.x, fy = (double)d->look_at.y - d->position.y,
           fz = (double)d->look_at.z - d->position.z;
    double fl = sqrt(fx * fx + fy * fy + fz * fz);
    if (!(fl > 0.0))
        return rtk_error(RTK_ERR_INVALID, "camera: position and look_at are the same point");
    fx /= fl, fy /= fl, fz /= fl;
    double ux = d->up.x, uy = d->up.y, uz = d->up.z;
    double rx = fy * uz - fz * uy, ry = fz * ux - fx * uz, rz = fx * uy - fy * ux;
    double rl = sqrt(rx * rx + ry * ry + rz * rz);
    if (!(rl > 1e-9 * sqrt(ux * ux + uy * uy + uz * uz)) || !(rl > 0.0))
        return rtk_error(RTK_ERR_INVALID, "camera: up is zero or parallel to the view direction; "
                                          "set camera.up to another direction");
    rx /= rl, ry /= rl, rz /= rl;
    double vx = ry * fz - rz * fy, vy = rz * fx - rx * fz, vz = rx * fy - ry * fx;
    double th = tan(0.5 * d->fov_deg * M_PI / 180.0);
    double aspect = (double)width / (double)height;
    cam->eye = d->position;
    cam->forward = rtk_vec3_make((float)fx, (float)fy, (float)fz);
    cam->right = rtk_vec3_make((float)(rx * th * aspect), (float)(ry * th * aspect), (float)(rz * th * aspect));
    cam->up = rtk_vec3_make((float)(vx * th), (float)(vy * th), (float)(vz * th));
    cam->width = width;
    cam->height = height;
    return RTK_OK;
}

rtk_ray rtk_camera_ray(const rtk_camera *cam, float fx, float fy)
{
    return rtk_camera_ray_at(cam, fx, fy);
}

void rtk_camera_differential(const rtk_camera *cam, float fx, float fy, rtk_ray_differential *out)
{
    rtk_ray rx = rtk_camera_ray(cam, fx + 1.0f, fy), ry = rtk_camera_ray(cam, fx, fy + 1.0f);
    out->rx_org = rx.org;
    out->rx_dir = rx.dir;
    out->ry_org = ry.org;
    out->ry_dir = ry.dir;
}

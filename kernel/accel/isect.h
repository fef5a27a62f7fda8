/* The ray/triangle test and its tolerances, in plain C that nvcc
 * compiles too (RTK_HD, include/rtk/common.h): one source for the
 * kernel's traversals and the CUDA backend's, so that the CPU tests the
 * GPU's arithmetic bit for bit (tests/cuda). The kernel and every
 * compilation of this header must not contract a * b + c into a fused
 * multiply-add (-ffp-contract=off, nvcc --fmad=false): the watertight
 * test relies on each product being rounded on its own. */
#ifndef RTK_ACCEL_ISECT_H
#define RTK_ACCEL_ISECT_H

#include <rtk/ray.h>

#include <float.h>
#include <math.h>

/* The axes of the watertight triangle test (Woop, Benthin, Wald 2013) for
 * direction d: kz that of the largest |component|, kx and ky the next two
 * cyclically, swapped when d[kz] < 0 to keep the winding. The scalar test
 * and the wide traversal's four-lane one take them from here. */
RTK_HD static inline void rtk_shear_axes(const float d[3], int *kx, int *ky, int *kz)
{
    /* In integer arithmetic on comparisons, so that compilers emit no
     * branch: directions of AO and diffuse rays are random, and branches
     * here would be mispredicted every other ray. Same result as
     * z = ax > ay ? (ax > az ? 0 : 2) : (ay > az ? 1 : 2), x and y the
     * next two cyclically, swapped when d[z] < 0. */
    float ax = fabsf(d[0]), ay = fabsf(d[1]), az = fabsf(d[2]);
    int xy = ax > ay;
    int top = (xy ? ax : ay) > az;
    int z = 2 - top * (1 + xy);
    int x = 9 >> (2 * z) & 3;  /* 1, 2, 0 for z = 0, 1, 2 */
    int y = 18 >> (2 * z) & 3; /* 2, 0, 1 */
    int swap = (x ^ y) & -(d[z] < 0.0f);
    *kx = x ^ swap, *ky = y ^ swap, *kz = z;
}

/* A reported hit distance t is within RTK_T_TOLERANCE * |t| of the exact
 * one: rtk_intersect_triangle recomputes t in double when its float error
 * bound (pbrt-v4's, loose by orders of magnitude) is larger. Smaller
 * values send more hits to double precision: at 16 ulps most hits on the
 * showroom did, at 2^-10 one in ten rays; traversal culls 4 tolerances
 * beyond the closest hit, so only that much extra work follows. */
#define RTK_T_TOLERANCE (1.0f / 1024.0f)

/* Boxes entered after a hit at tmax (or up to the ray's tmax) are those
 * entered at or before this distance: tmax widened by four tolerances, so
 * that a triangle whose float t ties with or undercuts tmax is never culled
 * by rounding, and equal distances still resolve to the lowest id. */
RTK_HD static inline float rtk_cull_distance(float tmax)
{
    return tmax + fabsf(tmax) * (4.0f * RTK_T_TOLERANCE);
}

/* Component k of v, in float and in double. */
RTK_HD static inline float rtk_axis(rtk_vec3 v, int k)
{
    return k == 0 ? v.x : k == 1 ? v.y : v.z;
}

/* Bound on the rounding error of the float t below (Pharr, Jakob,
 * Humphreys, pbrt-v4 section 6.8.7): t carries error proportional to the
 * vertices' distance from the origin, not to t itself. */
RTK_HD static inline float rtk_isect_t_error(float U, float V, float W, float ax, float ay, float bx, float by,
                                             float cx, float cy, float az, float bz, float cz, float rcp)
{
    const float g2 = 2.0f * 0.5f * FLT_EPSILON / (1.0f - 2.0f * 0.5f * FLT_EPSILON);
    const float g3 = 3.0f * 0.5f * FLT_EPSILON / (1.0f - 3.0f * 0.5f * FLT_EPSILON);
    const float g5 = 5.0f * 0.5f * FLT_EPSILON / (1.0f - 5.0f * 0.5f * FLT_EPSILON);
    float max_z = fmaxf(fabsf(az), fmaxf(fabsf(bz), fabsf(cz)));
    float max_x = fmaxf(fabsf(ax), fmaxf(fabsf(bx), fabsf(cx)));
    float max_y = fmaxf(fabsf(ay), fmaxf(fabsf(by), fabsf(cy)));
    float dz = g3 * max_z, dx = g5 * (max_x + max_z), dy = g5 * (max_y + max_z);
    float de = 2.0f * (g2 * max_x * max_y + dy * max_x + dx * max_y);
    float max_e = fmaxf(fabsf(U), fmaxf(fabsf(V), fabsf(W)));
    return 3.0f * (g3 * max_e * max_z + de * max_z + dz * max_e) * fabsf(rcp);
}

RTK_HD static inline double rtk_axis_d(rtk_vec3 v, int k)
{
    return k == 0 ? v.x : k == 1 ? v.y : v.z;
}

/* The same ray-space computation of t, in double. */
RTK_HD static inline double rtk_isect_exact_t(const rtk_ray *ray, rtk_vec3 a, rtk_vec3 b, rtk_vec3 c, int kx, int ky,
                                              int kz)
{
    double dz = rtk_axis_d(ray->dir, kz);
    double sx = rtk_axis_d(ray->dir, kx) / dz, sy = rtk_axis_d(ray->dir, ky) / dz, sz = 1.0 / dz;
    double A[3], B[3], C[3];
    for (int k = 0; k < 3; k++) {
        A[k] = rtk_axis_d(a, k) - rtk_axis_d(ray->org, k);
        B[k] = rtk_axis_d(b, k) - rtk_axis_d(ray->org, k);
        C[k] = rtk_axis_d(c, k) - rtk_axis_d(ray->org, k);
    }
    double ax = A[kx] - sx * A[kz], ay = A[ky] - sy * A[kz];
    double bx = B[kx] - sx * B[kz], by = B[ky] - sy * B[kz];
    double cx = C[kx] - sx * C[kz], cy = C[ky] - sy * C[kz];
    double U = cx * by - cy * bx, V = ax * cy - ay * cx, W = bx * ay - by * ax;
    double det = U + V + W;
    if (det == 0.0)
        return -1.0;
    return (U * sz * A[kz] + V * sz * B[kz] + W * sz * C[kz]) / det;
}

/* rtk_intersect_triangle (include/rtk/ray.h): the watertight test, hits
 * on an edge and uncertain distances decided in double. */
RTK_HD static inline int rtk_isect_triangle(const rtk_ray *ray, rtk_vec3 a, rtk_vec3 b, rtk_vec3 c, float *t_out,
                                            float *u_out, float *v_out)
{
    /* Woop, Benthin, Wald 2013: shear into ray space with z the dominant axis. */
    const float d[3] = {ray->dir.x, ray->dir.y, ray->dir.z};
    int kx, ky, kz;
    rtk_shear_axes(d, &kx, &ky, &kz);
    float dz = d[kz];
    float sx = d[kx] / dz, sy = d[ky] / dz, sz = 1.0f / dz;
    const rtk_vec3 o = ray->org;
    rtk_vec3 A = {a.x - o.x, a.y - o.y, a.z - o.z}, B = {b.x - o.x, b.y - o.y, b.z - o.z},
             C = {c.x - o.x, c.y - o.y, c.z - o.z};
    float ax = rtk_axis(A, kx) - sx * rtk_axis(A, kz), ay = rtk_axis(A, ky) - sy * rtk_axis(A, kz);
    float bx = rtk_axis(B, kx) - sx * rtk_axis(B, kz), by = rtk_axis(B, ky) - sy * rtk_axis(B, kz);
    float cx = rtk_axis(C, kx) - sx * rtk_axis(C, kz), cy = rtk_axis(C, ky) - sy * rtk_axis(C, kz);
    float U = cx * by - cy * bx, V = ax * cy - ay * cx, W = bx * ay - by * ax;
    if (U == 0.0f || V == 0.0f || W == 0.0f) {
        /* On an edge in float: decide in double so neighbours agree. The
         * signs come from the doubles: their float roundings may underflow
         * to 0 (origins a denormal away from a vertex's coordinate). */
        double Ud = (double)cx * by - (double)cy * bx;
        double Vd = (double)ax * cy - (double)ay * cx;
        double Wd = (double)bx * ay - (double)by * ax;
        if ((Ud < 0.0 || Vd < 0.0 || Wd < 0.0) && (Ud > 0.0 || Vd > 0.0 || Wd > 0.0))
            return 0;
        U = (float)Ud, V = (float)Vd, W = (float)Wd;
    }
    if ((U < 0.0f || V < 0.0f || W < 0.0f) && (U > 0.0f || V > 0.0f || W > 0.0f))
        return 0;
    float det = U + V + W;
    if (det == 0.0f)
        return 0;
    float az = sz * rtk_axis(A, kz), bz = sz * rtk_axis(B, kz), cz = sz * rtk_axis(C, kz);
    float T = U * az + V * bz + W * cz;
    float rcp = 1.0f / det;
    float t = T * rcp;
    float err = rtk_isect_t_error(U, V, W, ax, ay, bx, by, cx, cy, az, bz, cz, rcp);
    if (!(err < RTK_T_TOLERANCE * fabsf(t))) {
        /* Outside the range even with the error (a ray leaving a surface
         * meets it behind its origin): no need for double. */
        if (t + err < ray->tmin || t - err > ray->tmax)
            return 0;
        /* The float t may be off by more than traversal allows (grazing or
         * thin triangles), or too close to the origin for float to tell
         * its sign (a ray leaving a large triangle would otherwise meet it
         * or its coplanar neighbours again; t = 0, or a bound that
         * underflowed): decide in double, range check included, so that
         * the answer does not depend on a tmax another triangle set. */
        double td = rtk_isect_exact_t(ray, a, b, c, kx, ky, kz);
        t = (float)td;
        if (!(t >= ray->tmin && t <= ray->tmax) || (ray->tmin >= 0.0f && !(td > 0.0)))
            return 0;
    } else if (!(t >= ray->tmin && t <= ray->tmax)) {
        return 0;
    }
    *t_out = t;
    *u_out = V * rcp;
    *v_out = W * rcp;
    return 1;
}

#endif

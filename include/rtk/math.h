/* Small vector types and inline helpers used across the SDK. */
#ifndef RTK_MATH_H
#define RTK_MATH_H

#include <math.h>
#include <rtk/common.h>

RTK_EXTERN_C_BEGIN

/* pi, for plugins built without _GNU_SOURCE (strict C has no M_PI). */
#define RTK_PI 3.14159265358979323846

/* A 2D point or direction. */
typedef struct rtk_vec2 {
    float x, y;
} rtk_vec2;

/* A 3D point or direction. */
typedef struct rtk_vec3 {
    float x, y, z;
} rtk_vec3;

/* Linear RGB radiance or reflectance. */
typedef struct rtk_rgb {
    float r, g, b;
} rtk_rgb;

/* Axis-aligned box; empty when lower > upper on any axis. */
typedef struct rtk_bounds {
    rtk_vec3 lower, upper;
} rtk_bounds;

RTK_SDK_INLINE rtk_vec3 rtk_vec3_make(float x, float y, float z)
{
    rtk_vec3 v;
    v.x = x;
    v.y = y;
    v.z = z;
    return v;
}

RTK_SDK_INLINE rtk_rgb rtk_rgb_make(float r, float g, float b)
{
    rtk_rgb c;
    c.r = r;
    c.g = g;
    c.b = b;
    return c;
}

RTK_SDK_INLINE rtk_vec3 rtk_vec3_add(rtk_vec3 a, rtk_vec3 b) { return rtk_vec3_make(a.x + b.x, a.y + b.y, a.z + b.z); }
RTK_SDK_INLINE rtk_vec3 rtk_vec3_sub(rtk_vec3 a, rtk_vec3 b) { return rtk_vec3_make(a.x - b.x, a.y - b.y, a.z - b.z); }
RTK_SDK_INLINE rtk_vec3 rtk_vec3_scale(rtk_vec3 a, float s) { return rtk_vec3_make(a.x * s, a.y * s, a.z * s); }
RTK_SDK_INLINE rtk_vec3 rtk_vec3_neg(rtk_vec3 a) { return rtk_vec3_make(-a.x, -a.y, -a.z); }
RTK_SDK_INLINE float rtk_vec3_dot(rtk_vec3 a, rtk_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
RTK_SDK_INLINE float rtk_vec3_length(rtk_vec3 a) { return sqrtf(rtk_vec3_dot(a, a)); }

RTK_SDK_INLINE rtk_vec3 rtk_vec3_cross(rtk_vec3 a, rtk_vec3 b)
{
    return rtk_vec3_make(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}

/* Unit vector along a; the zero vector stays zero. */
RTK_SDK_INLINE rtk_vec3 rtk_vec3_normalize(rtk_vec3 a)
{
    float len = rtk_vec3_length(a);
    return len > 0.0f ? rtk_vec3_scale(a, 1.0f / len) : a;
}

RTK_SDK_INLINE rtk_rgb rtk_rgb_scale(rtk_rgb c, float s) { return rtk_rgb_make(c.r * s, c.g * s, c.b * s); }
RTK_SDK_INLINE rtk_rgb rtk_rgb_mul(rtk_rgb a, rtk_rgb b) { return rtk_rgb_make(a.r * b.r, a.g * b.g, a.b * b.b); }
RTK_SDK_INLINE rtk_rgb rtk_rgb_add(rtk_rgb a, rtk_rgb b) { return rtk_rgb_make(a.r + b.r, a.g + b.g, a.b + b.b); }

RTK_EXTERN_C_END

#endif

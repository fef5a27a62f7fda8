/* headlight's estimator in plain C that nvcc compiles too (RTK_HD), on
 * the SDK's types only: headlight.c and the device program "headlight"
 * (plugins/integrators/device_programs.h) both run it. */
#ifndef RTK_HEADLIGHT_ESTIMATOR_H
#define RTK_HEADLIGHT_ESTIMATOR_H

#include <rtk/math.h>

#include <math.h>

/* base x (ambient + (1 - ambient) |cos|) between the shading normal ns and
 * the view ray's direction dir. */
RTK_HD static inline rtk_rgb rtk_headlight_value(rtk_rgb base, rtk_vec3 ns, rtk_vec3 dir, float ambient)
{
    rtk_vec3 d = rtk_vec3_normalize(dir);
    float c = fabsf(rtk_vec3_dot(ns, d));
    float k = ambient + (1.0f - ambient) * c;
    return rtk_rgb_scale(base, k);
}

#endif

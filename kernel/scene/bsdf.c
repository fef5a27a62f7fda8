/* rtk_bsdf_eval, rtk_bsdf_pdf, rtk_bsdf_flags and rtk_bsdf_sample: the
 * lobes and their mixture are bsdf_lobes.h, shared with a GPU backend. */
#include "bsdf_lobes.h"

rtk_rgb rtk_bsdf_eval(const rtk_bsdf *bsdf, rtk_vec3 wo, rtk_vec3 wi)
{
    return rtk_lobes_eval(bsdf, wo, wi);
}

float rtk_bsdf_pdf(const rtk_bsdf *bsdf, rtk_vec3 wo, rtk_vec3 wi)
{
    return rtk_lobes_pdf(bsdf, wo, wi);
}

unsigned rtk_bsdf_flags(const rtk_bsdf *bsdf)
{
    return rtk_lobes_flags(bsdf);
}

int rtk_bsdf_sample(const rtk_bsdf *bsdf, rtk_vec3 wo, float u_lobe, rtk_vec2 u, rtk_bsdf_sample_out *out)
{
    return rtk_lobes_sample(bsdf, wo, u_lobe, u, out);
}

/* outside_tree: the smallest correct integrator, built the way a user
 * builds a plugin outside the rtk tree, against the installed SDK only:
 *
 *   cc -shared -fPIC $(pkg-config --cflags rtk) outside_tree.c -o outside_tree.so
 *
 * It traces the camera ray (so it links against a kernel service) and
 * returns radiance 0.5 whether the ray hits or misses: a render with it
 * has mean 0.5 in every channel. It includes nothing but <rtk/rtk.h>.
 *
 * Parameters: none.
 *
 * Example: integrator = { plugin = "outside_tree"; };
 */
#include <rtk/rtk.h>

static rtk_status outside_tree_create(const rtk_params *params, void **state)
{
    (void)params;
    *state = NULL;
    return RTK_OK;
}

static uint32_t outside_tree_needs(const void *state)
{
    (void)state;
    return 0;
}

static void outside_tree_li(const void *state, rtk_ctx *ctx, const rtk_ray *ray, rtk_li_result *out)
{
    (void)state;
    rtk_hit hit;
    if (rtk_trace(ctx, ray, &hit))
        out->depth = hit.t * rtk_vec3_length(ray->dir);
    out->radiance = rtk_rgb_make(0.5f, 0.5f, 0.5f);
}

static void outside_tree_destroy(void *state)
{
    (void)state;
}

static const rtk_integrator_fns outside_tree_fns = {
    .size = sizeof(rtk_integrator_fns),
    .create = outside_tree_create,
    .needs = outside_tree_needs,
    .li = outside_tree_li,
    .destroy = outside_tree_destroy,
};

static const rtk_plugin outside_tree_plugin = {
    RTK_PLUGIN_HEADER,
    .kind = RTK_KIND_INTEGRATOR,
    .name = "outside_tree",
    .version = "1.0",
    .summary = "constant radiance 0.5, built outside the rtk tree",
    .functions = &outside_tree_fns,
};

RTK_PLUGIN_ENTRY(outside_tree_plugin)

/* Conformance check of an integrator's device program (ABI 3.6,
 * rtk_integrator_fns.device_program): the program it describes is one the
 * kernel knows (plugins/integrators/device_programs.h), and the standard room
 * rendered through it, on a stand-in device that runs the programs' own
 * code on the CPU (as a device accelerator's fallback does), equals the
 * render through li bit for bit, rays counted included, for each sampler. */
#include "conform.h"
#include "../../plugins/integrators/device_programs.h"

#include <stddef.h>
#include <stdlib.h>
#include <string.h>

/* The stand-in device: the scene's own tree as a flat tree. */
typedef struct cpu_device {
    rtk_program_scene ps;
    void *block; /* the tree view's corners and base colours */
    void *program_block; /* rtk_program_scene_of's */
    uint64_t lights; /* the stamp of the lights it reads */
} cpu_device;

static rtk_status cpu_shade(const void *state, rtk_shade_batch *b)
{
    const cpu_device *d = state;
    const rtk_program p = rtk_program_of(b->program);
    if (p.kind == RTK_PROGRAM_NONE)
        return rtk_error(RTK_ERR_UNSUPPORTED, "conform: no device program '%.32s'", b->program->name);
    rtk_program_scene ps = d->ps;
    ps.albedo = b->albedo;
    for (uint32_t i = 0; i < b->count; i++) {
        rtk_program_count c;
        rtk_program_run(&p, &ps, b->gen, &b->pos[i], &b->rays[i], b->diffs ? &b->diffs[i] : NULL, &b->out[i], &c);
        b->rays_traced += c.traced;
        b->invalid_rays += c.invalid;
    }
    return RTK_OK;
}

static void cpu_closest_batch(const void *state, const rtk_ray *rays, uint32_t count, rtk_hit *hits)
{
    const cpu_device *d = state;
    for (uint32_t i = 0; i < count; i++)
        rtk_flat_scene_closest(&d->ps.flat, &rays[i], &hits[i]);
}

static void cpu_any_batch(const void *state, const rtk_ray *rays, uint32_t count, uint8_t *occluded)
{
    const cpu_device *d = state;
    for (uint32_t i = 0; i < count; i++)
        occluded[i] = (uint8_t)rtk_flat_scene_any(&d->ps.flat, &rays[i]);
}

static void cpu_destroy(void *state)
{
    (void)state; /* the check owns it */
}

static const rtk_accelerator_fns cpu_device_fns = {
    .size = sizeof(rtk_accelerator_fns),
    .destroy = cpu_destroy,
    .closest_batch = cpu_closest_batch,
    .any_batch = cpu_any_batch,
    .shade = cpu_shade,
};

/* The stand-in device over scene's built tree (no instances), given it
 * as the kernel gives a device its tree. */
static rtk_status cpu_device_of(const rtk_scene *scene, cpu_device *d)
{
    memset(d, 0, sizeof *d);
    rtk_device_tree tree;
    rtk_status st = rtk_device_tree_view(scene, 1, &tree, &d->block);
    if (st != RTK_OK)
        return st;
    d->lights = tree.lights ? tree.lights->stamp : 0;
    rtk_flat_scene flat;
    rtk_flat_scene_of(&tree, NULL, &flat);
    return rtk_program_scene_of(&tree, &flat, &d->program_block, &d->ps) == 0 ? RTK_OK : RTK_ERR_NOMEM;
}

void rtk_conform_device_program(rtk_conform_runner *r, const rtk_integrator_fns *f, void *state, rtk_scene *scene,
                                rtk_film_render *job, float *through_program, float *through_li, size_t count,
                                const char *label)
{
    rtk_device_program desc;
    memset(&desc, 0, sizeof desc);
    if (f->size < offsetof(rtk_integrator_fns, device_program) + sizeof f->device_program || !f->device_program ||
        !f->device_program(state, &desc))
        return;
    char name[256];
    desc.name[sizeof desc.name - 1] = '\0';
    snprintf(name, sizeof name, "device program '%s' is one the kernel runs [%s]", desc.name, label);
    const rtk_program p = rtk_program_of(&desc);
    rtk_conform_check(r, p.kind != RTK_PROGRAM_NONE, name, "plugins/integrators/device_programs.h lists no program '%s' "
                      "with parameters %g, %g, ...", desc.name, (double)desc.params[0], (double)desc.params[1]);
    if (p.kind == RTK_PROGRAM_NONE)
        return;
    cpu_device d;
    rtk_status st = cpu_device_of(scene, &d);
    const rtk_accelerator_fns *saved_device = scene->device;
    void *saved_state = scene->device_state;
    const uint64_t saved_lights = scene->device_lights;
    scene->device = &cpu_device_fns;
    scene->device_state = &d;
    scene->device_lights = d.lights;
    const char *why = st == RTK_OK ? rtk_device_runs(scene, &desc) : "out of memory";
    static const rtk_sampler_type samplers[] = {RTK_SAMPLER_INDEPENDENT, RTK_SAMPLER_STRATIFIED, RTK_SAMPLER_SOBOL};
    static const char *const names[] = {"independent", "stratified", "sobol"};
    for (size_t k = 0; k < sizeof samplers / sizeof samplers[0]; k++) {
        snprintf(name, sizeof name, "device program equals li bit for bit (%s sampler) [%s]", names[k], label);
        if (why) {
            rtk_conform_check(r, 0, name, "the standard room cannot run it: %s", why);
            continue;
        }
        rtk_render_stats sa, sb;
        job->sampler = samplers[k];
        job->one_ray_at_a_time = 0;
        job->device_program = &desc;
        rtk_status s1 = rtk_render_film(job, through_program, &sa);
        job->device_program = NULL;
        job->one_ray_at_a_time = 1;
        rtk_status s2 = s1 == RTK_OK ? rtk_render_film(job, through_li, &sb) : s1;
        if (s1 != RTK_OK || s2 != RTK_OK) {
            rtk_conform_check(r, 0, name, "%s", rtk_error_message());
            continue;
        }
        rtk_conform_same_films(r, name, "the program", through_program, &sa, through_li, &sb, count);
    }
    job->sampler = RTK_SAMPLER_INDEPENDENT;
    job->one_ray_at_a_time = 0;
    job->device_program = NULL;
    scene->device = saved_device;
    scene->device_state = saved_state;
    scene->device_lights = saved_lights;
    free(d.block);
    free(d.program_block);
}

/* Config loading: libconfig text, then the --set overrides, then every
 * value checked against a schema, then the plugins resolved. The kernel's
 * own settings (scene, camera, film, sampler, textures, threads) are
 * described with the same rtk_param_desc tables as plugin parameters, so
 * every slot gets the same checks and "did you mean" suggestions. Every
 * error names the config file and line, or the --set entry it came from,
 * and happens before any scene data is read. */
#include "config.h"
#include "../accel/accel.h"

#include <ctype.h>
#include <errno.h>
#include <libconfig.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

static const rtk_param_desc top_params[] = {
    {.name = "scene", .type = RTK_PARAM_STRING, .required = 1,
     .doc = "model to render (.obj, .gltf, .glb), relative to the config file"},
    {.name = "camera", .type = RTK_PARAM_STRING, .doc = "group: position, look_at, up, fov"},
    {.name = "film", .type = RTK_PARAM_STRING, .doc = "group: width, height, spp, output, half, aovs"},
    {.name = "sampler", .type = RTK_PARAM_STRING, .doc = "group: type, seed"},
    {.name = "textures", .type = RTK_PARAM_STRING, .doc = "group: filter"},
    {.name = "threads", .type = RTK_PARAM_INT, .def = 0, .min = 0, .max = 1024,
     .doc = "render threads, 0 = one per core this process may use; more than those are capped with a warning"},
    {.name = "oversubscribe", .type = RTK_PARAM_BOOL, .def = 0,
     .doc = "run threads beyond the cores this process may use as given (they take turns), as --oversubscribe does"},
    {.name = "cache", .type = RTK_PARAM_STRING, .def_string = "",
     .doc = "BVH cache directory, relative to the config file; \"off\" disables; "
            "default $XDG_CACHE_HOME/rtk or ~/.cache/rtk"},
    {.name = "cache_limit", .type = RTK_PARAM_INT, .def = 4096, .min = 0, .max = 1048576,
     .doc = "MB the BVH cache may hold: past it, the least recently used trees are removed; 0 = no limit"},
    {.name = "plugin_path", .type = RTK_PARAM_STRING,
     .doc = "directory or list of directories with more plugins (trusted configs only)"},
    {.name = "lights", .type = RTK_PARAM_STRING,
     .doc = "list of point, spot and directional lights: ( { type = \"point\"; ... }, ... )"},
    {.name = "environment", .type = RTK_PARAM_STRING,
     .doc = "group: light from rays that leave the scene: file = \"sky.exr\" (equirectangular) or color = [r, g, b]; "
            "strength, rotation"},
    {.name = "instances", .type = RTK_PARAM_STRING,
     .doc = "list of models placed beside the scene, each loaded once: ( { file = \"bunny.obj\"; "
            "translate = [x, y, z]; rotate = [ax, ay, az, degrees]; scale = s; grid = [nx, ny, nz]; "
            "spacing = [dx, dy, dz]; }, ... )"},
    {.name = "accelerator", .type = RTK_PARAM_STRING, .doc = "group: plugin = \"sah\"; and its parameters"},
    {.name = "integrator", .type = RTK_PARAM_STRING, .doc = "group: plugin = \"headlight\"; and its parameters"},
    {.name = "filter", .type = RTK_PARAM_STRING, .doc = "group: plugin = \"box\"; and its parameters"},
};
static const char *const top_special[] = {"camera", "film", "sampler", "textures", "plugin_path", "lights",
                                          "environment", "instances", "accelerator", "integrator", "filter", NULL};

static const rtk_param_desc camera_params[] = {
    {.name = "position", .type = RTK_PARAM_STRING, .required = 1, .doc = "eye point [x, y, z]"},
    {.name = "look_at", .type = RTK_PARAM_STRING, .required = 1, .doc = "point looked at [x, y, z]"},
    {.name = "up", .type = RTK_PARAM_STRING, .doc = "up direction [x, y, z], default [0, 1, 0]"},
    {.name = "fov", .type = RTK_PARAM_FLOAT, .def = 39.3, .min = 0.0, .max = 180.0,
     .doc = "vertical field of view in degrees, in (0, 180)"},
};
static const char *const camera_special[] = {"position", "look_at", "up", NULL};

static const rtk_param_desc film_params[] = {
    {.name = "width", .type = RTK_PARAM_INT, .def = 512, .min = 1, .max = 16384, .doc = "image width in pixels"},
    {.name = "height", .type = RTK_PARAM_INT, .def = 512, .min = 1, .max = 16384, .doc = "image height in pixels"},
    {.name = "spp", .type = RTK_PARAM_INT, .def = 16, .min = 1, .max = 1 << 20, .doc = "samples per pixel"},
    {.name = "output", .type = RTK_PARAM_STRING, .def_string = "",
     .doc = "image file (.exr or .png), default <config name>.png next to the config"},
    {.name = "half", .type = RTK_PARAM_BOOL, .def = 0, .doc = "store EXR channels as half floats"},
    {.name = "reconstruction", .type = RTK_PARAM_STRING, .def_string = "splat", .choices = "splat|importance",
     .doc = "splat: each sample weighted into every pixel the filter reaches; importance: samples placed by the "
            "filter (weights f / pdf), each into its own pixel"},
    {.name = "aovs", .type = RTK_PARAM_STRING,
     .doc = "extra EXR layers: a list of \"albedo\", \"normal\", \"depth\""},
};
static const char *const film_special[] = {"aovs", NULL};

static const rtk_param_desc sampler_params[] = {
    {.name = "type", .type = RTK_PARAM_STRING, .def_string = "independent", .choices = "independent|stratified|sobol",
     .doc = "sample generator: independent (PCG32), stratified (jittered strata) or sobol (Owen-scrambled)"},
    {.name = "seed", .type = RTK_PARAM_INT, .def = 0, .min = 0, .max = 9223372036854775807.0,
     .doc = "seed of the sample streams"},
};

static const rtk_param_desc textures_params[] = {
    {.name = "filter", .type = RTK_PARAM_STRING, .def_string = "bilinear", .choices = "nearest|bilinear|trilinear",
     .doc = "texture filter: nearest texel, bilinear, or trilinear between MIP levels picked by ray differentials"},
    {.name = "memory", .type = RTK_PARAM_INT, .def = 2048, .min = 1, .max = 1048576,
     .doc = "MB the decoded textures may take in all (float RGBA, MIP levels included); a texture past it is "
            "not decoded, with a warning"},
};

static const rtk_param_desc light_params[] = {
    {.name = "type", .type = RTK_PARAM_STRING, .def_string = "point", .choices = "point|spot|directional",
     .doc = "kind of light"},
    {.name = "position", .type = RTK_PARAM_STRING, .doc = "point and spot: where the light is [x, y, z]"},
    {.name = "direction", .type = RTK_PARAM_STRING,
     .doc = "directional and spot: the direction the light travels [x, y, z]"},
    {.name = "intensity", .type = RTK_PARAM_STRING,
     .doc = "[r, g, b]: W/sr for point and spot, irradiance W/m^2 for directional"},
    {.name = "inner", .type = RTK_PARAM_FLOAT, .def = 30.0, .min = 0.0, .max = 90.0,
     .doc = "spot: half-angle of full intensity, degrees"},
    {.name = "outer", .type = RTK_PARAM_FLOAT, .def = 45.0, .min = 0.0, .max = 90.0,
     .doc = "spot: half-angle beyond which it is dark, degrees"},
};
static const char *const light_special[] = {"position", "direction", "intensity", NULL};

static const rtk_param_desc environment_params[] = {
    {.name = "file", .type = RTK_PARAM_STRING,
     .doc = "equirectangular RGB image (EXR, HDR, any float image OpenImageIO reads), relative to the config"},
    {.name = "color", .type = RTK_PARAM_STRING, .doc = "[r, g, b]: a constant radiance instead of a file"},
    {.name = "strength", .type = RTK_PARAM_FLOAT, .def = 1.0, .min = 0.0, .max = 1e30,
     .doc = "factor on the radiance"},
    {.name = "rotation", .type = RTK_PARAM_FLOAT, .def = 0.0, .min = -36000.0, .max = 36000.0,
     .doc = "degrees about +y (the up axis), right-handed: 90 moves the image's centre from -z to -x"},
};
static const char *const environment_special[] = {"color", NULL};

static const rtk_param_desc instance_params[] = {
    {.name = "file", .type = RTK_PARAM_STRING, .required = 1,
     .doc = "model to place (.obj, .gltf, .glb), relative to the config file; loaded once however often placed"},
    {.name = "translate", .type = RTK_PARAM_STRING, .doc = "[x, y, z] added after rotating and scaling"},
    {.name = "rotate", .type = RTK_PARAM_STRING, .doc = "[ax, ay, az, degrees]: rotation about an axis"},
    {.name = "scale", .type = RTK_PARAM_STRING, .doc = "s or [sx, sy, sz], applied first"},
    {.name = "grid", .type = RTK_PARAM_STRING,
     .doc = "[nx, ny, nz] copies, default [1, 1, 1]; copy (i, j, k) moves by (i dx, j dy, k dz)"},
    {.name = "spacing", .type = RTK_PARAM_STRING, .doc = "[dx, dy, dz] between grid copies"},
};
static const char *const instance_special[] = {"translate", "rotate", "scale", "grid", "spacing", NULL};

static const rtk_plugin top_schema = {RTK_PLUGIN_HEADER, .name = "the config", .params = top_params,
                                      .param_count = RTK_COUNTOF(top_params)};
static const rtk_plugin camera_schema = {RTK_PLUGIN_HEADER, .name = "camera", .params = camera_params,
                                         .param_count = RTK_COUNTOF(camera_params)};
static const rtk_plugin film_schema = {RTK_PLUGIN_HEADER, .name = "film", .params = film_params,
                                       .param_count = RTK_COUNTOF(film_params)};
static const rtk_plugin sampler_schema = {RTK_PLUGIN_HEADER, .name = "sampler", .params = sampler_params,
                                          .param_count = RTK_COUNTOF(sampler_params)};
static const rtk_plugin textures_schema = {RTK_PLUGIN_HEADER, .name = "textures", .params = textures_params,
                                           .param_count = RTK_COUNTOF(textures_params)};
static const rtk_plugin light_schema = {RTK_PLUGIN_HEADER, .name = "lights", .params = light_params,
                                        .param_count = RTK_COUNTOF(light_params)};
static const rtk_plugin environment_schema = {RTK_PLUGIN_HEADER, .name = "environment", .params = environment_params,
                                              .param_count = RTK_COUNTOF(environment_params)};
static const rtk_plugin instance_schema = {RTK_PLUGIN_HEADER, .name = "instances", .params = instance_params,
                                           .param_count = RTK_COUNTOF(instance_params)};

static const char aov_choices[] = "albedo|normal|depth";

/* The errors of one load, reported together: every bad key and --set entry
 * at once rather than one per run. */
typedef struct error_list {
    char text[3600];  /* the messages, one per line */
    size_t used;
    unsigned count;   /* errors recorded */
    unsigned dropped; /* of those, left out of text for lack of room */
    rtk_status first; /* the first one's status */
} error_list;

/* One override: its "path=value" entry and how the user wrote it, for
 * messages ("-o out.png"; NULL: "--set ENTRY"). */
typedef struct override {
    char *entry;
    char *label;
} override;

/* State of one rtk_config_load call. */
typedef struct loader {
    const char *path;      /* the config file as the caller named it */
    char *dir;             /* its directory: relative paths start here */
    config_t cfg;
    rtk_registry *registry;
    int trusted;           /* options->allow_config_plugins */
    override *overrides;   /* the --set entries; settings they made point here */
    size_t override_count;
    int oversubscribe;     /* options->oversubscribe */
    error_list *errors;    /* every error found so far */
} loader;

/* Records the current error message (of status code) in ld->errors. */
static void note_error(const loader *ld, rtk_status code)
{
    error_list *e = ld->errors;
    const char *msg = rtk_error_message();
    if (e->count++ == 0)
        e->first = code;
    size_t need = strlen(msg) + 4;
    if (e->used + need >= sizeof e->text) {
        e->dropped++;
        return;
    }
    e->used += (size_t)snprintf(e->text + e->used, sizeof e->text - e->used, "%s%s", e->used ? "\n  " : "", msg);
}

/* The outcome of a load: RTK_OK, its one error as it was, or a message
 * listing every error. */
static rtk_status report_errors(const error_list *e)
{
    if (e->count == 0)
        return RTK_OK;
    if (e->count == 1)
        return rtk_error(e->first, "%s", e->text);
    char more[64] = "";
    if (e->dropped)
        snprintf(more, sizeof more, "\n  ... and %u more", e->dropped);
    return rtk_error(e->first, "%u errors:\n  %s%s", e->count, e->text, more);
}

/* The name to show for file, a setting's source as libconfig reports it:
 * @include names are relative to the config's directory. [caller frees] */
static char *included_file(const loader *ld, const char *file)
{
    if (!file || strcmp(file, ld->path) == 0)
        return rtk_strdup(ld->path);
    return rtk_path_join(ld->dir, file);
}

/* How an override is named in messages: its label, or "--set ENTRY". */
static void override_name(const override *o, char *buf, size_t size)
{
    if (o->label)
        snprintf(buf, size, "%s", o->label);
    else
        snprintf(buf, size, "--set %s", o->entry);
}

/* Where s came from: "scene.cfg:7", "--set film.width=64", "-o out.png",
 * or the file alone when s is NULL or has no line. */
static void where(const loader *ld, const config_setting_t *s, char *buf, size_t size)
{
    const override *o = s ? config_setting_get_hook(s) : NULL;
    if (o) {
        override_name(o, buf, size);
        return;
    }
    const char *file = s ? config_setting_source_file(s) : NULL;
    unsigned line = s ? config_setting_source_line(s) : 0;
    char *shown = included_file(ld, file);
    if (line)
        snprintf(buf, size, "%s:%u", shown ? shown : ld->path, line);
    else
        snprintf(buf, size, "%s", shown ? shown : ld->path);
    free(shown);
}

/* Records an error located at s and returns code. */
static rtk_status fail(const loader *ld, const config_setting_t *s, rtk_status code, const char *fmt, ...)
    RTK_PRINTF(4, 5);
static rtk_status fail(const loader *ld, const config_setting_t *s, rtk_status code, const char *fmt, ...)
{
    char loc[1100], text[3000];
    where(ld, s, loc, sizeof loc);
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    return rtk_error(code, "%s: %s", loc, text);
}

/* The text after '=' of the --set entry that made s, or NULL. */
static const char *override_text(const config_setting_t *s)
{
    const override *o = config_setting_get_hook(s);
    const char *eq = o ? strchr(o->entry, '=') : NULL;
    return eq ? eq + 1 : NULL;
}

/* What s holds, for "expected X, found Y" messages. */
static void describe_setting(const config_setting_t *s, char *buf, size_t size)
{
    switch (config_setting_type(s)) {
    case CONFIG_TYPE_INT:
    case CONFIG_TYPE_INT64:
        snprintf(buf, size, "an integer (%lld)", config_setting_get_int64(s));
        break;
    case CONFIG_TYPE_FLOAT:
        snprintf(buf, size, "a float (%g)", config_setting_get_float(s));
        break;
    case CONFIG_TYPE_BOOL:
        snprintf(buf, size, "a boolean (%s)", config_setting_get_bool(s) ? "true" : "false");
        break;
    case CONFIG_TYPE_STRING:
        snprintf(buf, size, "a string (\"%s\")", config_setting_get_string(s));
        break;
    case CONFIG_TYPE_GROUP:
        snprintf(buf, size, "a group { ... }");
        break;
    case CONFIG_TYPE_ARRAY:
        snprintf(buf, size, "an array [ ... ]");
        break;
    case CONFIG_TYPE_LIST:
        snprintf(buf, size, "a list ( ... )");
        break;
    default:
        snprintf(buf, size, "nothing");
        break;
    }
}

static int is_int_setting(const config_setting_t *s)
{
    return config_setting_type(s) == CONFIG_TYPE_INT || config_setting_type(s) == CONFIG_TYPE_INT64;
}

static int is_sequence(const config_setting_t *s)
{
    return config_setting_type(s) == CONFIG_TYPE_ARRAY || config_setting_type(s) == CONFIG_TYPE_LIST;
}

/* 1 for the spellings of infinity libconfig itself cannot parse. */
static int is_inf_text(const char *s)
{
    if (*s == '+' || *s == '-')
        s++;
    return strcasecmp(s, "inf") == 0 || strcasecmp(s, "infinity") == 0;
}

static int in_list(const char *const *list, const char *name)
{
    for (; list && *list; list++) {
        if (strcmp(*list, name) == 0)
            return 1;
    }
    return 0;
}

static const rtk_param_desc *find_desc(const rtk_plugin *schema, const char *name)
{
    for (uint32_t i = 0; i < schema->param_count; i++) {
        if (strcmp(schema->params[i].name, name) == 0)
            return &schema->params[i];
    }
    return NULL;
}

static rtk_param_value *find_value(rtk_params *params, const char *name)
{
    for (uint32_t i = 0; i < params->count; i++) {
        if (strcmp(params->values[i].desc->name, name) == 0)
            return &params->values[i];
    }
    return NULL;
}

/* Sets one declared value from a libconfig setting: integers are accepted
 * where numbers are expected, floats never where integers are; strings
 * "inf"/"infinity" stand for the infinity libconfig cannot write. */
static rtk_status set_from_setting(const loader *ld, rtk_params *params, const rtk_param_desc *desc,
                                   const config_setting_t *s, const char *prefix)
{
    char text[64];
    const char *use = NULL;
    int type = config_setting_type(s);
    switch (desc->type) {
    case RTK_PARAM_INT:
        if (is_int_setting(s)) {
            snprintf(text, sizeof text, "%lld", config_setting_get_int64(s));
            use = text;
        }
        break;
    case RTK_PARAM_FLOAT:
        if (is_int_setting(s)) {
            snprintf(text, sizeof text, "%lld", config_setting_get_int64(s));
            use = text;
        } else if (type == CONFIG_TYPE_FLOAT) {
            snprintf(text, sizeof text, "%.17g", config_setting_get_float(s));
            use = text;
        } else if (type == CONFIG_TYPE_STRING && is_inf_text(config_setting_get_string(s))) {
            use = config_setting_get_string(s);
        }
        break;
    case RTK_PARAM_BOOL:
        if (type == CONFIG_TYPE_BOOL) {
            use = config_setting_get_bool(s) ? "true" : "false";
        } else if (is_int_setting(s)) {
            snprintf(text, sizeof text, "%lld", config_setting_get_int64(s));
            use = text;
        }
        break;
    case RTK_PARAM_STRING:
        if (type == CONFIG_TYPE_STRING)
            use = config_setting_get_string(s);
        break;
    }
    /* A --set value was typed by guessing; let the schema read its text
     * (--set film.output=2024, --set film.half=yes). */
    if (!use && config_setting_is_scalar(s))
        use = override_text(s);
    if (!use) {
        char found[256];
        describe_setting(s, found, sizeof found);
        const char *expected = desc->type == RTK_PARAM_INT     ? "an integer"
                               : desc->type == RTK_PARAM_FLOAT ? "a number"
                               : desc->type == RTK_PARAM_BOOL  ? "a boolean (true or false)"
                                                               : "a string";
        return fail(ld, s, RTK_ERR_INVALID, "%s%s: expected %s, found %s", prefix, desc->name, expected, found);
    }
    if (rtk_params_set_text(params, desc->name, use) != RTK_OK)
        return fail(ld, s, RTK_ERR_INVALID, "%s%s", prefix, rtk_error_message());
    return RTK_OK;
}

/* Appends "a, b, c" (the schema's names, after "plugin" for plugin slots). */
static void list_keys(const rtk_plugin *schema, int plugin_slot, char *buf, size_t size)
{
    size_t used = 0;
    buf[0] = '\0';
    if (plugin_slot)
        used += (size_t)snprintf(buf, size, "plugin");
    for (uint32_t i = 0; i < schema->param_count && used < size; i++)
        used += (size_t)snprintf(buf + used, size - used, "%s%s", used ? ", " : "", schema->params[i].name);
}

/* How one group is checked against a schema. */
typedef struct slot_spec {
    const char *label;           /* "film", "integrator"; NULL at the top level */
    const rtk_plugin *schema;    /* kernel table or the chosen plugin */
    const char *const *special;  /* declared keys the caller reads itself (arrays, groups) */
    int plugin_slot;             /* the group also holds plugin = "..." */
    int plugin_chosen;           /* the plugin was named, not taken by default */
    const config_setting_t *at;  /* where to point when the group is not given */
} slot_spec;

/* Error for a key the schema does not declare. */
static rtk_status unknown_key(const loader *ld, const config_setting_t *s, const slot_spec *spec)
{
    const char *name = config_setting_name(s);
    char keys[1024], hint[256] = "";
    list_keys(spec->schema, spec->plugin_slot, keys, sizeof keys);
    const char *near = rtk_params_suggest(spec->schema->params, spec->schema->param_count, name);
    if (spec->plugin_slot) {
        static const rtk_param_desc plugin_key[] = {{.name = "plugin", .type = RTK_PARAM_STRING}};
        const char *p = rtk_params_suggest(plugin_key, 1, name);
        if (p && (!near || rtk_edit_distance(name, p) < rtk_edit_distance(name, near)))
            near = p;
    }
    char mean[200] = "";
    if (near)
        snprintf(mean, sizeof mean, " (did you mean '%s'?)", near);
    if (spec->plugin_slot && !spec->plugin_chosen)
        snprintf(hint, sizeof hint, "; %s is the default %s: choose another with plugin = \"name\";",
                 spec->schema->name, spec->label);
    if (!spec->label)
        return fail(ld, s, RTK_ERR_INVALID, "unknown setting '%s'%s; top-level settings: %s", name, mean, keys);
    return fail(ld, s, RTK_ERR_INVALID, "%s: unknown key '%s'%s; keys of %s: %s%s", spec->label, name, mean,
                spec->schema->name, keys, hint);
}

/* Checks every member of group (NULL = not given) against spec and returns
 * the params with defaults for the rest. Keys in spec->special are left to
 * the caller and only marked as given. A bad key is recorded in
 * ld->errors and the others are still checked. */
static rtk_status fill_params(const loader *ld, const config_setting_t *group, const slot_spec *spec,
                              rtk_params **out)
{
    *out = NULL;
    rtk_params *params = rtk_params_defaults(spec->schema);
    if (!params)
        return RTK_ERR_NOMEM;
    char prefix[128] = "";
    if (spec->label)
        snprintf(prefix, sizeof prefix, "%s: ", spec->label);
    const unsigned errors_before = ld->errors->count;
    int count = group ? config_setting_length(group) : 0;
    for (int i = 0; i < count; i++) {
        const config_setting_t *s = config_setting_get_elem(group, (unsigned)i);
        const char *name = config_setting_name(s);
        if (spec->plugin_slot && strcmp(name, "plugin") == 0)
            continue;
        rtk_param_value *value = find_value(params, name);
        rtk_status status = RTK_OK;
        if (!value)
            status = unknown_key(ld, s, spec);
        else if (in_list(spec->special, name))
            value->set_by_user = 1;
        else
            status = set_from_setting(ld, params, value->desc, s, prefix);
        if (status == RTK_ERR_NOMEM) {
            rtk_params_destroy(params);
            return status;
        }
        if (status != RTK_OK)
            note_error(ld, status); /* and on to the group's other keys */
    }
    if (ld->errors->count != errors_before) {
        rtk_params_destroy(params);
        return RTK_ERR_INVALID;
    }
    const config_setting_t *at = group ? group : spec->at;
    for (uint32_t i = 0; i < params->count; i++) {
        const rtk_param_desc *desc = params->values[i].desc; /* points into the schema */
        if (desc->required && !params->values[i].set_by_user) {
            rtk_params_destroy(params);
            const char *doc = desc->doc ? desc->doc : "required";
            if (spec->plugin_slot)
                return fail(ld, at, RTK_ERR_INVALID, "%s: plugin %s needs '%s' (%s)", spec->label, spec->schema->name,
                            desc->name, doc);
            return fail(ld, at, RTK_ERR_INVALID, "%smissing required key '%s' (%s)", prefix, desc->name, doc);
        }
    }
    *out = params;
    return RTK_OK;
}

/* The member key of group, or NULL when group is NULL or lacks it. */
static config_setting_t *member(const config_setting_t *group, const char *key)
{
    return group ? config_setting_get_member(group, key) : NULL;
}

/* Reads key of group as [x, y, z] when given. */
/* Reads group.key as a list of n finite numbers into v; leaves v alone
 * when the key is absent. */
static rtk_status read_numbers(const loader *ld, const config_setting_t *group, const char *label, const char *key,
                               unsigned n, const char *shape, double *v)
{
    const config_setting_t *s = member(group, key);
    if (!s)
        return RTK_OK;
    char found[256];
    if (!is_sequence(s) || config_setting_length(s) != (int)n) {
        if (is_sequence(s))
            snprintf(found, sizeof found, "%d elements", config_setting_length(s));
        else
            describe_setting(s, found, sizeof found);
        return fail(ld, s, RTK_ERR_INVALID, "%s: %s: expected %u numbers %s, found %s", label, key, n, shape, found);
    }
    for (unsigned i = 0; i < n; i++) {
        const config_setting_t *e = config_setting_get_elem(s, i);
        if (is_int_setting(e)) {
            v[i] = (double)config_setting_get_int64(e);
        } else if (config_setting_type(e) == CONFIG_TYPE_FLOAT) {
            v[i] = config_setting_get_float(e);
        } else {
            describe_setting(e, found, sizeof found);
            return fail(ld, s, RTK_ERR_INVALID, "%s: %s: element %u: expected a number, found %s", label, key,
                        i + 1, found);
        }
        if (!isfinite(v[i]) || fabs(v[i]) > 3.0e38)
            return fail(ld, s, RTK_ERR_INVALID, "%s: %s: element %u (%g) is not a finite float", label, key,
                        i + 1, v[i]);
    }
    return RTK_OK;
}

static rtk_status read_vec3(const loader *ld, const config_setting_t *group, const char *label, const char *key,
                            rtk_vec3 *out)
{
    double v[3] = {out->x, out->y, out->z};
    rtk_status status = read_numbers(ld, group, label, key, 3, "[x, y, z]", v);
    if (status != RTK_OK)
        return status;
    *out = rtk_vec3_make((float)v[0], (float)v[1], (float)v[2]);
    return RTK_OK;
}

/* Reads film.aovs: one string or a list of strings among aov_choices;
 * needs cfg->output set, as AOV layers exist only in EXR files. */
static rtk_status read_aovs(const loader *ld, const config_setting_t *film, rtk_config *cfg)
{
    const config_setting_t *s = member(film, "aovs");
    if (!s)
        return RTK_OK;
    if (!is_sequence(s) && config_setting_type(s) != CONFIG_TYPE_STRING) {
        char found[256];
        describe_setting(s, found, sizeof found);
        return fail(ld, s, RTK_ERR_INVALID, "film: aovs: expected a list of strings like [\"albedo\", \"depth\"], found %s",
                    found);
    }
    int count = is_sequence(s) ? config_setting_length(s) : 1;
    for (int i = 0; i < count; i++) {
        const config_setting_t *e = is_sequence(s) ? config_setting_get_elem(s, (unsigned)i) : s;
        if (config_setting_type(e) != CONFIG_TYPE_STRING) {
            char found[256];
            describe_setting(e, found, sizeof found);
            return fail(ld, s, RTK_ERR_INVALID, "film: aovs: expected one of \"albedo\", \"normal\", \"depth\", found %s",
                        found);
        }
        const char *name = config_setting_get_string(e);
        if (strcmp(name, "albedo") == 0) {
            cfg->aov_albedo = 1;
        } else if (strcmp(name, "normal") == 0) {
            cfg->aov_normal = 1;
        } else if (strcmp(name, "depth") == 0) {
            cfg->aov_depth = 1;
        } else {
            static const rtk_param_desc aovs[] = {{.name = "albedo"}, {.name = "normal"}, {.name = "depth"}};
            const char *near = rtk_params_suggest(aovs, RTK_COUNTOF(aovs), name);
            char mean[128] = "";
            if (near)
                snprintf(mean, sizeof mean, " (did you mean '%s'?)", near);
            return fail(ld, s, RTK_ERR_INVALID, "film: aovs: '%s' is not one of: %s%s", name, aov_choices, mean);
        }
    }
    size_t n = strlen(cfg->output);
    if ((cfg->aov_albedo || cfg->aov_normal || cfg->aov_depth) && (n < 4 || strcasecmp(cfg->output + n - 4, ".exr")))
        return fail(ld, s, RTK_ERR_INVALID, "film: aovs need an EXR output, but the image goes to '%s': "
                    "set film.output = \"name.exr\"", cfg->output);
    return RTK_OK;
}

/* Resolves a path against the config's directory: canonical when it
 * exists, else made absolute, so trust messages show the real place. */
static char *resolve(const loader *ld, const char *path)
{
    char *joined = rtk_path_join(ld->dir, path);
    if (!joined)
        return NULL;
    char *real = realpath(joined, NULL);
    if (real) {
        free(joined);
        return real;
    }
    char cwd[4096];
    if (joined[0] == '/' || !getcwd(cwd, sizeof cwd))
        return joined;
    char *absolute = rtk_path_join(cwd, joined);
    free(joined);
    return absolute;
}

/* Honours plugin_path (a string or a list of strings) for trusted configs. */
static rtk_status read_plugin_path(const loader *ld, const config_setting_t *root, rtk_config *cfg)
{
    (void)cfg;
    const config_setting_t *s = member(root, "plugin_path");
    if (!s)
        return RTK_OK;
    int count = is_sequence(s) ? config_setting_length(s) : 1;
    if (!is_sequence(s) && config_setting_type(s) != CONFIG_TYPE_STRING)
        count = -1;
    for (int i = 0; i < count; i++) {
        const config_setting_t *e = is_sequence(s) ? config_setting_get_elem(s, (unsigned)i) : s;
        if (config_setting_type(e) != CONFIG_TYPE_STRING) {
            count = -1;
            break;
        }
    }
    if (count < 0) {
        char found[256];
        describe_setting(s, found, sizeof found);
        return fail(ld, s, RTK_ERR_INVALID,
                    "plugin_path: expected a directory or a list of directories [\"a\", \"b\"], found %s", found);
    }
    for (int i = 0; i < count; i++) {
        const config_setting_t *e = is_sequence(s) ? config_setting_get_elem(s, (unsigned)i) : s;
        const char *text = config_setting_get_string(e);
        if (!text[0])
            return fail(ld, s, RTK_ERR_INVALID, "plugin_path: empty directory name");
        char *dir = resolve(ld, text);
        if (!dir)
            return RTK_ERR_NOMEM;
        rtk_status status = RTK_OK;
        struct stat st;
        if (!ld->trusted)
            status = fail(ld, s, RTK_ERR_PLUGIN,
                          "plugin_path would load code from '%s' named by the config; rerun with "
                          "--allow-config-plugins if you trust this config",
                          dir);
        else if (stat(dir, &st) != 0 || !S_ISDIR(st.st_mode))
            status = fail(ld, s, RTK_ERR_IO, "plugin_path: '%s' is not a directory", dir);
        else
            rtk_registry_add_dir(ld->registry, dir, "config plugin_path");
        free(dir);
        if (status != RTK_OK)
            return status;
    }
    return RTK_OK;
}

/* Resolves one plugin slot (a group with plugin = "name", or just the
 * name) and checks its parameters against the plugin's schema. */
static rtk_status load_slot(const loader *ld, const config_setting_t *root, const char *slot,
                            rtk_plugin_kind kind, const char *default_name, rtk_plugin_slot *out)
{
    const config_setting_t *s = member(root, slot);
    const config_setting_t *group = NULL, *named_at = s;
    const char *name = default_name;
    char found[256];
    if (s && config_setting_type(s) == CONFIG_TYPE_STRING) {
        name = config_setting_get_string(s);
    } else if (s && config_setting_is_group(s)) {
        group = s;
        const config_setting_t *p = member(s, "plugin");
        if (p) {
            named_at = p;
            if (config_setting_type(p) != CONFIG_TYPE_STRING) {
                describe_setting(p, found, sizeof found);
                return fail(ld, p, RTK_ERR_INVALID, "%s: plugin: expected a plugin name like \"%s\", found %s", slot,
                            default_name, found);
            }
            name = config_setting_get_string(p);
        }
    } else if (s) {
        describe_setting(s, found, sizeof found);
        return fail(ld, s, RTK_ERR_INVALID, "%s: expected a group { plugin = \"%s\"; ... }, found %s", slot,
                    default_name, found);
    }
    if (!name[0])
        return fail(ld, named_at, RTK_ERR_INVALID, "%s: plugin name is empty", slot);
    const rtk_plugin *plugin = NULL;
    rtk_status status;
    if (strchr(name, '/')) {
        char *file = resolve(ld, name);
        if (!file)
            return RTK_ERR_NOMEM;
        if (!ld->trusted)
            status = fail(ld, named_at, RTK_ERR_PLUGIN,
                          "%s: plugin = \"%s\" would load code from '%s' named by the config; rerun with "
                          "--allow-config-plugins if you trust this config",
                          slot, name, file);
        else if ((status = rtk_plugin_open(file, kind, &plugin)) != RTK_OK)
            status = fail(ld, named_at, status, "%s: %s", slot, rtk_error_message());
        free(file);
        if (status != RTK_OK)
            return status;
    } else if ((status = rtk_registry_find(ld->registry, kind, name, &plugin)) != RTK_OK) {
        return fail(ld, named_at, status, "%s: %s", slot, rtk_error_message());
    }
    if (!plugin || plugin->kind != kind)
        return fail(ld, named_at, RTK_ERR_PLUGIN, "%s: plugin '%s' is of kind %s, not %s", slot, name,
                    plugin ? rtk_kind_name(plugin->kind) : "(none)", rtk_kind_name(kind));
    slot_spec spec = {.label = slot, .schema = plugin, .plugin_slot = 1, .plugin_chosen = s != NULL,
                      .at = named_at};
    status = fill_params(ld, group, &spec, &out->params);
    if (status == RTK_OK)
        out->plugin = plugin;
    return status;
}

/* Checks that a top-level kernel slot is a group. */
static rtk_status expect_group(const loader *ld, const config_setting_t *s, const char *example)
{
    if (!s || config_setting_is_group(s))
        return RTK_OK;
    char found[256];
    describe_setting(s, found, sizeof found);
    return fail(ld, s, RTK_ERR_INVALID, "%s: expected a group like %s = { %s }, found %s", config_setting_name(s),
                config_setting_name(s), example, found);
}

static rtk_status read_camera(const loader *ld, const config_setting_t *root, rtk_config *cfg)
{
    const config_setting_t *group = member(root, "camera");
    rtk_status status = expect_group(ld, group, "position = [0.0, 1.0, 4.0]; look_at = [0.0, 1.0, 0.0];");
    if (status != RTK_OK)
        return status;
    rtk_params *params = NULL;
    slot_spec spec = {.label = "camera", .schema = &camera_schema, .special = camera_special};
    if (group && (status = fill_params(ld, group, &spec, &params)) != RTK_OK)
        return status;
    cfg->has_camera = group != NULL;
    cfg->camera.position = rtk_vec3_make(0.0f, 0.0f, 0.0f);
    cfg->camera.look_at = rtk_vec3_make(0.0f, 0.0f, -1.0f);
    cfg->camera.up = rtk_vec3_make(0.0f, 1.0f, 0.0f);
    cfg->camera.fov_deg = 39.3f;
    if (!params)
        return RTK_OK;
    double fov = rtk_params_float(params, "fov");
    rtk_params_destroy(params);
    if (fov <= 0.0 || fov >= 180.0)
        return fail(ld, member(group, "fov"), RTK_ERR_INVALID, "camera: fov = %g is out of range (0, 180)", fov);
    cfg->camera.fov_deg = (float)fov;
    if ((status = read_vec3(ld, group, "camera", "position", &cfg->camera.position)) != RTK_OK ||
        (status = read_vec3(ld, group, "camera", "look_at", &cfg->camera.look_at)) != RTK_OK ||
        (status = read_vec3(ld, group, "camera", "up", &cfg->camera.up)) != RTK_OK)
        return status;
    /* The same checks rtk_camera_init makes, here so they carry a line. */
    rtk_vec3 p = cfg->camera.position, a = cfg->camera.look_at, u = cfg->camera.up;
    double d[3] = {(double)a.x - p.x, (double)a.y - p.y, (double)a.z - p.z};
    double c[3] = {d[1] * u.z - d[2] * u.y, d[2] * u.x - d[0] * u.z, d[0] * u.y - d[1] * u.x};
    double dn = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    double un = sqrt((double)u.x * u.x + (double)u.y * u.y + (double)u.z * u.z);
    double cn = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    if (dn == 0.0)
        return fail(ld, member(group, "look_at"), RTK_ERR_INVALID, "camera: look_at is the same point as position");
    if (un == 0.0 || cn <= 1e-6 * dn * un)
        return fail(ld, member(group, "up") ? member(group, "up") : group, RTK_ERR_INVALID,
                    "camera: up [%g, %g, %g] is %s the view direction", u.x, u.y, u.z,
                    un == 0.0 ? "zero, it cannot orient" : "parallel to");
    return RTK_OK;
}

/* One element of a list of groups: its group g, label ("lights[2]") and
 * settings checked against the list's schema, into item. */
typedef rtk_status (*group_elem_fn)(const loader *ld, const config_setting_t *g, const char *label,
                                    const rtk_params *params, void *item, rtk_config *cfg);

/* A config list of groups such as lights or instances: what its groups
 * look like, for the messages, how their settings are checked and read. */
typedef struct group_list {
    const char *key;     /* "lights" */
    const char *example; /* a whole group, for the list's message */
    const char *brief;   /* its start, for an element's message */
    const rtk_plugin *schema;
    const char *const *special;
    size_t size; /* of an element */
    group_elem_fn read;
} group_list;

/* Reads the list gl->key of root, if there is one, into n + 1 zeroed
 * elements at *out, one group at a time. */
static rtk_status read_group_list(const loader *ld, const config_setting_t *root, const group_list *gl, void **out,
                                  rtk_config *cfg)
{
    const config_setting_t *list = member(root, gl->key);
    if (!list)
        return RTK_OK;
    if (config_setting_type(list) != CONFIG_TYPE_LIST) {
        char found[256];
        describe_setting(list, found, sizeof found);
        return fail(ld, list, RTK_ERR_INVALID, "%s: expected a list of groups ( %s ), found %s", gl->key,
                    gl->example, found);
    }
    int n = config_setting_length(list);
    char *items = rtk_calloc((size_t)n + 1, gl->size);
    *out = items;
    if (!items)
        return RTK_ERR_NOMEM;
    for (int i = 0; i < n; i++) {
        const config_setting_t *g = config_setting_get_elem(list, (unsigned)i);
        char label[32];
        snprintf(label, sizeof label, "%s[%d]", gl->key, i);
        if (config_setting_type(g) != CONFIG_TYPE_GROUP)
            return fail(ld, g, RTK_ERR_INVALID, "%s: expected a group %s", label, gl->brief);
        rtk_params *params = NULL;
        slot_spec spec = {.label = label, .schema = gl->schema, .special = gl->special};
        rtk_status status = fill_params(ld, g, &spec, &params);
        if (status == RTK_OK)
            status = gl->read(ld, g, label, params, items + (size_t)i * gl->size, cfg);
        rtk_params_destroy(params);
        if (status != RTK_OK)
            return status;
    }
    return RTK_OK;
}

/* One entry of the lights list. */
static rtk_status read_light(const loader *ld, const config_setting_t *g, const char *label,
                             const rtk_params *params, void *item, rtk_config *cfg)
{
    rtk_punctual_light *l = item;
    const char *type = rtk_params_string(params, "type");
    l->type = strcmp(type, "directional") == 0 ? RTK_LIGHT_DIRECTIONAL
              : strcmp(type, "spot") == 0      ? RTK_LIGHT_SPOT
                                               : RTK_LIGHT_POINT;
    double inner = rtk_params_float(params, "inner"), outer = rtk_params_float(params, "outer");
    const char *need = l->type == RTK_LIGHT_POINT ? "position" : l->type == RTK_LIGHT_DIRECTIONAL ? "direction" : NULL;
    if (need && !member(g, need))
        return fail(ld, g, RTK_ERR_INVALID, "%s: a %s light needs %s = [x, y, z]", label, type, need);
    if (l->type == RTK_LIGHT_SPOT && (!member(g, "position") || !member(g, "direction")))
        return fail(ld, g, RTK_ERR_INVALID, "%s: a spot light needs position and direction", label);
    if (!member(g, "intensity"))
        return fail(ld, g, RTK_ERR_INVALID, "%s: no intensity: add intensity = [r, g, b];", label);
    rtk_vec3 intensity = rtk_vec3_make(0, 0, 0);
    rtk_status status;
    if ((status = read_vec3(ld, g, label, "position", &l->position)) != RTK_OK ||
        (status = read_vec3(ld, g, label, "direction", &l->direction)) != RTK_OK ||
        (status = read_vec3(ld, g, label, "intensity", &intensity)) != RTK_OK)
        return status;
    if (intensity.x < 0.0f || intensity.y < 0.0f || intensity.z < 0.0f)
        return fail(ld, member(g, "intensity"), RTK_ERR_INVALID, "%s: intensity must not be negative", label);
    l->intensity = rtk_rgb_make(intensity.x, intensity.y, intensity.z);
    if (l->type != RTK_LIGHT_POINT) {
        if (rtk_vec3_length(l->direction) == 0.0f)
            return fail(ld, member(g, "direction"), RTK_ERR_INVALID, "%s: direction is zero", label);
        l->direction = rtk_vec3_normalize(l->direction);
    }
    if (l->type == RTK_LIGHT_SPOT && inner > outer)
        return fail(ld, g, RTK_ERR_INVALID, "%s: inner (%g) is wider than outer (%g)", label, inner, outer);
    l->cos_inner = (float)cos(inner * M_PI / 180.0);
    l->cos_outer = (float)cos(outer * M_PI / 180.0);
    cfg->light_count++;
    return RTK_OK;
}

/* Reads the list of punctual lights. */
static rtk_status read_lights(const loader *ld, const config_setting_t *root, rtk_config *cfg)
{
    static const group_list gl = {.key = "lights",
                                  .example = "{ type = \"point\"; position = [0, 2, 0]; intensity = [5, 5, 5]; }",
                                  .brief = "{ type = \"point\"; ... }",
                                  .schema = &light_schema,
                                  .special = light_special,
                                  .size = sizeof(rtk_punctual_light),
                                  .read = read_light};
    void *lights = NULL;
    rtk_status status = read_group_list(ld, root, &gl, &lights, cfg);
    cfg->lights = lights;
    return status;
}

/* Reads the environment group: a file or a colour, strength, rotation. */
static rtk_status read_environment(const loader *ld, const config_setting_t *root, rtk_config *cfg)
{
    static const char example[] = "file = \"sky.exr\"; strength = 1.0; rotation = 0.0;";
    const config_setting_t *group = member(root, "environment");
    if (!group)
        return RTK_OK;
    rtk_status status = expect_group(ld, group, example);
    if (status != RTK_OK)
        return status;
    rtk_params *params = NULL;
    slot_spec spec = {.label = "environment", .schema = &environment_schema, .special = environment_special};
    if ((status = fill_params(ld, group, &spec, &params)) != RTK_OK)
        return status;
    rtk_config_environment *env = &cfg->environment;
    const config_setting_t *file_at = member(group, "file"), *color_at = member(group, "color");
    env->strength = (float)rtk_params_float(params, "strength");
    env->rotation = (float)rtk_params_float(params, "rotation");
    char *file = file_at ? rtk_path_join(ld->dir, rtk_params_string(params, "file")) : NULL;
    int empty = file_at && !rtk_params_string(params, "file")[0];
    rtk_params_destroy(params);
    if (file_at && !file)
        return RTK_ERR_NOMEM;
    char loc[1050];
    where(ld, group, loc, sizeof loc);
    snprintf(env->where, sizeof env->where, "%s: environment", loc);
    struct stat st;
    if (file_at && color_at)
        status = fail(ld, color_at, RTK_ERR_INVALID,
                      "environment: both file and color are given; keep one (file = \"sky.exr\"; or color = [r, g, b];)");
    else if (!file_at && !color_at)
        status = fail(ld, group, RTK_ERR_INVALID, "environment: give file = \"sky.exr\"; or color = [r, g, b];");
    else if (empty)
        status = fail(ld, file_at, RTK_ERR_INVALID, "environment: file is empty: name an equirectangular EXR or HDR");
    else if (file_at && (stat(file, &st) != 0 || access(file, R_OK) != 0))
        status = fail(ld, file_at, RTK_ERR_IO, "environment: file '%s' cannot be read (%s): check the path, relative to "
                      "the config's folder", file, strerror(errno));
    else if (file_at && !S_ISREG(st.st_mode))
        status = fail(ld, file_at, RTK_ERR_IO, "environment: file '%s' is not a regular file: name an image", file);
    if (status != RTK_OK) {
        free(file);
        return status;
    }
    env->file = file;
    env->given = 1;
    if (color_at) {
        rtk_vec3 c = rtk_vec3_make(0.0f, 0.0f, 0.0f);
        if ((status = read_vec3(ld, group, "environment", "color", &c)) != RTK_OK)
            return status;
        if (c.x < 0.0f || c.y < 0.0f || c.z < 0.0f)
            return fail(ld, color_at, RTK_ERR_INVALID, "environment: color [%g, %g, %g] has a negative component; "
                        "radiance is 0 or more", c.x, c.y, c.z);
        env->color = rtk_rgb_make(c.x, c.y, c.z);
    }
    return RTK_OK;
}

/* Most copies one instances entry may ask for. */
#define RTK_MAX_GRID_COPIES (1u << 24)

/* T(translate) R(axis, degrees) S(scale), 3x4 row-major. */
static void compose(const double t[3], const double axis[3], double degrees, const double s[3], double m[12])
{
    double len = sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    double x = axis[0] / len, y = axis[1] / len, z = axis[2] / len;
    double a = degrees * M_PI / 180.0, c = cos(a), sn = sin(a), k = 1.0 - c;
    double r[9] = {c + x * x * k,      x * y * k - z * sn, x * z * k + y * sn,
                   y * x * k + z * sn, c + y * y * k,      y * z * k - x * sn,
                   z * x * k - y * sn, z * y * k + x * sn, c + z * z * k};
    for (int row = 0; row < 3; row++) {
        for (int col = 0; col < 3; col++)
            m[4 * row + col] = r[3 * row + col] * s[col];
        m[4 * row + 3] = t[row];
    }
}

/* One entry of the instances list (its file owned once counted, so that
 * rtk_config_destroy frees it). */
static rtk_status read_instance(const loader *ld, const config_setting_t *g, const char *label,
                                const rtk_params *params, void *item, rtk_config *cfg)
{
    rtk_config_instance *in = item;
    const char *file = rtk_params_string(params, "file");
    if (!file[0])
        return fail(ld, member(g, "file"), RTK_ERR_INVALID, "%s: file is empty: give the model to place", label);
    if (!(in->file = rtk_path_join(ld->dir, file)))
        return RTK_ERR_NOMEM;
    cfg->instance_count++;
    char loc[1050];
    where(ld, g, loc, sizeof loc);
    snprintf(in->where, sizeof in->where, "%s: %s", loc, label);

    double t[3] = {0, 0, 0}, rot[4] = {0, 1, 0, 0}, s[3] = {1, 1, 1}, grid[3] = {1, 1, 1};
    rtk_status status;
    const config_setting_t *scale = member(g, "scale");
    if (scale && (is_int_setting(scale) || config_setting_type(scale) == CONFIG_TYPE_FLOAT)) {
        double v = is_int_setting(scale) ? (double)config_setting_get_int64(scale) : config_setting_get_float(scale);
        s[0] = s[1] = s[2] = v;
    } else if ((status = read_numbers(ld, g, label, "scale", 3, "[sx, sy, sz] (or one number)", s)) != RTK_OK) {
        return status;
    }
    if ((status = read_numbers(ld, g, label, "translate", 3, "[x, y, z]", t)) != RTK_OK ||
        (status = read_numbers(ld, g, label, "rotate", 4, "[ax, ay, az, degrees]", rot)) != RTK_OK ||
        (status = read_numbers(ld, g, label, "grid", 3, "[nx, ny, nz]", grid)) != RTK_OK ||
        (status = read_numbers(ld, g, label, "spacing", 3, "[dx, dy, dz]", in->spacing)) != RTK_OK)
        return status;
    for (int k = 0; k < 3; k++) {
        if (!isfinite(s[k]) || s[k] == 0.0)
            return fail(ld, scale, RTK_ERR_INVALID, "%s: scale must be finite and not zero (it would flatten "
                        "the model)", label);
    }
    if (rot[0] == 0.0 && rot[1] == 0.0 && rot[2] == 0.0) {
        if (rot[3] != 0.0)
            return fail(ld, member(g, "rotate"), RTK_ERR_INVALID,
                        "%s: rotate: the axis [0, 0, 0] has no direction; give e.g. [0, 1, 0, %g]", label, rot[3]);
        rot[1] = 1.0;
    }
    double copies = 1.0;
    for (int k = 0; k < 3; k++) {
        if (grid[k] < 1.0 || grid[k] != floor(grid[k]))
            return fail(ld, member(g, "grid"), RTK_ERR_INVALID,
                        "%s: grid: element %d (%g) must be a whole number of copies, at least 1", label, k + 1,
                        grid[k]);
        copies *= grid[k];
    }
    if (copies > RTK_MAX_GRID_COPIES)
        return fail(ld, member(g, "grid"), RTK_ERR_INVALID, "%s: grid asks for %.0f copies; at most %u", label,
                    copies, RTK_MAX_GRID_COPIES);
    for (int k = 0; k < 3; k++)
        in->grid[k] = (uint32_t)grid[k];
    compose(t, rot, rot[3], s, in->to_world);
    return RTK_OK;
}

/* Reads the list of instanced models. */
static rtk_status read_instances(const loader *ld, const config_setting_t *root, rtk_config *cfg)
{
    static const group_list gl = {.key = "instances",
                                  .example = "{ file = \"bunny.obj\"; translate = [0, 0, 0]; }",
                                  .brief = "{ file = \"bunny.obj\"; ... }",
                                  .schema = &instance_schema,
                                  .special = instance_special,
                                  .size = sizeof(rtk_config_instance),
                                  .read = read_instance};
    void *instances = NULL;
    rtk_status status = read_group_list(ld, root, &gl, &instances, cfg);
    cfg->instances = instances;
    return status;
}

/* "<config name without .cfg>.png" next to the config. */
static char *default_output(const loader *ld)
{
    const char *slash = strrchr(ld->path, '/');
    const char *base = slash ? slash + 1 : ld->path;
    size_t n = strlen(base);
    if (n > 4 && strcmp(base + n - 4, ".cfg") == 0)
        n -= 4;
    char name[1024];
    snprintf(name, sizeof name, "%.*s.png", (int)(n < 1000 ? n : 1000), base);
    return rtk_path_join(ld->dir, name);
}

static rtk_status read_film(const loader *ld, const config_setting_t *root, rtk_config *cfg)
{
    const config_setting_t *group = member(root, "film");
    rtk_status status = expect_group(ld, group, "width = 512; height = 512; spp = 16;");
    if (status != RTK_OK)
        return status;
    rtk_params *params = NULL;
    slot_spec spec = {.label = "film", .schema = &film_schema, .special = film_special};
    if ((status = fill_params(ld, group, &spec, &params)) != RTK_OK)
        return status;
    cfg->width = (uint32_t)rtk_params_int(params, "width");
    cfg->height = (uint32_t)rtk_params_int(params, "height");
    cfg->spp = (uint32_t)rtk_params_int(params, "spp");
    cfg->half = rtk_params_bool(params, "half");
    cfg->importance = strcmp(rtk_params_string(params, "reconstruction"), "importance") == 0;
    const char *output = rtk_params_string(params, "output");
    const config_setting_t *at = member(group, "output");
    if (at && !output[0]) {
        status = fail(ld, at, RTK_ERR_INVALID, "film: output is empty");
    } else if (at) {
        const char *slash = strrchr(output, '/');
        const char *dot = strrchr(slash ? slash + 1 : output, '.');
        if (!dot || dot == (slash ? slash + 1 : output) || !dot[1])
            status = fail(ld, at, RTK_ERR_INVALID,
                          "film: output = \"%s\" has no file extension; the format comes from it (.exr, .png)", output);
        else if (!(cfg->output = rtk_path_join(ld->dir, output)))
            status = RTK_ERR_NOMEM;
    } else if (!(cfg->output = default_output(ld))) {
        status = RTK_ERR_NOMEM;
    }
    rtk_params_destroy(params);
    if (status != RTK_OK)
        return status;
    return read_aovs(ld, group, cfg);
}

static rtk_status read_sampler(const loader *ld, const config_setting_t *root, rtk_config *cfg)
{
    const config_setting_t *group = member(root, "sampler");
    rtk_status status = expect_group(ld, group, "type = \"independent\"; seed = 7;");
    if (status != RTK_OK)
        return status;
    rtk_params *params = NULL;
    slot_spec spec = {.label = "sampler", .schema = &sampler_schema};
    if ((status = fill_params(ld, group, &spec, &params)) != RTK_OK)
        return status;
    cfg->seed = (uint64_t)rtk_params_int(params, "seed");
    cfg->sampler_type = rtk_strdup(rtk_params_string(params, "type"));
    rtk_params_destroy(params);
    return cfg->sampler_type ? RTK_OK : RTK_ERR_NOMEM;
}

static rtk_status read_textures(const loader *ld, const config_setting_t *root, rtk_config *cfg)
{
    const config_setting_t *group = member(root, "textures");
    rtk_status status = expect_group(ld, group, "filter = \"trilinear\";");
    if (status != RTK_OK)
        return status;
    rtk_params *params = NULL;
    slot_spec spec = {.label = "textures", .schema = &textures_schema};
    if ((status = fill_params(ld, group, &spec, &params)) != RTK_OK)
        return status;
    const char *name = rtk_params_string(params, "filter");
    cfg->texture_budget = (uint64_t)rtk_params_int(params, "memory") << 20;
    if (!rtk_texture_filter_from_name(name, &cfg->texture_filter))
        status = fail(ld, member(group, "filter"), RTK_ERR_INVALID,
                      "textures: filter = \"%s\": expected nearest, bilinear or trilinear", name);
    rtk_params_destroy(params);
    return status;
}

/* cache: a directory (relative to the config), "off", or the default. */
static rtk_status read_cache(const loader *ld, const config_setting_t *root, const rtk_params *params,
                             rtk_config *cfg)
{
    const config_setting_t *at = member(root, "cache");
    const char *dir = rtk_params_string(params, "cache");
    if (!at) {
        cfg->cache_dir = rtk_bvh_cache_default_dir();
        if (!cfg->cache_dir)
            rtk_log(RTK_LOG_DEBUG, "no XDG_CACHE_HOME or HOME: the BVH cache is off");
        return RTK_OK;
    }
    if (!dir[0])
        return fail(ld, at, RTK_ERR_INVALID, "cache is empty: give a directory, or \"off\" for no BVH cache");
    if (strcmp(dir, "off") == 0)
        return RTK_OK;
    return (cfg->cache_dir = rtk_path_join(ld->dir, dir)) ? RTK_OK : RTK_ERR_NOMEM;
}

/* Top level: known settings only, scene required, threads in range. */
static rtk_status read_top(const loader *ld, const config_setting_t *root, rtk_config *cfg)
{
    rtk_params *params = NULL;
    slot_spec spec = {.schema = &top_schema, .special = top_special};
    if (!member(root, "scene")) {
        /* Unknown settings first: "scnee" deserves a suggestion, not this. */
        for (int i = 0; i < config_setting_length(root); i++) {
            const config_setting_t *s = config_setting_get_elem(root, (unsigned)i);
            if (!find_desc(&top_schema, config_setting_name(s)))
                return unknown_key(ld, s, &spec);
        }
        return rtk_error(RTK_ERR_INVALID, "%s: no 'scene' setting: add scene = \"path/to/model.obj\";", ld->path);
    }
    rtk_status status = fill_params(ld, root, &spec, &params);
    if (status != RTK_OK)
        return status;
    const char *scene = rtk_params_string(params, "scene");
    cfg->threads = (uint32_t)rtk_params_int(params, "threads");
    if (cfg->threads) {
        char origin[1100];
        where(ld, member(root, "threads"), origin, sizeof origin);
        cfg->threads = rtk_threads_limit(cfg->threads, ld->oversubscribe || rtk_params_bool(params, "oversubscribe"),
                                         origin);
    }
    cfg->cache_limit = (uint64_t)rtk_params_int(params, "cache_limit") << 20;
    if (!scene[0])
        status = fail(ld, member(root, "scene"), RTK_ERR_INVALID, "scene is empty: give the model to render");
    else if (!(cfg->scene_path = rtk_path_join(ld->dir, scene)))
        status = RTK_ERR_NOMEM;
    if (status == RTK_OK)
        status = read_cache(ld, root, params, cfg);
    rtk_params_destroy(params);
    return status;
}

/* Splits "a.b.c" into the components of an override; 0 when malformed. */
static int split_path(char *path, char **parts, int max, int *count)
{
    *count = 0;
    char *p = path;
    for (;;) {
        char *dot = strchr(p, '.');
        if (dot)
            *dot = '\0';
        if (!*p || *count == max)
            return 0;
        parts[(*count)++] = p;
        if (!dot)
            return 1;
        p = dot + 1;
    }
}

/* What an override value looks like. */
typedef enum value_kind { VALUE_INT, VALUE_FLOAT, VALUE_BOOL, VALUE_STRING } value_kind;

/* Classifies text (trimmed, quotes removed for strings, into buf). */
static value_kind classify(const char *text, size_t len, long long *i, double *f, char *buf, size_t size)
{
    while (len && (*text == ' ' || *text == '\t')) {
        text++;
        len--;
    }
    while (len && (text[len - 1] == ' ' || text[len - 1] == '\t'))
        len--;
    snprintf(buf, size, "%.*s", (int)len, text);
    if (len >= 2 && (buf[0] == '"' || buf[0] == '\'') && buf[len - 1] == buf[0]) {
        memmove(buf, buf + 1, len - 2);
        buf[len - 2] = '\0';
        return VALUE_STRING;
    }
    if (!buf[0])
        return VALUE_STRING;
    char *end;
    errno = 0;
    *i = strtoll(buf, &end, 10);
    if (!*end && errno == 0)
        return VALUE_INT;
    *f = strtod(buf, &end);
    if (!*end)
        return VALUE_FLOAT;
    if (strcmp(buf, "true") == 0 || strcmp(buf, "false") == 0) {
        *i = buf[0] == 't';
        return VALUE_BOOL;
    }
    return VALUE_STRING;
}

/* Fills an array setting from "[1, 2, 3]" or "[albedo, depth]". */
static int fill_array(config_setting_t *array, const char *inner, char *err, size_t err_size)
{
    size_t n = strlen(inner);
    int numbers = 0, strings = 0, floats = 0, wide = 0;
    for (int pass = 0; pass < 2; pass++) {
        const char *p = inner;
        while (n && *p) {
            const char *comma = strchr(p, ',');
            size_t len = comma ? (size_t)(comma - p) : strlen(p);
            long long i = 0;
            double f = 0.0;
            char buf[1024];
            if (len >= sizeof buf) {
                snprintf(err, err_size, "an array element is longer than %zu characters", sizeof buf - 1);
                return 0;
            }
            value_kind kind = classify(p, len, &i, &f, buf, sizeof buf);
            if (pass == 0) {
                if (kind == VALUE_STRING && !buf[0]) {
                    snprintf(err, err_size, "empty element in the array");
                    return 0;
                }
                numbers += kind == VALUE_INT || kind == VALUE_FLOAT;
                strings += kind == VALUE_STRING || kind == VALUE_BOOL;
                floats += kind == VALUE_FLOAT;
                wide += kind == VALUE_INT && (i < INT_MIN || i > INT_MAX);
            } else {
                config_setting_t *e;
                if (strings)
                    e = config_setting_set_string_elem(array, -1, buf);
                else if (floats)
                    e = config_setting_set_float_elem(array, -1, kind == VALUE_INT ? (double)i : f);
                else if (wide)
                    e = config_setting_set_int64_elem(array, -1, i);
                else
                    e = config_setting_set_int_elem(array, -1, (int)i);
                if (!e) {
                    snprintf(err, err_size, "cannot store element '%.200s'", buf);
                    return 0;
                }
            }
            if (!comma)
                break;
            p = comma + 1;
        }
        if (numbers && strings) {
            snprintf(err, err_size, "an array holds either numbers or strings, not both");
            return 0;
        }
    }
    return 1;
}

/* Adds name = text under parent, the type inferred from text. */
static config_setting_t *add_value(config_setting_t *parent, const char *name, const char *text, char *err,
                                   size_t err_size)
{
    size_t len = strlen(text);
    config_setting_t *s;
    if (text[0] == '[') {
        if (len < 2 || text[len - 1] != ']') {
            snprintf(err, err_size, "an array must end with ']'");
            return NULL;
        }
        char *inner = rtk_alloc(len - 1);
        if (!inner)
            return NULL;
        snprintf(inner, len - 1, "%s", text + 1);
        s = config_setting_add(parent, name, CONFIG_TYPE_ARRAY);
        if (s && !fill_array(s, inner, err, err_size)) {
            config_setting_remove(parent, name);
            s = NULL;
        }
        free(inner);
        if (!s && !err[0])
            snprintf(err, err_size, "'%s' cannot be a setting name", name);
        return s;
    }
    long long i = 0;
    double f = 0.0;
    char *buf = rtk_alloc(len + 1);
    if (!buf)
        return NULL;
    value_kind kind = classify(text, len, &i, &f, buf, len + 1);
    int type = kind == VALUE_FLOAT                     ? CONFIG_TYPE_FLOAT
               : kind == VALUE_BOOL                    ? CONFIG_TYPE_BOOL
               : kind == VALUE_STRING                  ? CONFIG_TYPE_STRING
               : (i < INT_MIN || i > INT_MAX) ? CONFIG_TYPE_INT64
                                                       : CONFIG_TYPE_INT;
    s = config_setting_add(parent, name, type);
    if (!s)
        snprintf(err, err_size, "'%s' cannot be a setting name (use letters, digits, '_' or '-')", name);
    else if (type == CONFIG_TYPE_FLOAT)
        config_setting_set_float(s, f);
    else if (type == CONFIG_TYPE_BOOL)
        config_setting_set_bool(s, (int)i);
    else if (type == CONFIG_TYPE_STRING)
        config_setting_set_string(s, buf);
    else if (type == CONFIG_TYPE_INT64)
        config_setting_set_int64(s, i);
    else
        config_setting_set_int(s, (int)i);
    free(buf);
    return s;
}

/* Applies one "path.to.key=value" entry to the parsed tree; every setting
 * it creates remembers the entry for error messages. */
static rtk_status apply_override(loader *ld, override *o)
{
    const char *entry = o->entry;
    char name[1100];
    override_name(o, name, sizeof name);
    char *eq = strchr(entry, '=');
    if (!eq)
        return rtk_error(RTK_ERR_INVALID, "%s: expected path=value, e.g. --set integrator.rays=64", name);
    size_t path_len = (size_t)(eq - entry);
    if (path_len == 0)
        return rtk_error(RTK_ERR_INVALID, "%s: the setting path before '=' is empty", name);
    char path[512];
    if (path_len >= sizeof path)
        return rtk_error(RTK_ERR_INVALID, "%.64s...: setting path is too long", name);
    memcpy(path, entry, path_len);
    path[path_len] = '\0';
    char *parts[16];
    int count;
    if (!split_path(path, parts, 16, &count))
        return rtk_error(RTK_ERR_INVALID, "%s: malformed setting path (empty part or too deep)", name);
    config_setting_t *cur = config_root_setting(&ld->cfg);
    for (int k = 0; k + 1 < count; k++) {
        config_setting_t *next = config_setting_get_member(cur, parts[k]);
        if (!next) {
            next = config_setting_add(cur, parts[k], CONFIG_TYPE_GROUP);
            if (!next)
                return rtk_error(RTK_ERR_INVALID, "%s: '%s' cannot be a setting name", name, parts[k]);
            config_setting_set_hook(next, o);
        } else if (!config_setting_is_group(next)) {
            char at[1100];
            where(ld, next, at, sizeof at);
            return rtk_error(RTK_ERR_INVALID, "%s: '%s' is not a group (it is set at %s)", name, parts[k], at);
        }
        cur = next;
    }
    const char *key = parts[count - 1];
    if (config_setting_get_member(cur, key))
        config_setting_remove(cur, key);
    char err[256] = "";
    config_setting_t *s = add_value(cur, key, eq + 1, err, sizeof err);
    if (!s)
        return err[0] ? rtk_error(RTK_ERR_INVALID, "%s: %s", name, err) : RTK_ERR_NOMEM;
    config_setting_set_hook(s, o);
    return RTK_OK;
}

/* Before libconfig 1.5 parses a config, its text is checked here, because
 * libconfig reads an integer without the L suffix into 32 bits and wraps
 * it without a word (width = 4294967297 became 1, 2147483648 became
 * -2147483648, 0xffffffff -1) and one beyond 64 bits into -1; cannot read
 * inf; leaks a string that stands where its grammar wants none ("x" = 1;);
 * ends the process on an @include of a directory; and reads an included
 * file again at every @include of it. So every integer literal outside
 * comments and strings, every bare inf, every string's place and every
 * @include is checked, in the file and those it includes. An included
 * file's text continues the including file's at the @include, so the
 * check follows the token before it into the file and the file's last
 * token out of it, and asks that a file close the strings, comments and
 * brackets it opens. Each file is read once for each place it is
 * included in (the token before it and whether that is in [ ] or ( )),
 * known by device and inode, so the check takes time linear in the
 * files' text; a cycle of includes, nesting deeper than libconfig's 10
 * levels, and a config that would expand past INCLUDE_BYTES_MAX or
 * INCLUDE_COUNT_MAX are errors. */
#define INCLUDE_DEPTH_MAX 10
#define INCLUDE_BYTES_MAX ((uint64_t)64 << 20)
#define INCLUDE_COUNT_MAX 4096u
/* Brackets open at once in one file. */
#define BRACKET_DEPTH_MAX 256

/* Where a file's text starts (or ends): the token before it, '=' for '='
 * and ':', a bracket, ',', ';', 'S' a string, 'N' a name, '#' a number,
 * '-' a sign before a name; and whether that is inside [ ] or ( ). */
typedef struct text_place {
    char prev;
    char in_sequence;
} text_place;

/* One file the check has read, in one place. */
typedef struct checked_file {
    dev_t dev;
    ino_t ino;
    text_place entry;  /* where it is included */
    char exit_prev;    /* its last token, or entry.prev when it has none */
    int done;          /* 0 while its includes are checked: meeting it again then is a cycle */
    uint64_t bytes;    /* its text with every include expanded, as libconfig reads it */
    uint64_t includes; /* @include lines met while libconfig reads it */
} checked_file;

/* State of the check of one config and its includes. */
typedef struct text_check {
    const loader *ld;
    checked_file *files;
    uint32_t count, cap;
    uint32_t include_lines; /* @include lines read */
} text_check;

static _Thread_local unsigned files_read;

unsigned rtk_config_files_read(void)
{
    return files_read;
}

/* Checks the number starting at text[*at] (a sign, then digits, letters
 * and dots), moving *at past it: an integer must fit where libconfig puts
 * it (32 bits, or 64 with L). */
static rtk_status check_number_literal(const char *text, size_t len, size_t *at, const char *shown, unsigned line)
{
    size_t b = *at, i = b;
    int sign = text[i] == '-' || text[i] == '+';
    int hex = text[i + sign] == '0' && (text[i + sign + 1] == 'x' || text[i + sign + 1] == 'X');
    for (i += (size_t)sign; i < len; i++) {
        if (isalnum((unsigned char)text[i]) || text[i] == '.')
            continue;
        /* a sign after a decimal exponent's e */
        if (!hex && (text[i] == '-' || text[i] == '+') && (text[i - 1] == 'e' || text[i - 1] == 'E'))
            continue;
        break;
    }
    *at = i;
    const size_t start = b + (size_t)sign + (hex ? 2 : 0);
    size_t digits = 0;
    while (start + digits < i &&
           (hex ? isxdigit((unsigned char)text[start + digits]) : isdigit((unsigned char)text[start + digits])))
        digits++;
    const size_t rest = i - start - digits; /* the suffix: "", "L" or "LL" for an integer */
    int wide = rest > 0 && rest <= 2 && text[start + digits] == 'L' && (rest == 1 || text[start + digits + 1] == 'L');
    if (digits == 0 || (rest > 0 && !wide))
        return RTK_OK; /* a float, or not an integer libconfig reads */
    int beyond64 = 1, beyond32 = 1;
    if (i - b < 64) {
        char tok[64];
        memcpy(tok, text + b, i - b);
        tok[i - b] = '\0';
        errno = 0;
        if (hex) {
            unsigned long long u = strtoull(tok + sign, NULL, 16);
            beyond64 = errno == ERANGE || u > (unsigned long long)LLONG_MAX;
            beyond32 = u > 0x7fffffffull;
        } else {
            long long v = strtoll(tok, NULL, 10);
            beyond64 = errno == ERANGE;
            beyond32 = v < INT_MIN || v > INT_MAX;
        }
    }
    const int shown_len = i - b < 64 ? (int)(i - b) : 64;
    const char *more = i - b < 64 ? "" : "...";
    if (beyond64)
        return rtk_error(RTK_ERR_PARSE, "%s:%u: the integer %.*s%s does not fit in 64 bits; give a smaller value",
                         shown, line, shown_len, text + b, more);
    if (beyond32 && !wide)
        return rtk_error(RTK_ERR_PARSE,
                         "%s:%u: the integer %.*s does not fit in 32 bits, and libconfig would read it wrapped; "
                         "write %.*sL for a 64-bit integer (or give a smaller value)",
                         shown, line, shown_len, text + b, shown_len, text + b);
    return RTK_OK;
}

static rtk_status check_file(text_check *tc, const char *path, const char *shown, int depth, text_place entry,
                             uint32_t *index);

/* a + b, or cap + 1 when that is more than cap. */
static uint64_t add_capped(uint64_t a, uint64_t b, uint64_t cap)
{
    return a > cap || b > cap - a ? cap + 1 : a + b;
}

/* The @include at text[*at] (a line start) of the file tc->files[self],
 * at place: the named file is checked there and its expansion added to
 * self's; *at moves past the file name and place->prev becomes the
 * included file's last token. */
static rtk_status check_include(text_check *tc, uint32_t self, const char *shown, unsigned line, int depth,
                                const char *text, size_t len, size_t *at, text_place *place)
{
    size_t q = *at + 8;
    while (q < len && (text[q] == ' ' || text[q] == '\t'))
        q++;
    size_t e = q + 1;
    while (q < len && text[q] == '"' && e < len && text[e] != '"' && text[e] != '\n')
        e++;
    if (q >= len || text[q] != '"' || e >= len || text[e] != '"')
        return rtk_error(RTK_ERR_PARSE, "%s:%u: @include needs a file name in double quotes on its line: "
                         "@include \"other.cfg\"", shown, line);
    *at = e + 1;
    const int name_len = (int)(e + 1 - q);
    if (++tc->include_lines > INCLUDE_COUNT_MAX)
        return rtk_error(RTK_ERR_PARSE, "%s:%u: more than %u @include lines in the config and the files it includes",
                         shown, line, INCLUDE_COUNT_MAX);
    if (depth >= INCLUDE_DEPTH_MAX)
        return rtk_error(RTK_ERR_PARSE, "%s:%u: @include %.*s nests includes more than %d deep, libconfig's limit",
                         shown, line, name_len, text + q, INCLUDE_DEPTH_MAX);
    /* libconfig joins every name to the include directory, absolute or not. */
    const char *dir = strcmp(tc->ld->dir, ".") == 0 ? "" : tc->ld->dir;
    if (text[q + 1] == '/')
        return rtk_error(RTK_ERR_PARSE, "%s:%u: @include %.*s: an absolute path, which libconfig would read under "
                         "%s; name the file relative to that folder", shown, line, name_len, text + q,
                         dir[0] ? dir : "the current folder");
    size_t size = strlen(dir) + (e - q) + 2;
    char *inc = rtk_alloc(size);
    if (!inc)
        return RTK_ERR_NOMEM;
    snprintf(inc, size, "%s%s%.*s", dir, dir[0] ? "/" : "", (int)(e - q - 1), text + q + 1);
    struct stat st;
    rtk_status status = RTK_OK;
    uint32_t child = UINT32_MAX;
    if (stat(inc, &st) != 0)
        status = rtk_error(RTK_ERR_IO, "%s:%u: @include %.*s: cannot read %s: %s", shown, line, name_len, text + q,
                           inc, strerror(errno));
    else if (!S_ISREG(st.st_mode))
        status = rtk_error(RTK_ERR_IO, "%s:%u: @include %.*s: %s is %s, not a config file", shown, line, name_len,
                           text + q, inc, S_ISDIR(st.st_mode) ? "a directory" : "not a regular file");
    else
        status = check_file(tc, inc, inc, depth + 1, *place, &child);
    if (status == RTK_OK && child == UINT32_MAX)
        status = rtk_error(RTK_ERR_PARSE, "%s:%u: @include %.*s includes itself, directly or through the files it "
                           "includes", shown, line, name_len, text + q);
    if (status == RTK_OK) {
        checked_file *me = &tc->files[self];
        const checked_file *it = &tc->files[child];
        place->prev = it->exit_prev;
        me->bytes = add_capped(me->bytes, it->bytes, INCLUDE_BYTES_MAX);
        me->includes = add_capped(me->includes, it->includes + 1, INCLUDE_COUNT_MAX);
        if (me->bytes > INCLUDE_BYTES_MAX || me->includes > INCLUDE_COUNT_MAX)
            status = rtk_error(RTK_ERR_PARSE,
                               "%s:%u: @include %.*s makes %s more than %llu MiB or %u includes once expanded "
                               "(libconfig reads a file again at each @include of it): include each file once",
                               shown, line, name_len, text + q, shown, (unsigned long long)(INCLUDE_BYTES_MAX >> 20),
                               INCLUDE_COUNT_MAX);
    }
    free(inc);
    return status;
}

/* Checks the text of the file tc->files[self], included depth deep; see
 * the comment above INCLUDE_DEPTH_MAX. */
static rtk_status check_text(text_check *tc, uint32_t self, const char *shown, int depth, const char *text,
                             size_t len)
{
    static const char *const bracket_names[] = {"group { }", "array [ ]", "list ( )"};
    char open[BRACKET_DEPTH_MAX]; /* brackets opened and not closed: '{', '[' or '(' */
    unsigned open_line = 0;       /* of open[0] */
    int level = 0;
    text_place place = tc->files[self].entry;
    const char *key = NULL; /* the last name before a value, for the inf message */
    int key_len = 0;
    unsigned line = 1;
    int line_start = 1;
    for (size_t i = 0; i < len;) {
        char c = text[i];
        if (c == '\n') {
            line++, line_start = 1, i++;
            continue;
        }
        if (c == '#' || (c == '/' && text[i + 1] == '/')) {
            while (i < len && text[i] != '\n')
                i++;
            continue;
        }
        if (c == ' ' || c == '\t' || c == '\r') {
            i++;
            continue;
        }
        if (c == '/' && text[i + 1] == '*') {
            unsigned start = line;
            for (i += 2; i < len && !(text[i] == '*' && text[i + 1] == '/'); i++)
                line += text[i] == '\n';
            if (i >= len)
                return rtk_error(RTK_ERR_PARSE, "%s:%u: the comment /* opened here is not closed in this file",
                                 shown, start);
            i += 2;
            continue;
        }
        if (c == '@' && line_start && strncmp(text + i, "@include", 8) == 0) {
            text_place here = {.prev = place.prev, .in_sequence = level > 0 ? open[level - 1] != '{' : place.in_sequence};
            rtk_status status = check_include(tc, self, shown, line, depth, text, len, &i, &here);
            if (status != RTK_OK)
                return status;
            place.prev = here.prev;
            continue;
        }
        line_start = 0;
        /* Where libconfig takes a value: after '=' or ':', or in [ ] or ( ) after the bracket or a comma. */
        int in_sequence = level > 0 ? open[level - 1] != '{' : place.in_sequence;
        char prev = place.prev;
        int value_place = prev == '=' || (in_sequence && (prev == '[' || prev == '(' || prev == ','));
        if (c == '"') {
            size_t b = i;
            unsigned start = line;
            for (i++; i < len && text[i] != '"'; i++) {
                if (text[i] == '\\' && i + 1 < len)
                    i++;
                line += text[i] == '\n';
            }
            if (i >= len)
                return rtk_error(RTK_ERR_PARSE, "%s:%u: the string opened here is not closed in this file", shown,
                                 start);
            i++;
            if (!value_place && prev != 'S')
                return rtk_error(RTK_ERR_PARSE,
                                 "%s:%u: syntax error at the string %.*s%s: a string is a value, after '=' or ':' "
                                 "(name = \"text\";) or in [ ] or ( ) after a comma",
                                 shown, start, i - b < 40 ? (int)(i - b) : 40, text + b, i - b < 40 ? "" : "...");
            place.prev = 'S';
            continue;
        }
        if (isalpha((unsigned char)c) || c == '*' || c == '_') { /* a name, digits and all */
            size_t b = i;
            while (i < len && (isalnum((unsigned char)text[i]) || (text[i] && strchr("-_*", text[i]))))
                i++;
            char word[16] = "";
            if (i - b < sizeof word)
                memcpy(word, text + b, i - b);
            if ((value_place || prev == '-') && is_inf_text(word))
                return rtk_error(RTK_ERR_PARSE,
                                 "%s:%u: libconfig cannot read %s%s as a number; write it as a string, "
                                 "%.*s = \"%s%s\"; (rtk reads \"inf\" and \"infinity\" where a number is expected)",
                                 shown, line, prev == '-' ? "-" : "", word, key ? key_len : 4, key ? key : "name",
                                 prev == '-' ? "-" : "", word);
            if (!value_place) {
                key = text + b;
                key_len = (int)(i - b);
            }
            place.prev = 'N';
            continue;
        }
        int sign = c == '-' || c == '+';
        /* 7, -7, 1.5, .5, -.5 */
        size_t digit = i + (size_t)sign + (i + (size_t)sign < len && text[i + (size_t)sign] == '.');
        if (digit < len && isdigit((unsigned char)text[digit]) && (digit == i || sign || c == '.')) {
            rtk_status status = check_number_literal(text, len, &i, shown, line);
            if (status != RTK_OK)
                return status;
            place.prev = '#';
            continue;
        }
        i++;
        if (c == '{' || c == '[' || c == '(') {
            if (level == BRACKET_DEPTH_MAX)
                return rtk_error(RTK_ERR_PARSE, "%s:%u: more than %d groups, arrays and lists inside each other",
                                 shown, line, BRACKET_DEPTH_MAX);
            if (level == 0)
                open_line = line;
            open[level++] = c;
            place.prev = c;
        } else if (c == '}' || c == ']' || c == ')') {
            if (level == 0)
                return rtk_error(RTK_ERR_PARSE, "%s:%u: '%c' closes a bracket this file did not open%s", shown, line, c,
                                 depth ? " (an included file holds whole settings, groups, arrays and lists)" : "");
            level--;
            place.prev = c;
        } else if (c == '=' || c == ':') {
            place.prev = '=';
        } else if (c == ',' || c == ';') {
            place.prev = c;
        } else if (sign && value_place) {
            place.prev = '-'; /* a sign before a name: -inf */
        } else {
            /* libconfig would stop here too, but leak a string it scanned past this point. */
            char what[16];
            if (isgraph((unsigned char)c))
                snprintf(what, sizeof what, "'%c'", c);
            else
                snprintf(what, sizeof what, "byte 0x%02x", (unsigned char)c);
            return rtk_error(RTK_ERR_PARSE, "%s:%u: syntax error at %s: a config holds names, numbers, \"strings\", "
                             "= : ; , { } [ ] ( ) and comments", shown, line, what);
        }
    }
    if (level > 0) {
        int kind = open[0] == '{' ? 0 : open[0] == '[' ? 1 : 2;
        return rtk_error(RTK_ERR_PARSE, "%s:%u: the %s opened here is not closed in this file", shown, open_line,
                         bracket_names[kind]);
    }
    tc->files[self].exit_prev = place.prev;
    return RTK_OK;
}

/* Checks the file at path (shown as shown) included at entry, unless it
 * was checked there before; *index is its entry in tc->files, or
 * UINT32_MAX when it is being checked already (a cycle). */
static rtk_status check_file(text_check *tc, const char *path, const char *shown, int depth, text_place entry,
                             uint32_t *index)
{
    struct stat st;
    if (stat(path, &st) != 0)
        return rtk_error(RTK_ERR_IO, "%s: cannot read config: %s", shown, strerror(errno));
    *index = UINT32_MAX;
    for (uint32_t k = 0; k < tc->count; k++) {
        const checked_file *f = &tc->files[k];
        if (f->dev != st.st_dev || f->ino != st.st_ino)
            continue;
        if (!f->done)
            return RTK_OK;
        if (f->entry.prev == entry.prev && f->entry.in_sequence == entry.in_sequence) {
            *index = k;
            return RTK_OK;
        }
    }
    if (!rtk_grow_array((void **)&tc->files, &tc->cap, tc->count, sizeof *tc->files))
        return RTK_ERR_NOMEM;
    uint32_t self = tc->count++;
    tc->files[self] = (checked_file){.dev = st.st_dev, .ino = st.st_ino, .entry = entry, .exit_prev = entry.prev};
    unsigned char *bytes = NULL;
    size_t len = 0;
    rtk_status status = rtk_file_read(path, "config file", INCLUDE_BYTES_MAX, &bytes, &len);
    char *text = (char *)bytes;
    if (status != RTK_OK)
        return status;
    files_read++;
    tc->files[self].bytes = len;
    status = check_text(tc, self, shown, depth, text, len);
    free(text);
    tc->files[self].done = 1;
    *index = self;
    return status;
}

/* Checks the config's text and every file it includes; a config that is
 * not a regular file (rtk render <(...)) is left to libconfig, since what
 * is read here would not reach it. */
static rtk_status check_config_text(const loader *ld)
{
    struct stat st;
    files_read = 0;
    if (stat(ld->path, &st) != 0 || !S_ISREG(st.st_mode))
        return RTK_OK;
    text_check tc = {.ld = ld};
    uint32_t root;
    rtk_status status = check_file(&tc, ld->path, ld->path, 0, (text_place){.prev = ';'}, &root);
    free(tc.files);
    return status;
}

/* Parses the file into ld->cfg with an error naming the file and line. */
static rtk_status parse_file(loader *ld)
{
    struct stat st;
    if (stat(ld->path, &st) != 0)
        return rtk_error(RTK_ERR_IO, "%s: cannot read config: %s", ld->path, strerror(errno));
    if (S_ISDIR(st.st_mode))
        return rtk_error(RTK_ERR_IO, "%s: is a directory, not a config file", ld->path);
    rtk_status checked = check_config_text(ld);
    if (checked != RTK_OK)
        return checked;
    config_set_include_dir(&ld->cfg, ld->dir);
    if (config_read_file(&ld->cfg, ld->path))
        return RTK_OK;
    char *file = included_file(ld, config_error_file(&ld->cfg));
    const char *shown = file ? file : ld->path;
    const char *text = config_error_text(&ld->cfg) ? config_error_text(&ld->cfg) : "unreadable";
    rtk_status status;
    if (config_error_type(&ld->cfg) == CONFIG_ERR_FILE_IO)
        status = rtk_error(RTK_ERR_IO, "%s: cannot read config: %s", shown, text);
    else if (strstr(text, "mismatched element type"))
        status = rtk_error(RTK_ERR_PARSE,
                           "%s:%d: %s: an array [ ... ] holds one type, so write 1.0 rather than 1 "
                           "among floats (or use a list ( ... ))",
                           shown, config_error_line(&ld->cfg), text);
    else
        status = rtk_error(RTK_ERR_PARSE, "%s:%d: %s", shown, config_error_line(&ld->cfg), text);
    free(file);
    return status;
}

static rtk_status read_accelerator(const loader *ld, const config_setting_t *root, rtk_config *cfg)
{
    rtk_status st = load_slot(ld, root, "accelerator", RTK_KIND_ACCELERATOR, "sah", &cfg->accelerator);
    if (st != RTK_OK || !rtk_accelerator_is_device(cfg->accelerator.plugin))
        return st;
    /* A device accelerator's builder, checked here so that a wrong one is
     * reported at its line; the kernel finds it again when it builds. */
    const char *name = rtk_params_string(cfg->accelerator.params, "builder");
    const config_setting_t *group = member(root, "accelerator");
    const config_setting_t *at = group && config_setting_is_group(group) ? member(group, "builder") : NULL;
    const rtk_plugin *builder = NULL;
    if ((st = rtk_registry_find(ld->registry, RTK_KIND_ACCELERATOR, name, &builder)) != RTK_OK) {
        char msg[2048];
        snprintf(msg, sizeof msg, "%s", rtk_error_message());
        return fail(ld, at ? at : group, st, "accelerator: builder: %s", msg);
    }
    const char *unfit = rtk_builder_unfit(builder);
    if (unfit)
        return fail(ld, at ? at : group, RTK_ERR_INVALID, "accelerator: builder = \"%s\" names an accelerator that "
                    "%s; name one that builds the kernel's tree (median, sah or lbvh)", name, unfit);
    return RTK_OK;
}

static rtk_status read_integrator(const loader *ld, const config_setting_t *root, rtk_config *cfg)
{
    return load_slot(ld, root, "integrator", RTK_KIND_INTEGRATOR, "headlight", &cfg->integrator);
}

static rtk_status read_filter(const loader *ld, const config_setting_t *root, rtk_config *cfg)
{
    return load_slot(ld, root, "filter", RTK_KIND_FILTER, "box", &cfg->filter);
}

/* Parses, applies every override, then runs every reader, recording each
 * one's error and going on, so that all are reported at once; only the
 * plugin slots wait for plugin_path, which may hold their plugins. */
static rtk_status load(loader *ld, rtk_config *cfg)
{
    rtk_status status = parse_file(ld);
    if (status != RTK_OK)
        return status;
    for (size_t i = 0; i < ld->override_count; i++) {
        if ((status = apply_override(ld, &ld->overrides[i])) == RTK_ERR_NOMEM)
            return status;
        if (status != RTK_OK)
            note_error(ld, status);
    }
    typedef rtk_status (*reader_fn)(const loader *ld, const config_setting_t *root, rtk_config *cfg);
    static const reader_fn readers[] = {read_top,      read_plugin_path, read_camera,      read_film,
                                        read_sampler,  read_lights,      read_environment, read_instances,
                                        read_textures,
                                        read_accelerator, read_integrator, read_filter};
    const config_setting_t *root = config_root_setting(&ld->cfg);
    for (size_t i = 0; i < RTK_COUNTOF(readers); i++) {
        unsigned before = ld->errors->count;
        status = readers[i](ld, root, cfg);
        if (status == RTK_ERR_NOMEM)
            return status;
        if (status != RTK_OK && ld->errors->count == before)
            note_error(ld, status);
        if (status != RTK_OK && readers[i] == read_plugin_path)
            break;
    }
    return report_errors(ld->errors);
}

RTK_API rtk_status rtk_config_load(const char *path, rtk_registry *registry, const rtk_config_options *options,
                                   rtk_config **out)
{
    if (!out)
        return rtk_error(RTK_ERR_INVALID, "rtk_config_load: out is NULL");
    *out = NULL;
    if (!path || !path[0])
        return rtk_error(RTK_ERR_INVALID, "no config file given");
    if (!registry)
        return rtk_error(RTK_ERR_INVALID, "%s: no plugin registry to resolve plugins with", path);
    /* Fields past the caller's size keep their defaults; size 0 means a
     * caller built against this header that left it unset. */
    size_t size = options ? (options->size ? options->size : sizeof *options) : 0;
    error_list errors = {.count = 0};
    loader ld = {.path = path, .registry = registry, .errors = &errors};
    if (size >= offsetof(rtk_config_options, allow_config_plugins) + sizeof options->allow_config_plugins)
        ld.trusted = options->allow_config_plugins != 0;
    if (size >= offsetof(rtk_config_options, oversubscribe) + sizeof options->oversubscribe)
        ld.oversubscribe = options->oversubscribe != 0;
    int allow_outside_files = 0;
    if (size >= offsetof(rtk_config_options, allow_outside_files) + sizeof options->allow_outside_files)
        allow_outside_files = options->allow_outside_files != 0;
    size_t override_count = 0;
    if (size >= offsetof(rtk_config_options, override_count) + sizeof options->override_count && options->overrides)
        override_count = options->override_count;
    rtk_config *cfg = rtk_calloc(1, sizeof *cfg);
    ld.dir = rtk_path_dirname(path);
    ld.overrides = rtk_calloc(override_count, sizeof *ld.overrides);
    config_init(&ld.cfg);
    rtk_status status = cfg && ld.dir && ld.overrides ? RTK_OK : RTK_ERR_NOMEM;
    const char *const *labels = NULL;
    if (size >= offsetof(rtk_config_options, override_labels) + sizeof options->override_labels)
        labels = options->override_labels;
    for (size_t i = 0; status == RTK_OK && i < override_count; i++) {
        const char *entry = options->overrides[i] ? options->overrides[i] : "";
        if (!(ld.overrides[i].entry = rtk_strdup(entry)))
            status = RTK_ERR_NOMEM;
        if (labels && labels[i] && !(ld.overrides[i].label = rtk_strdup(labels[i])))
            status = RTK_ERR_NOMEM;
        ld.override_count = i + 1;
    }
    if (status == RTK_OK && !(cfg->path = rtk_strdup(path)))
        status = RTK_ERR_NOMEM;
    if (status == RTK_OK)
        cfg->allow_outside_files = allow_outside_files;
    if (status == RTK_OK)
        status = load(&ld, cfg);
    config_destroy(&ld.cfg);
    for (size_t i = 0; i < ld.override_count; i++) {
        free(ld.overrides[i].entry);
        free(ld.overrides[i].label);
    }
    free(ld.overrides);
    free(ld.dir);
    if (status != RTK_OK) {
        rtk_config_destroy(cfg);
        return status;
    }
    *out = cfg;
    return RTK_OK;
}

RTK_API uint32_t rtk_threads_limit(uint32_t wanted, int oversubscribe, const char *origin)
{
    uint32_t cores = rtk_core_count();
    if (wanted <= cores || oversubscribe)
        return wanted;
    char key[1200];
    snprintf(key, sizeof key, "threads:%s:%u", origin ? origin : "", wanted);
    rtk_warn_once(key,
                  "%s: %u threads on the %u core%s this process may use would only take turns; using %u "
                  "(--oversubscribe, or oversubscribe = true; in the config, runs all %u)",
                  origin ? origin : "threads", wanted, cores, cores == 1 ? "" : "s", cores, wanted);
    return cores;
}

RTK_API void rtk_config_destroy(rtk_config *config)
{
    if (!config)
        return;
    free(config->path);
    free(config->scene_path);
    free(config->output);
    free(config->sampler_type);
    free(config->cache_dir);
    free(config->lights);
    free(config->environment.file);
    for (uint32_t i = 0; i < config->instance_count; i++)
        free(config->instances[i].file);
    free(config->instances);
    rtk_params_destroy(config->integrator.params);
    rtk_params_destroy(config->accelerator.params);
    rtk_params_destroy(config->filter.params);
    free(config);
}

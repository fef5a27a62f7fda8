/* Parameter values of one plugin instance: defaults from the schema, text
 * values checked against it, and the typed getters plugins call.
 * The kernel validates every value here before a plugin sees it, so the
 * getters only fail when a plugin reads a name its own schema lacks. */
#include "core.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

/* 2^63: the first double past the int64 range. */
#define INT64_LIMIT 9223372036854775808.0

static const char *plugin_name(const rtk_plugin *plugin)
{
    return plugin && plugin->name ? plugin->name : "(unnamed plugin)";
}

/* "an integer", "a number", ... for messages. */
static const char *type_text(rtk_param_type type)
{
    switch (type) {
    case RTK_PARAM_INT: return "an integer";
    case RTK_PARAM_FLOAT: return "a number";
    case RTK_PARAM_BOOL: return "a boolean (true or false)";
    case RTK_PARAM_STRING: return "a string";
    }
    return "a value of an unknown type";
}

RTK_API const char *rtk_param_type_name(rtk_param_type type)
{
    switch (type) {
    case RTK_PARAM_INT: return "int";
    case RTK_PARAM_FLOAT: return "float";
    case RTK_PARAM_BOOL: return "bool";
    case RTK_PARAM_STRING: return "string";
    }
    return "unknown";
}

static rtk_param_value *find_value(const rtk_params *params, const char *name)
{
    for (uint32_t i = 0; i < params->count; i++) {
        if (strcmp(params->values[i].desc->name, name) == 0)
            return &params->values[i];
    }
    return NULL;
}

/* The value a getter of the given type may return, or NULL after warning. */
static const rtk_param_value *getter_value(const rtk_params *params, const char *name, rtk_param_type type)
{
    char key[256];
    if (!params || !name) {
        rtk_warn_once("params:null", "a plugin read parameter '%s' without a params object",
                      name ? name : "(null)");
        return NULL;
    }
    const char *plugin = plugin_name(params->plugin);
    const rtk_param_value *value = find_value(params, name);
    if (!value) {
        snprintf(key, sizeof key, "params:%s:%s:undeclared", plugin, name);
        rtk_warn_once(key, "plugin '%s' read parameter '%s', which its schema does not declare",
                      plugin, name);
        return NULL;
    }
    if (value->desc->type != type) {
        snprintf(key, sizeof key, "params:%s:%s:type%d", plugin, name, (int)type);
        rtk_warn_once(key, "plugin '%s' read parameter '%s' (%s) as %s", plugin, name,
                      type_text(value->desc->type), type_text(type));
        return NULL;
    }
    return value;
}

RTK_API int64_t rtk_params_int(const rtk_params *params, const char *name)
{
    const rtk_param_value *value = getter_value(params, name, RTK_PARAM_INT);
    return value ? value->i : 0;
}

RTK_API double rtk_params_float(const rtk_params *params, const char *name)
{
    const rtk_param_value *value = getter_value(params, name, RTK_PARAM_FLOAT);
    return value ? value->f : 0.0;
}

RTK_API int rtk_params_bool(const rtk_params *params, const char *name)
{
    const rtk_param_value *value = getter_value(params, name, RTK_PARAM_BOOL);
    return value ? (int)value->i : 0;
}

RTK_API const char *rtk_params_string(const rtk_params *params, const char *name)
{
    const rtk_param_value *value = getter_value(params, name, RTK_PARAM_STRING);
    return value && value->s ? value->s : "";
}

rtk_params *rtk_params_defaults(const rtk_plugin *plugin)
{
    if (!plugin) {
        rtk_error(RTK_ERR_INVALID, "no plugin to take parameter defaults from");
        return NULL;
    }
    rtk_params *params = rtk_calloc(1, sizeof *params);
    if (!params)
        return NULL;
    params->plugin = plugin;
    params->count = plugin->params ? plugin->param_count : 0;
    params->values = rtk_calloc(params->count, sizeof *params->values);
    if (!params->values) {
        free(params);
        return NULL;
    }
    for (uint32_t i = 0; i < params->count; i++) {
        rtk_param_value *value = &params->values[i];
        const rtk_param_desc *desc = &plugin->params[i];
        value->desc = desc;
        switch (desc->type) {
        case RTK_PARAM_INT:
            if (desc->def >= -INT64_LIMIT && desc->def < INT64_LIMIT)
                value->i = (int64_t)desc->def;
            break;
        case RTK_PARAM_FLOAT:
            value->f = desc->def;
            break;
        case RTK_PARAM_BOOL:
            value->i = desc->def != 0.0;
            break;
        case RTK_PARAM_STRING:
            value->s = rtk_strdup(desc->def_string ? desc->def_string : "");
            if (!value->s) {
                rtk_params_destroy(params);
                return NULL;
            }
            break;
        }
    }
    return params;
}

void rtk_params_destroy(rtk_params *params)
{
    if (!params)
        return;
    for (uint32_t i = 0; i < params->count; i++)
        free(params->values[i].s);
    free(params->values);
    free(params);
}

/* Parses a whole base-10 integer; 0 ok, -1 not an integer, -2 outside int64. */
static int parse_int(const char *text, int64_t *out)
{
    char *end;
    errno = 0;
    long long v = strtoll(text, &end, 10);
    if (end == text)
        return -1;
    while (*end == ' ' || *end == '\t')
        end++;
    if (*end)
        return -1;
    if (errno == ERANGE)
        return -2;
    *out = v;
    return 0;
}

/* Parses a whole number ("0.5", "1e-3", "16", "inf"); 0 ok, -1 not a
 * number (or NaN), -2 overflows a double. */
static int parse_float(const char *text, double *out)
{
    char *end;
    errno = 0;
    double v = strtod(text, &end);
    if (end == text)
        return -1;
    while (*end == ' ' || *end == '\t')
        end++;
    if (*end || isnan(v))
        return -1;
    if (errno == ERANGE && isinf(v))
        return -2;
    *out = v;
    return 0;
}

/* 1 / 0 for the usual spellings of a boolean, -1 for anything else. */
static int parse_bool(const char *text)
{
    static const char *const yes[] = {"true", "yes", "on", "1"};
    static const char *const no[] = {"false", "no", "off", "0"};
    for (size_t i = 0; i < sizeof yes / sizeof yes[0]; i++) {
        if (strcasecmp(text, yes[i]) == 0)
            return 1;
        if (strcasecmp(text, no[i]) == 0)
            return 0;
    }
    return -1;
}

/* 1 if s is one of the '|'-separated choices. */
static int choice_allowed(const char *choices, const char *s)
{
    size_t n = strlen(s);
    const char *p = choices;
    for (;;) {
        const char *bar = strchr(p, '|');
        size_t len = bar ? (size_t)(bar - p) : strlen(p);
        if (len == n && strncmp(p, s, n) == 0)
            return 1;
        if (!bar)
            return 0;
        p = bar + 1;
    }
}

/* Edit distance from word to candidate when candidate passes for a typo of
 * word (at most a third of word's length, at least 2, and something in
 * common), else INT_MAX. */
static int typo_distance(const char *word, const char *candidate)
{
    size_t len = strlen(word), other = strlen(candidate);
    int limit = (int)(len / 3) > 2 ? (int)(len / 3) : 2;
    int d = rtk_edit_distance(word, candidate);
    /* A distance equal to the longer length means nothing in common. */
    if (d > limit || (size_t)d >= (len > other ? len : other))
        return INT_MAX;
    return d;
}

/* Writes the choices as "a, b, c" into buf, and the closest one to s
 * (or "" when none is close) into near. */
static void describe_choices(const char *choices, const char *s, char *buf, size_t size,
                             char *near, size_t near_size)
{
    size_t used = 0;
    int best = INT_MAX;
    near[0] = '\0';
    buf[0] = '\0';
    const char *p = choices;
    for (;;) {
        const char *bar = strchr(p, '|');
        size_t len = bar ? (size_t)(bar - p) : strlen(p);
        char one[128];
        snprintf(one, sizeof one, "%.*s", (int)len, p);
        if (used < size)
            used += (size_t)snprintf(buf + used, size - used, "%s%s", used ? ", " : "", one);
        int d = typo_distance(s, one);
        if (d < best) {
            best = d;
            snprintf(near, near_size, "%s", one);
        }
        if (!bar)
            break;
        p = bar + 1;
    }
}

/* One bound of an integer range; 2^63 and beyond (an open side) stand
 * for INT64_MAX, which a double cannot hold exactly, -2^63 and below for
 * INT64_MIN. */
static void describe_int_bound(double v, char *buf, size_t size)
{
    if (v >= INT64_LIMIT)
        snprintf(buf, size, "%lld", (long long)INT64_MAX);
    else if (v <= -INT64_LIMIT)
        snprintf(buf, size, "%lld", (long long)INT64_MIN);
    else
        snprintf(buf, size, "%.0f", v);
}

/* "[1, 4096]" for an integer range, "[0.001, 16]" for a float one. */
static void describe_range(const rtk_param_desc *desc, char *buf, size_t size)
{
    if (desc->type == RTK_PARAM_INT) {
        char lo[32], hi[32];
        describe_int_bound(desc->min, lo, sizeof lo);
        describe_int_bound(desc->max, hi, sizeof hi);
        snprintf(buf, size, "[%s, %s]", lo, hi);
    } else {
        snprintf(buf, size, "[%g, %g]", desc->min, desc->max);
    }
}

/* Appends the declared names of params to buf as "a, b, c". */
static void list_names(const rtk_params *params, char *buf, size_t size)
{
    size_t used = 0;
    buf[0] = '\0';
    for (uint32_t i = 0; i < params->count && used < size; i++)
        used += (size_t)snprintf(buf + used, size - used, "%s%s", i ? ", " : "",
                                 params->values[i].desc->name);
    if (params->count == 0)
        snprintf(buf, size, "(none)");
}

rtk_status rtk_params_set_text(rtk_params *params, const char *name, const char *text)
{
    if (!params || !name || !text)
        return rtk_error(RTK_ERR_INVALID, "rtk_params_set_text: missing argument");
    rtk_param_value *value = find_value(params, name);
    if (!value) {
        char keys[1024];
        list_names(params, keys, sizeof keys);
        const rtk_param_desc *schema = params->plugin ? params->plugin->params : NULL;
        const char *near = schema ? rtk_params_suggest(schema, params->count, name) : NULL;
        if (near)
            return rtk_error(RTK_ERR_INVALID, "unknown key '%s' (did you mean '%s'?); keys of %s: %s",
                             name, near, plugin_name(params->plugin), keys);
        return rtk_error(RTK_ERR_INVALID, "unknown key '%s'; keys of %s: %s", name,
                         plugin_name(params->plugin), keys);
    }
    const rtk_param_desc *desc = value->desc;
    int bounded = rtk_param_has_range(desc);
    char range[128];
    describe_range(desc, range, sizeof range);
    while (*text == ' ' || *text == '\t')
        text++;
    switch (desc->type) {
    case RTK_PARAM_INT: {
        int64_t v = 0;
        int r = parse_int(text, &v);
        if (r == -2)
            return rtk_error(RTK_ERR_INVALID, "%s = %s is outside the 64-bit integer range", name, text);
        if (r != 0)
            return rtk_error(RTK_ERR_INVALID, "%s: expected an integer, found '%s'", name, text);
        if (bounded && ((double)v < desc->min || (double)v > desc->max))
            return rtk_error(RTK_ERR_INVALID, "%s = %lld is out of range %s", name, (long long)v, range);
        value->i = v;
        break;
    }
    case RTK_PARAM_FLOAT: {
        double v = 0.0;
        int r = parse_float(text, &v);
        if (r == -2)
            return rtk_error(RTK_ERR_INVALID, "%s = %s is too large for a double", name, text);
        if (r != 0)
            return rtk_error(RTK_ERR_INVALID, "%s: expected a number (e.g. 0.5, 1e-3, inf), found '%s'",
                             name, text);
        if (bounded && (v < desc->min || v > desc->max))
            return rtk_error(RTK_ERR_INVALID, "%s = %g is out of range %s", name, v, range);
        value->f = v;
        break;
    }
    case RTK_PARAM_BOOL: {
        int v = parse_bool(text);
        if (v < 0)
            return rtk_error(RTK_ERR_INVALID, "%s: expected a boolean (true or false), found '%s'", name, text);
        value->i = v;
        break;
    }
    case RTK_PARAM_STRING: {
        if (desc->choices && !choice_allowed(desc->choices, text)) {
            char list[1024], near[128];
            describe_choices(desc->choices, text, list, sizeof list, near, sizeof near);
            if (near[0])
                return rtk_error(RTK_ERR_INVALID, "%s = '%s' is not one of: %s (did you mean '%s'?)", name,
                                 text, list, near);
            return rtk_error(RTK_ERR_INVALID, "%s = '%s' is not one of: %s", name, text, list);
        }
        char *copy = rtk_strdup(text);
        if (!copy)
            return RTK_ERR_NOMEM;
        free(value->s);
        value->s = copy;
        break;
    }
    default:
        return rtk_error(RTK_ERR_INVALID, "%s: parameter of unknown type %d", name, (int)desc->type);
    }
    value->set_by_user = 1;
    return RTK_OK;
}

/* 1 if name can be written as a config key: a letter, then letters,
 * digits, '_' or '-'. */
static int valid_key(const char *name)
{
    if (!((name[0] >= 'a' && name[0] <= 'z') || (name[0] >= 'A' && name[0] <= 'Z')))
        return 0;
    for (const char *p = name + 1; *p; p++) {
        int ok = (*p >= 'a' && *p <= 'z') || (*p >= 'A' && *p <= 'Z') || (*p >= '0' && *p <= '9') ||
                 *p == '_' || *p == '-';
        if (!ok)
            return 0;
    }
    return 1;
}

/* Checks one numeric entry: a sane range and a default inside it. */
static rtk_status check_number(const char *plugin, const rtk_param_desc *desc)
{
    char range[128];
    describe_range(desc, range, sizeof range);
    if (isnan(desc->min) || isnan(desc->max) || desc->min > desc->max)
        return rtk_error(RTK_ERR_PLUGIN, "plugin '%s': parameter '%s' has range %s with min > max", plugin,
                         desc->name, range);
    int bounded = rtk_param_has_range(desc);
    /* An integer bound is a whole number within int64, or infinite (open). */
    int int_bounds_ok = 1;
    for (int k = 0; k < 2; k++) {
        double v = k ? desc->max : desc->min;
        if (!isinf(v) && (v != floor(v) || v < -INT64_LIMIT || v > INT64_LIMIT))
            int_bounds_ok = 0;
    }
    if (desc->type == RTK_PARAM_INT && bounded && !int_bounds_ok)
        return rtk_error(RTK_ERR_PLUGIN, "plugin '%s': integer parameter '%s' has range %s, not 64-bit integers",
                         plugin, desc->name, range);
    if (desc->required)
        return RTK_OK;
    if (isnan(desc->def))
        return rtk_error(RTK_ERR_PLUGIN, "plugin '%s': parameter '%s' has a NaN default", plugin, desc->name);
    if (desc->type == RTK_PARAM_INT &&
        (desc->def != floor(desc->def) || desc->def < -INT64_LIMIT || desc->def >= INT64_LIMIT))
        return rtk_error(RTK_ERR_PLUGIN, "plugin '%s': integer parameter '%s' has default %g, not a 64-bit integer",
                         plugin, desc->name, desc->def);
    if (bounded && (desc->def < desc->min || desc->def > desc->max))
        return rtk_error(RTK_ERR_PLUGIN, "plugin '%s': parameter '%s' has default %g outside its range %s", plugin,
                         desc->name, desc->def, range);
    return RTK_OK;
}

/* Checks one string entry: well-formed choices holding the default. */
static rtk_status check_string(const char *plugin, const rtk_param_desc *desc)
{
    const char *choices = desc->choices;
    if (!choices)
        return RTK_OK;
    if (!choices[0] || choices[0] == '|' || choices[strlen(choices) - 1] == '|' || strstr(choices, "||"))
        return rtk_error(RTK_ERR_PLUGIN, "plugin '%s': parameter '%s' has an empty choice in \"%s\"", plugin,
                         desc->name, choices);
    const char *def = desc->def_string ? desc->def_string : "";
    if (!desc->required && !choice_allowed(choices, def))
        return rtk_error(RTK_ERR_PLUGIN, "plugin '%s': parameter '%s' has default \"%s\", not one of \"%s\"",
                         plugin, desc->name, def, choices);
    return RTK_OK;
}

rtk_status rtk_params_check_schema(const rtk_plugin *plugin)
{
    if (!plugin)
        return rtk_error(RTK_ERR_PLUGIN, "no plugin descriptor to check");
    const char *name = plugin_name(plugin);
    if (plugin->param_count && !plugin->params)
        return rtk_error(RTK_ERR_PLUGIN, "plugin '%s': param_count is %u but params is NULL", name,
                         plugin->param_count);
    for (uint32_t i = 0; i < plugin->param_count; i++) {
        const rtk_param_desc *desc = &plugin->params[i];
        if (!desc->name || !desc->name[0])
            return rtk_error(RTK_ERR_PLUGIN, "plugin '%s': parameter %u has no name", name, i);
        if (!valid_key(desc->name))
            return rtk_error(RTK_ERR_PLUGIN,
                             "plugin '%s': parameter name '%s' cannot be written in a config "
                             "(use a letter, then letters, digits, '_' or '-')",
                             name, desc->name);
        if (strcmp(desc->name, "plugin") == 0)
            return rtk_error(RTK_ERR_PLUGIN,
                             "plugin '%s': parameter name 'plugin' is reserved (it selects the plugin)", name);
        for (uint32_t j = 0; j < i; j++) {
            if (plugin->params[j].name && strcmp(plugin->params[j].name, desc->name) == 0)
                return rtk_error(RTK_ERR_PLUGIN, "plugin '%s': parameter '%s' is declared twice", name,
                                 desc->name);
        }
        if (desc->choices && desc->type != RTK_PARAM_STRING)
            return rtk_error(RTK_ERR_PLUGIN, "plugin '%s': parameter '%s' has choices but is not a string", name,
                             desc->name);
        rtk_status status = RTK_OK;
        switch (desc->type) {
        case RTK_PARAM_INT:
        case RTK_PARAM_FLOAT:
            status = check_number(name, desc);
            break;
        case RTK_PARAM_BOOL:
            if (!desc->required && desc->def != 0.0 && desc->def != 1.0)
                status = rtk_error(RTK_ERR_PLUGIN, "plugin '%s': boolean parameter '%s' has default %g, not 0 or 1",
                                   name, desc->name, desc->def);
            break;
        case RTK_PARAM_STRING:
            status = check_string(name, desc);
            break;
        default:
            status = rtk_error(RTK_ERR_PLUGIN, "plugin '%s': parameter '%s' has unknown type %d", name, desc->name,
                               (int)desc->type);
            break;
        }
        if (status != RTK_OK)
            return status;
    }
    return RTK_OK;
}

RTK_API const char *rtk_suggest(const char *word, const char *const *names, size_t count, size_t stride)
{
    if (!word || !names)
        return NULL;
    const char *best = NULL;
    int best_distance = INT_MAX;
    for (size_t i = 0; i < count; i++) {
        const char *candidate;
        memcpy(&candidate, (const char *)names + i * stride, sizeof candidate);
        if (!candidate)
            continue;
        int d = typo_distance(word, candidate);
        if (d < best_distance) {
            best_distance = d;
            best = candidate;
        }
    }
    return best;
}

const char *rtk_params_suggest(const rtk_param_desc *schema, uint32_t count, const char *name)
{
    return schema ? rtk_suggest(name, &schema->name, count, sizeof *schema) : NULL;
}

/* Plugin parameters: the schema a plugin declares, and typed getters.
 * The kernel validates every config value against the schema before any
 * plugin is created, so a getter for a declared name always succeeds. */
#ifndef RTK_PARAMS_H
#define RTK_PARAMS_H

#include <rtk/common.h>

RTK_EXTERN_C_BEGIN

/* Type of one parameter value. */
typedef enum rtk_param_type {
    RTK_PARAM_INT = 1,
    RTK_PARAM_FLOAT = 2,
    RTK_PARAM_BOOL = 3,
    RTK_PARAM_STRING = 4
} rtk_param_type;

/* One entry of a plugin's parameter schema. Zero-initialised fields mean
 * "none": min and max both 0 mean unbounded, choices == NULL means any
 * string. Any other min and max are an inclusive range, an exact one such
 * as [1, 1] included; -INFINITY or INFINITY leaves one side open. */
typedef struct rtk_param_desc {
    const char *name;       /* key in the config, e.g. "rays" */
    rtk_param_type type;
    double def;             /* default for int, float and bool */
    const char *def_string; /* default for strings */
    double min, max;        /* inclusive range for int and float */
    const char *choices;    /* allowed strings, '|'-separated: "object|spatial" */
    const char *doc;        /* one line for `rtk plugins NAME` */
    int required;           /* 1: the config must give it, def is ignored */
} rtk_param_desc;

/* 1 when desc declares a range for its int or float values (min and max
 * not both 0), 0 when they are unbounded. */
static inline int rtk_param_has_range(const rtk_param_desc *desc)
{
    return desc->min != 0.0 || desc->max != 0.0;
}

/* The type's name as schemas and messages spell it: "int", "float",
 * "bool", "string"; "unknown" for any other value. [any thread] */
RTK_API const char *rtk_param_type_name(rtk_param_type type);

/* Validated values for one plugin instance (opaque, kernel-owned). */
typedef struct rtk_params rtk_params;

/* Value of a declared parameter; 0 / 0.0 / "" for a name the schema
 * does not declare or of another type (and an error is logged once). */
RTK_API int64_t rtk_params_int(const rtk_params *params, const char *name);
RTK_API double rtk_params_float(const rtk_params *params, const char *name);
RTK_API int rtk_params_bool(const rtk_params *params, const char *name);
RTK_API const char *rtk_params_string(const rtk_params *params, const char *name);

RTK_EXTERN_C_END

#endif

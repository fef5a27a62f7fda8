/* Tests of kernel/core/params.c: defaults, text parsing with type, range and
 * choice checks, the typed getters, schema checks and suggestions. */
#include "config/config.h"
#include "render/render.h"
#include "image/image.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

static int failures;
static int checks;

#define CHECK(cond)                                                                  \
    do {                                                                             \
        checks++;                                                                    \
        if (!(cond)) {                                                               \
            failures++;                                                              \
            fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__, #cond); \
        }                                                                            \
    } while (0)

/* Checks that the last error message contains needle. */
#define CHECK_MSG(needle)                                                                              \
    do {                                                                                               \
        checks++;                                                                                      \
        if (!strstr(rtk_error_message(), (needle))) {                                                  \
            failures++;                                                                                \
            fprintf(stderr, "%s:%d: error lacks \"%s\":\n  %s\n", __FILE__, __LINE__, (needle),        \
                    rtk_error_message());                                                              \
        }                                                                                              \
    } while (0)

static const rtk_param_desc ao_params[] = {
    {.name = "rays", .type = RTK_PARAM_INT, .def = 16, .min = 1, .max = 4096, .doc = "rays per hit"},
    {.name = "distance", .type = RTK_PARAM_FLOAT, .def = INFINITY, .doc = "occlusion distance"},
    {.name = "bias", .type = RTK_PARAM_FLOAT, .def = 0.5, .min = 0, .max = 1, .doc = "blend"},
    {.name = "mode", .type = RTK_PARAM_STRING, .def_string = "fast", .choices = "fast|slow", .doc = "speed"},
    {.name = "cosine", .type = RTK_PARAM_BOOL, .def = 1, .doc = "cosine-weighted"},
    {.name = "label", .type = RTK_PARAM_STRING, .required = 1, .doc = "free text"},
};
static const rtk_plugin ao = {RTK_PLUGIN_HEADER, .kind = RTK_KIND_INTEGRATOR, .name = "ao", .params = ao_params,
                              .param_count = RTK_COUNTOF(ao_params)};

static void test_defaults_and_getters(void)
{
    rtk_params *p = rtk_params_defaults(&ao);
    CHECK(p != NULL);
    if (!p)
        return;
    CHECK(p->count == RTK_COUNTOF(ao_params));
    CHECK(rtk_params_int(p, "rays") == 16);
    CHECK(isinf(rtk_params_float(p, "distance")));
    CHECK(rtk_params_float(p, "bias") == 0.5);
    CHECK(strcmp(rtk_params_string(p, "mode"), "fast") == 0);
    CHECK(rtk_params_bool(p, "cosine") == 1);
    CHECK(strcmp(rtk_params_string(p, "label"), "") == 0);
    for (uint32_t i = 0; i < p->count; i++)
        CHECK(p->values[i].set_by_user == 0);
    /* Undeclared names and wrong types give zero values (and one warning). */
    CHECK(rtk_params_int(p, "nope") == 0);
    CHECK(rtk_params_int(p, "bias") == 0);
    CHECK(rtk_params_float(p, "rays") == 0.0);
    CHECK(rtk_params_bool(p, "mode") == 0);
    CHECK(strcmp(rtk_params_string(p, "rays"), "") == 0);
    CHECK(rtk_params_int(NULL, "rays") == 0);
    rtk_params_destroy(p);
}

/* The one spelling of the types that rtk plugins and rtk conform print. */
static void test_type_names(void)
{
    CHECK(strcmp(rtk_param_type_name(RTK_PARAM_INT), "int") == 0);
    CHECK(strcmp(rtk_param_type_name(RTK_PARAM_FLOAT), "float") == 0);
    CHECK(strcmp(rtk_param_type_name(RTK_PARAM_BOOL), "bool") == 0);
    CHECK(strcmp(rtk_param_type_name(RTK_PARAM_STRING), "string") == 0);
    CHECK(strcmp(rtk_param_type_name((rtk_param_type)0), "unknown") == 0);
}

static void test_set_text(void)
{
    rtk_params *p = rtk_params_defaults(&ao);
    if (!p)
        return;
    CHECK(rtk_params_set_text(p, "rays", "64") == RTK_OK);
    CHECK(rtk_params_int(p, "rays") == 64);
    CHECK(p->values[0].set_by_user == 1);
    CHECK(rtk_params_set_text(p, "rays", "0") == RTK_ERR_INVALID);
    CHECK_MSG("rays = 0 is out of range [1, 4096]");
    CHECK(rtk_params_set_text(p, "rays", "4097") == RTK_ERR_INVALID);
    CHECK(rtk_params_set_text(p, "rays", "1.5") == RTK_ERR_INVALID);
    CHECK_MSG("rays: expected an integer, found '1.5'");
    CHECK(rtk_params_set_text(p, "rays", "many") == RTK_ERR_INVALID);
    CHECK(rtk_params_set_text(p, "rays", "99999999999999999999") == RTK_ERR_INVALID);
    CHECK_MSG("64-bit");
    CHECK(rtk_params_int(p, "rays") == 64);

    CHECK(rtk_params_set_text(p, "distance", "1e-3") == RTK_OK);
    CHECK(rtk_params_float(p, "distance") == 1e-3);
    CHECK(rtk_params_set_text(p, "distance", "16") == RTK_OK);
    CHECK(rtk_params_float(p, "distance") == 16.0);
    CHECK(rtk_params_set_text(p, "distance", "inf") == RTK_OK);
    CHECK(isinf(rtk_params_float(p, "distance")));
    CHECK(rtk_params_set_text(p, "distance", "nan") == RTK_ERR_INVALID);
    CHECK(rtk_params_set_text(p, "distance", "1e999") == RTK_ERR_INVALID);
    CHECK(rtk_params_set_text(p, "distance", "far") == RTK_ERR_INVALID);
    CHECK_MSG("distance: expected a number");
    CHECK(rtk_params_set_text(p, "bias", "0.25") == RTK_OK);
    CHECK(rtk_params_float(p, "bias") == 0.25);
    CHECK(rtk_params_set_text(p, "bias", "inf") == RTK_ERR_INVALID);
    CHECK_MSG("bias = inf is out of range [0, 1]");
    CHECK(rtk_params_set_text(p, "bias", "1.5") == RTK_ERR_INVALID);
    CHECK_MSG("bias = 1.5 is out of range [0, 1]");

    static const char *const yes[] = {"true", "yes", "1", "on", "TRUE"};
    static const char *const no[] = {"false", "no", "0", "off"};
    for (size_t i = 0; i < sizeof yes / sizeof yes[0]; i++) {
        CHECK(rtk_params_set_text(p, "cosine", "false") == RTK_OK);
        CHECK(rtk_params_set_text(p, "cosine", yes[i]) == RTK_OK && rtk_params_bool(p, "cosine") == 1);
    }
    for (size_t i = 0; i < sizeof no / sizeof no[0]; i++) {
        CHECK(rtk_params_set_text(p, "cosine", "true") == RTK_OK);
        CHECK(rtk_params_set_text(p, "cosine", no[i]) == RTK_OK && rtk_params_bool(p, "cosine") == 0);
    }
    CHECK(rtk_params_set_text(p, "cosine", "2") == RTK_ERR_INVALID);
    CHECK_MSG("cosine: expected a boolean");

    CHECK(rtk_params_set_text(p, "mode", "slow") == RTK_OK);
    CHECK(strcmp(rtk_params_string(p, "mode"), "slow") == 0);
    CHECK(rtk_params_set_text(p, "mode", "fsat") == RTK_ERR_INVALID);
    CHECK_MSG("mode = 'fsat' is not one of: fast, slow (did you mean 'fast'?)");
    CHECK(strcmp(rtk_params_string(p, "mode"), "slow") == 0);
    CHECK(rtk_params_set_text(p, "label", "any text at all") == RTK_OK);
    CHECK(strcmp(rtk_params_string(p, "label"), "any text at all") == 0);

    CHECK(rtk_params_set_text(p, "rayz", "3") == RTK_ERR_INVALID);
    CHECK_MSG("unknown key 'rayz' (did you mean 'rays'?); keys of ao: rays, distance");
    rtk_params_destroy(p);
}

/* Schema check of a one-entry plugin; returns the status. */
static rtk_status check_one(rtk_param_desc desc)
{
    rtk_plugin plugin = {RTK_PLUGIN_HEADER, .kind = RTK_KIND_FILTER, .name = "bad", .params = &desc,
                         .param_count = 1};
    return rtk_params_check_schema(&plugin);
}

static void test_check_schema(void)
{
    CHECK(rtk_params_check_schema(&ao) == RTK_OK);
    rtk_plugin none = {RTK_PLUGIN_HEADER, .kind = RTK_KIND_FILTER, .name = "none"};
    CHECK(rtk_params_check_schema(&none) == RTK_OK);
    none.param_count = 2;
    CHECK(rtk_params_check_schema(&none) != RTK_OK);
    CHECK_MSG("none");

    CHECK(check_one((rtk_param_desc){.name = "", .type = RTK_PARAM_INT}) != RTK_OK);
    CHECK_MSG("plugin 'bad'");
    CHECK(check_one((rtk_param_desc){.name = NULL, .type = RTK_PARAM_INT}) != RTK_OK);
    CHECK(check_one((rtk_param_desc){.name = "two words", .type = RTK_PARAM_INT}) != RTK_OK);
    CHECK(check_one((rtk_param_desc){.name = "plugin", .type = RTK_PARAM_STRING}) != RTK_OK);
    CHECK(check_one((rtk_param_desc){.name = "x", .type = (rtk_param_type)9}) != RTK_OK);
    CHECK(check_one((rtk_param_desc){.name = "x", .type = RTK_PARAM_INT, .def = 0, .min = 1, .max = 4}) != RTK_OK);
    CHECK_MSG("default 0 outside its range [1, 4]");
    CHECK(check_one((rtk_param_desc){.name = "x", .type = RTK_PARAM_INT, .def = 1.5}) != RTK_OK);
    CHECK(check_one((rtk_param_desc){.name = "x", .type = RTK_PARAM_INT, .def = 1, .min = 0.5, .max = 4}) != RTK_OK);
    CHECK(check_one((rtk_param_desc){.name = "x", .type = RTK_PARAM_INT, .def = 1, .max = 1e30}) != RTK_OK);
    CHECK_MSG("not 64-bit integers");
    CHECK(check_one((rtk_param_desc){.name = "x", .type = RTK_PARAM_FLOAT, .def = 2, .min = 3, .max = 1}) != RTK_OK);
    CHECK_MSG("min > max");
    CHECK(check_one((rtk_param_desc){.name = "x", .type = RTK_PARAM_FLOAT, .def = NAN}) != RTK_OK);
    CHECK(check_one((rtk_param_desc){.name = "x", .type = RTK_PARAM_FLOAT, .def = INFINITY}) == RTK_OK);
    CHECK(check_one((rtk_param_desc){.name = "x", .type = RTK_PARAM_FLOAT, .required = 1, .min = 1, .max = 2}) ==
          RTK_OK);
    CHECK(check_one((rtk_param_desc){.name = "x", .type = RTK_PARAM_BOOL, .def = 2}) != RTK_OK);
    CHECK(check_one((rtk_param_desc){.name = "x", .type = RTK_PARAM_STRING, .def_string = "c", .choices = "a|b"}) !=
          RTK_OK);
    CHECK_MSG("default \"c\"");
    CHECK(check_one((rtk_param_desc){.name = "x", .type = RTK_PARAM_STRING, .def_string = "a", .choices = "a||b"}) !=
          RTK_OK);
    CHECK(check_one((rtk_param_desc){.name = "x", .type = RTK_PARAM_INT, .choices = "a|b"}) != RTK_OK);
    CHECK(check_one((rtk_param_desc){.name = "x", .type = RTK_PARAM_STRING, .def_string = "b", .choices = "a|b"}) ==
          RTK_OK);

    rtk_param_desc twice[] = {{.name = "x", .type = RTK_PARAM_INT}, {.name = "x", .type = RTK_PARAM_FLOAT}};
    rtk_plugin dup = {RTK_PLUGIN_HEADER, .kind = RTK_KIND_FILTER, .name = "dup", .params = twice, .param_count = 2};
    CHECK(rtk_params_check_schema(&dup) != RTK_OK);
    CHECK_MSG("'x' is declared twice");
}

/* A declared range [v, v] is exact: "min == max means unbounded" let a
 * parameter declared [1, 1] take -7. Only min and max both 0 (left out)
 * mean unbounded; an infinite bound leaves one side open. */
static const rtk_param_desc range_params[] = {
    {.name = "one", .type = RTK_PARAM_INT, .def = 1, .min = 1, .max = 1, .doc = "exactly 1"},
    {.name = "half", .type = RTK_PARAM_FLOAT, .def = 0.5, .min = 0.5, .max = 0.5, .doc = "exactly 0.5"},
    {.name = "any", .type = RTK_PARAM_INT, .def = 3, .doc = "unbounded"},
    {.name = "natural", .type = RTK_PARAM_INT, .def = 0, .min = 0, .max = INFINITY, .doc = "from 0 up"},
    {.name = "below", .type = RTK_PARAM_FLOAT, .def = -1, .min = -INFINITY, .max = 2, .doc = "up to 2"},
};
static const rtk_plugin ranges = {RTK_PLUGIN_HEADER, .kind = RTK_KIND_FILTER, .name = "ranges",
                                  .params = range_params, .param_count = RTK_COUNTOF(range_params)};

static void test_ranges(void)
{
    CHECK(rtk_params_check_schema(&ranges) == RTK_OK);
    CHECK(rtk_param_has_range(&range_params[0]) && rtk_param_has_range(&range_params[1]));
    CHECK(!rtk_param_has_range(&range_params[2]));
    CHECK(rtk_param_has_range(&range_params[3]) && rtk_param_has_range(&range_params[4]));
    rtk_params *p = rtk_params_defaults(&ranges);
    if (!p)
        return;
    CHECK(rtk_params_set_text(p, "one", "-7") == RTK_ERR_INVALID);
    CHECK_MSG("one = -7 is out of range [1, 1]");
    CHECK(rtk_params_set_text(p, "one", "2") == RTK_ERR_INVALID);
    CHECK(rtk_params_set_text(p, "one", "1") == RTK_OK && rtk_params_int(p, "one") == 1);
    CHECK(rtk_params_set_text(p, "half", "0.25") == RTK_ERR_INVALID);
    CHECK_MSG("half = 0.25 is out of range [0.5, 0.5]");
    CHECK(rtk_params_set_text(p, "half", "0.5") == RTK_OK);
    CHECK(rtk_params_set_text(p, "any", "-7") == RTK_OK && rtk_params_int(p, "any") == -7);
    CHECK(rtk_params_set_text(p, "natural", "-1") == RTK_ERR_INVALID);
    CHECK_MSG("natural = -1 is out of range [0, 9223372036854775807]");
    CHECK(rtk_params_set_text(p, "natural", "123456789012") == RTK_OK && rtk_params_int(p, "natural") == 123456789012);
    CHECK(rtk_params_set_text(p, "below", "-1e300") == RTK_OK);
    CHECK(rtk_params_set_text(p, "below", "-inf") == RTK_OK && isinf(rtk_params_float(p, "below")));
    CHECK(rtk_params_set_text(p, "below", "3") == RTK_ERR_INVALID);
    CHECK_MSG("below = 3 is out of range [-inf, 2]");
    rtk_params_destroy(p);
    /* The schema check holds a default to an exact range too. */
    CHECK(check_one((rtk_param_desc){.name = "x", .type = RTK_PARAM_INT, .def = 0, .min = 1, .max = 1}) != RTK_OK);
    CHECK_MSG("default 0 outside its range [1, 1]");
    CHECK(check_one((rtk_param_desc){.name = "x", .type = RTK_PARAM_FLOAT, .def = 2, .min = -3, .max = -3}) !=
          RTK_OK);
    CHECK(check_one((rtk_param_desc){.name = "x", .type = RTK_PARAM_INT, .def = -5, .min = -INFINITY, .max = 0}) ==
          RTK_OK);
    CHECK(check_one((rtk_param_desc){.name = "x", .type = RTK_PARAM_INT, .def = 5, .min = 0, .max = NAN}) != RTK_OK);
}

static void test_suggest(void)
{
    const rtk_param_desc *s = ao_params;
    uint32_t n = RTK_COUNTOF(ao_params);
    CHECK(rtk_params_suggest(s, n, "rayz") && strcmp(rtk_params_suggest(s, n, "rayz"), "rays") == 0);
    CHECK(rtk_params_suggest(s, n, "distnace") && strcmp(rtk_params_suggest(s, n, "distnace"), "distance") == 0);
    CHECK(rtk_params_suggest(s, n, "Mode") && strcmp(rtk_params_suggest(s, n, "Mode"), "mode") == 0);
    CHECK(rtk_params_suggest(s, n, "resolution") == NULL);
    CHECK(rtk_params_suggest(s, n, "xy") == NULL);
    CHECK(rtk_params_suggest(NULL, 0, "rays") == NULL);
    /* The same for plain strings and for structs that begin with a name. */
    static const char *const words[] = {"render", "plugins", NULL, "bench"};
    const char *near = rtk_suggest("rendr", words, RTK_COUNTOF(words), sizeof words[0]);
    CHECK(near && strcmp(near, "render") == 0);
    CHECK(rtk_suggest("sweep", words, RTK_COUNTOF(words), sizeof words[0]) == NULL);
    near = rtk_suggest("--thread", &(const char *const[]){"--threads", "--set"}[0], 2, sizeof(const char *));
    CHECK(near && strcmp(near, "--threads") == 0);
    near = rtk_suggest("distnace", &ao_params[0].name, RTK_COUNTOF(ao_params), sizeof ao_params[0]);
    CHECK(near && strcmp(near, "distance") == 0);
}

int main(void)
{
    rtk_log_set_level(RTK_LOG_ERROR); /* the getter warnings are expected here */
    test_defaults_and_getters();
    test_type_names();
    test_set_text();
    test_check_schema();
    test_ranges();
    test_suggest();
    printf("%d checks, %d failed\n", checks, failures);
    return failures ? 1 : 0;
}

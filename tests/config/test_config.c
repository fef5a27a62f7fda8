/* Tests of kernel/config/config.c through the real plugin registry: each bad
 * config is written to a temporary directory (so line numbers are known)
 * and the error must name the file, the line and the key at fault. The
 * broken configs in scenes/bad/ are checked the same way. */
#include "config/config.h"
#include "render/render.h"
#include "image/image.h"

#include <dirent.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#ifndef TEST_DIR
#define TEST_DIR "."
#endif

static int failures;
static int checks;
static char tmpdir[256];
static rtk_registry *registry;

#define CHECK(cond)                                                                  \
    do {                                                                             \
        checks++;                                                                    \
        if (!(cond)) {                                                               \
            failures++;                                                              \
            fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__, #cond); \
        }                                                                            \
    } while (0)

/* Writes text to name inside the temporary directory; returns the path. */
static const char *write_file(const char *name, const char *text)
{
    static char path[16][512];
    static int next;
    char *p = path[next++ % 16];
    snprintf(p, 512, "%s/%s", tmpdir, name);
    FILE *f = fopen(p, "w");
    if (!f) {
        fprintf(stderr, "cannot write %s\n", p);
        failures++;
        return p;
    }
    fputs(text, f);
    fclose(f);
    return p;
}

/* Loads path and expects it to fail with every string after opts in the
 * message (NULL-terminated: the compiler checks it). */
static void expect_error(int line, const char *path, const rtk_config_options *opts, ...)
    __attribute__((sentinel));
static void expect_error(int line, const char *path, const rtk_config_options *opts, ...)
{
    rtk_config *cfg = (rtk_config *)1;
    rtk_status status = rtk_config_load(path, registry, opts, &cfg);
    checks++;
    if (status == RTK_OK || cfg != NULL) {
        failures++;
        fprintf(stderr, "%s:%d: %s loaded, expected an error\n", __FILE__, line, path);
        rtk_config_destroy(cfg);
        return;
    }
    const char *msg = rtk_error_message();
    va_list ap;
    va_start(ap, opts);
    for (const char *needle = va_arg(ap, const char *); needle; needle = va_arg(ap, const char *)) {
        checks++;
        if (!strstr(msg, needle)) {
            failures++;
            fprintf(stderr, "%s:%d: error lacks \"%s\":\n  %s\n", __FILE__, line, needle, msg);
        }
    }
    va_end(ap);
}

/* Loads path and expects success. [caller frees] */
static rtk_config *expect_ok(int line, const char *path, const rtk_config_options *opts)
{
    rtk_config *cfg = NULL;
    checks++;
    if (rtk_config_load(path, registry, opts, &cfg) != RTK_OK || !cfg) {
        failures++;
        fprintf(stderr, "%s:%d: %s failed: %s\n", __FILE__, line, path, rtk_error_message());
        return NULL;
    }
    return cfg;
}

static int ends_with(const char *s, const char *tail)
{
    size_t a = strlen(s), b = strlen(tail);
    return a >= b && strcmp(s + a - b, tail) == 0;
}

static void test_minimal(void)
{
    const char *path = write_file("minimal.cfg", "scene = \"model.obj\";\n");
    rtk_config *cfg = expect_ok(__LINE__, path, NULL);
    if (!cfg)
        return;
    char want[600];
    snprintf(want, sizeof want, "%s/model.obj", tmpdir);
    CHECK(strcmp(cfg->scene_path, want) == 0);
    snprintf(want, sizeof want, "%s/minimal.png", tmpdir);
    CHECK(strcmp(cfg->output, want) == 0);
    CHECK(cfg->width == 512 && cfg->height == 512 && cfg->spp == 16);
    CHECK(cfg->threads == 0 && cfg->seed == 0 && cfg->half == 0);
    CHECK(!cfg->aov_albedo && !cfg->aov_normal && !cfg->aov_depth);
    CHECK(strcmp(cfg->sampler_type, "independent") == 0);
    CHECK(cfg->has_camera == 0);
    CHECK(strcmp(cfg->integrator.plugin->name, "headlight") == 0);
    CHECK(strcmp(cfg->accelerator.plugin->name, "sah") == 0);
    CHECK(strcmp(cfg->filter.plugin->name, "box") == 0);
    CHECK(cfg->integrator.params && cfg->accelerator.params && cfg->filter.params);
    CHECK(rtk_params_float(cfg->filter.params, "radius") == 0.5);
    rtk_config_destroy(cfg);
}

static void test_full(void)
{
    const char *path = write_file("full.cfg",
                                  "scene = \"cornell/cornell.obj\";\n"
                                  "camera = { position = [0.0, 1.0, 3.9]; look_at = [0, 1, 0]; fov = 50; };\n"
                                  "film = { width = 320; height = 240; spp = 4; output = \"out/img.exr\";\n"
                                  "         half = true; aovs = [\"albedo\", \"depth\"]; };\n"
                                  "sampler = { type = \"independent\"; seed = 7; };\n"
                                  "threads = 3;\noversubscribe = true;\n"
                                  "accelerator = { plugin = \"median\"; };\n"
                                  "integrator = \"headlight\";\n"
                                  "filter = { plugin = \"box\"; radius = 2; };\n");
    rtk_config *cfg = expect_ok(__LINE__, path, NULL);
    if (!cfg)
        return;
    CHECK(cfg->has_camera);
    CHECK(cfg->camera.position.x == 0.0f && cfg->camera.position.y == 1.0f && cfg->camera.position.z == 3.9f);
    CHECK(cfg->camera.look_at.y == 1.0f && cfg->camera.up.y == 1.0f && cfg->camera.up.x == 0.0f);
    CHECK(cfg->camera.fov_deg == 50.0f);
    CHECK(cfg->width == 320 && cfg->height == 240 && cfg->spp == 4 && cfg->half == 1);
    CHECK(ends_with(cfg->output, "/out/img.exr"));
    CHECK(cfg->aov_albedo && !cfg->aov_normal && cfg->aov_depth);
    CHECK(cfg->seed == 7 && cfg->threads == 3);
    CHECK(strcmp(cfg->integrator.plugin->name, "headlight") == 0);
    CHECK(rtk_params_float(cfg->filter.params, "radius") == 2.0); /* integer accepted for a float */
    rtk_config_destroy(cfg);
}

static void test_errors(void)
{
    const char *p;
    p = write_file("typo_slot.cfg", "scene = \"m.obj\";\n\nintgrator = { plugin = \"headlight\"; };\n");
    expect_error(__LINE__, p, NULL, "typo_slot.cfg:3", "'intgrator'", "did you mean 'integrator'", NULL);

    p = write_file("film_key.cfg", "scene = \"m.obj\";\nfilm = {\n  widht = 64;\n};\n");
    expect_error(__LINE__, p, NULL, "film_key.cfg:3", "film", "'widht'", "did you mean 'width'", "height", NULL);

    p = write_file("wrong_type.cfg", "scene = \"m.obj\";\nfilm = { width = \"big\"; };\n");
    expect_error(__LINE__, p, NULL, "wrong_type.cfg:2", "width", "expected an integer, found a string", NULL);

    p = write_file("float_int.cfg", "scene = \"m.obj\";\nfilm = { spp = 4.0; };\n");
    expect_error(__LINE__, p, NULL, "float_int.cfg:2", "spp", "expected an integer, found a float", NULL);

    p = write_file("range.cfg", "scene = \"m.obj\";\nfilm = {\n spp = 0; };\n");
    expect_error(__LINE__, p, NULL, "range.cfg:3", "spp = 0 is out of range [1, 1048576]", NULL);

    p = write_file("fov.cfg", "scene = \"m.obj\";\ncamera = { position = [0, 0, 1]; look_at = [0, 0, 0];\n fov = 180; };\n");
    expect_error(__LINE__, p, NULL, "fov.cfg:3", "fov = 180 is out of range (0, 180)", NULL);

    p = write_file("camera_req.cfg", "scene = \"m.obj\";\ncamera = { look_at = [0, 0, 0]; };\n");
    expect_error(__LINE__, p, NULL, "camera_req.cfg:2", "camera", "'position'", NULL);

    p = write_file("vec.cfg", "scene = \"m.obj\";\ncamera = { position = [0, 1]; look_at = [0, 0, 0]; };\n");
    expect_error(__LINE__, p, NULL, "vec.cfg:2", "position", "expected 3 numbers", NULL);

    p = write_file("aovs.cfg", "scene = \"m.obj\";\nfilm = { aovs = [\"albdo\"]; };\n");
    expect_error(__LINE__, p, NULL, "aovs.cfg:2", "'albdo'", "did you mean 'albedo'", NULL);

    p = write_file("aovs_png.cfg", "scene = \"m.obj\";\nfilm = {\n aovs = \"depth\"; };\n");
    expect_error(__LINE__, p, NULL, "aovs_png.cfg:3", "aovs need an EXR output", "aovs_png.png", NULL);

    p = write_file("same.cfg", "scene = \"m.obj\";\ncamera = { position = [1, 2, 3];\n look_at = [1, 2, 3]; };\n");
    expect_error(__LINE__, p, NULL, "same.cfg:3", "look_at is the same point as position", NULL);

    p = write_file("up.cfg", "scene = \"m.obj\";\ncamera = { position = [0, 0, 0]; look_at = [0, 2, 0];\n up = [0, 1, 0]; };\n");
    expect_error(__LINE__, p, NULL, "up.cfg:3", "parallel to the view direction", NULL);

    p = write_file("choice.cfg", "scene = \"m.obj\";\nsampler = { type = \"sobel\"; };\n");
    expect_error(__LINE__, p, NULL, "choice.cfg:2", "type = 'sobel' is not one of: independent", NULL);

    p = write_file("threads.cfg", "scene = \"m.obj\";\nthreads = -1;\n");
    expect_error(__LINE__, p, NULL, "threads.cfg:2", "threads = -1 is out of range [0, 1024]", NULL);

    p = write_file("no_scene.cfg", "film = { width = 64; };\n");
    expect_error(__LINE__, p, NULL, "no_scene.cfg: no 'scene' setting", "scene = \"path/to/model.obj\";", NULL);

    p = write_file("scnee.cfg", "scnee = \"m.obj\";\n");
    expect_error(__LINE__, p, NULL, "scnee.cfg:1", "did you mean 'scene'", NULL);

    p = write_file("syntax.cfg", "scene = \"m.obj\";\n\nfilm = { width = ; };\n");
    expect_error(__LINE__, p, NULL, "syntax.cfg:3", "syntax error", NULL);

    /* The lists of groups (lights, instances) share their checks. */
    p = write_file("lights_list.cfg", "scene = \"m.obj\";\nlights = { type = \"point\"; };\n");
    expect_error(__LINE__, p, NULL, "lights_list.cfg:2", "lights: expected a list of groups",
                 "{ type = \"point\"; position = [0, 2, 0]; intensity = [5, 5, 5]; }", "found a group", NULL);
    p = write_file("lights_elem.cfg", "scene = \"m.obj\";\n"
                                      "lights = ( { type = \"point\"; position = [0, 1, 0]; intensity = [1, 1, 1]; },\n"
                                      "  42 );\n");
    expect_error(__LINE__, p, NULL, "lights_elem.cfg:3", "lights[1]: expected a group { type = \"point\"; ... }", NULL);
    /* The light's type named in the message (read before its settings are freed). */
    p = write_file("lights_dir.cfg",
                   "scene = \"m.obj\";\nlights = ( {\n  type = \"directional\"; intensity = [1, 1, 1]; } );\n");
    expect_error(__LINE__, p, NULL, "lights_dir.cfg:2", "lights[0]: a directional light needs direction = [x, y, z]",
                 NULL);
    p = write_file("lights_key.cfg", "scene = \"m.obj\";\nlights = ( {\n  tpye = \"point\"; } );\n");
    expect_error(__LINE__, p, NULL, "lights_key.cfg:3", "lights[0]", "'tpye'", "did you mean 'type'", NULL);
    p = write_file("instances_list.cfg", "scene = \"m.obj\";\ninstances = [1, 2];\n");
    expect_error(__LINE__, p, NULL, "instances_list.cfg:2", "instances: expected a list of groups",
                 "{ file = \"bunny.obj\"; translate = [0, 0, 0]; }", NULL);
    p = write_file("instances_elem.cfg", "scene = \"m.obj\";\ninstances = (\n  \"bunny.obj\" );\n");
    expect_error(__LINE__, p, NULL, "instances_elem.cfg:3",
                 "instances[0]: expected a group { file = \"bunny.obj\"; ... }", NULL);

    char missing[512];
    snprintf(missing, sizeof missing, "%s/nope.cfg", tmpdir);
    expect_error(__LINE__, missing, NULL, "nope.cfg", "cannot read config", NULL);
}

/* libconfig wraps an integer without L that does not fit in 32 bits
 * (4294967297 became width 1): the loader refuses such literals first. */
static void test_int_literals(void)
{
    const char *p;
    p = write_file("int32.cfg", "scene = \"m.obj\";\nfilm = {\n  width = 4294967297; };\n");
    expect_error(__LINE__, p, NULL, "int32.cfg:3", "the integer 4294967297 does not fit in 32 bits",
                 "write 4294967297L", NULL);
    p = write_file("int32neg.cfg", "scene = \"m.obj\";\nthreads = -2147483649;\n");
    expect_error(__LINE__, p, NULL, "int32neg.cfg:2", "the integer -2147483649 does not fit in 32 bits", NULL);
    p = write_file("hex32.cfg", "scene = \"m.obj\";\nthreads = 0xffffffff;\n");
    expect_error(__LINE__, p, NULL, "hex32.cfg:2", "the integer 0xffffffff does not fit in 32 bits", NULL);
    p = write_file("int64.cfg", "scene = \"m.obj\";\ncache_limit = 99999999999999999999L;\n");
    expect_error(__LINE__, p, NULL, "int64.cfg:2", "the integer 99999999999999999999L does not fit in 64 bits",
                 NULL);
    p = write_file("int64b.cfg", "scene = \"m.obj\";\ncache_limit = 9223372036854775808;\n");
    expect_error(__LINE__, p, NULL, "int64b.cfg:2", "does not fit in 64 bits", NULL);
    /* In an @include'd file: its own name and line. */
    write_file("inc_int.cfg", "# included\nfilm = {\n  width = 2147483648; };\n");
    p = write_file("inc_main.cfg", "scene = \"m.obj\";\n@include \"inc_int.cfg\"\n");
    expect_error(__LINE__, p, NULL, "inc_int.cfg:3", "the integer 2147483648 does not fit in 32 bits", NULL);
    /* Allowed: in range, with L, in comments, strings and names, floats. */
    p = write_file("int_ok.cfg", "# width = 4294967297\n/* 99999999999999999999\n 4294967297 */\n"
                                 "scene = \"m4294967297\\\"9999999999.obj\";\n"
                                 "cache_limit = 1048576L; // 4294967297\nthreads = 0x10;\noversubscribe = true;\n"
                                 "film = { width = 0x40; height = 48; spp = 1; };\nsampler = { seed = 2147483647; };\n"
                                 "camera = { position = [1e10, -2.5e-10, 4294967297.0]; look_at = [0, 0, 0]; };\n");
    rtk_config *cfg = expect_ok(__LINE__, p, NULL);
    if (cfg) {
        CHECK(cfg->cache_limit == (uint64_t)1048576 << 20);
        CHECK(cfg->width == 64 && cfg->height == 48 && cfg->threads == 16 && cfg->seed == 2147483647);
        CHECK(ends_with(cfg->scene_path, "m4294967297\"9999999999.obj"));
        rtk_config_destroy(cfg);
    }
}

static void test_plugins(void)
{
    const char *p;
    p = write_file("headlite.cfg", "scene = \"m.obj\";\nintegrator = { plugin = \"headlite\"; };\n");
    expect_error(__LINE__, p, NULL, "headlite.cfg:2", "integrator", "headlite", "headlight", NULL);

    p = write_file("kind.cfg", "scene = \"m.obj\";\n\nintegrator = { plugin = \"box\"; };\n");
    expect_error(__LINE__, p, NULL, "kind.cfg:3", "integrator", "box", "filter", NULL);

    p = write_file("raduis.cfg", "scene = \"m.obj\";\nfilter = { plugin = \"box\";\n  raduis = 1.0; };\n");
    expect_error(__LINE__, p, NULL, "raduis.cfg:3", "filter", "'raduis'", "did you mean 'radius'", "keys of box",
                 NULL);

    p = write_file("radius_range.cfg", "scene = \"m.obj\";\nfilter = { plugin = \"box\"; radius = 100.0; };\n");
    expect_error(__LINE__, p, NULL, "radius_range.cfg:2", "radius = 100 is out of range [0.001, 16]", NULL);

    p = write_file("plugin_type.cfg", "scene = \"m.obj\";\nfilter = { plugin = 3; };\n");
    expect_error(__LINE__, p, NULL, "plugin_type.cfg:2", "filter: plugin: expected a plugin name", NULL);

    p = write_file("default_key.cfg", "scene = \"m.obj\";\nintegrator = { rays = 4; };\n");
    expect_error(__LINE__, p, NULL, "default_key.cfg:2", "'rays'", "keys of headlight", NULL);

    char dir[512];
    snprintf(dir, sizeof dir, "%s/myplugins", tmpdir);
    mkdir(dir, 0755);
    p = write_file("plugin_path.cfg", "scene = \"m.obj\";\nplugin_path = \"myplugins\";\n");
    expect_error(__LINE__, p, NULL, "plugin_path.cfg:2", "plugin_path would load code from", "myplugins",
                 "--allow-config-plugins", NULL);
    rtk_config_options trust = {.size = sizeof trust, .allow_config_plugins = 1};
    rtk_config_destroy(expect_ok(__LINE__, p, &trust));

    p = write_file("plugin_list.cfg", "scene = \"m.obj\";\nplugin_path = [\"myplugins\", \"missing\"];\n");
    expect_error(__LINE__, p, &trust, "plugin_list.cfg:2", "missing", "not a directory", NULL);

    p = write_file("plugin_file.cfg", "scene = \"m.obj\";\nfilter = { plugin = \"./myplugins/box.so\"; };\n");
    expect_error(__LINE__, p, NULL, "plugin_file.cfg:2", "would load code from", "box.so", "--allow-config-plugins",
                 NULL);
}

static void test_overrides(void)
{
    const char *p = write_file("over.cfg", "scene = \"m.obj\";\nfilm = { width = 32; };\n");
    const char *set[] = {"film.width=64", "film.height=48", "scene=other.obj", "camera.position=[1, 2, 3]",
                         "camera.look_at=[0,0,0]", "film.output=2024.exr", "filter.radius=1", "film.aovs=[normal]",
                         "sampler.seed=5000000000"};
    rtk_config_options opts = {.size = sizeof opts, .overrides = set, .override_count = RTK_COUNTOF(set)};
    rtk_config *cfg = expect_ok(__LINE__, p, &opts);
    if (cfg) {
        CHECK(cfg->width == 64 && cfg->height == 48);
        CHECK(ends_with(cfg->scene_path, "/other.obj"));
        CHECK(cfg->has_camera && cfg->camera.position.x == 1.0f && cfg->camera.position.z == 3.0f);
        CHECK(ends_with(cfg->output, "/2024.exr"));
        CHECK(rtk_params_float(cfg->filter.params, "radius") == 1.0);
        CHECK(cfg->aov_normal && !cfg->aov_albedo);
        CHECK(cfg->seed == 5000000000ull);
        rtk_config_destroy(cfg);
    }

    const char *bogus[] = {"integrator.bogus=1"};
    rtk_config_options bad = {.size = sizeof bad, .overrides = bogus, .override_count = 1};
    expect_error(__LINE__, p, &bad, "--set integrator.bogus=1", "'bogus'", NULL);

    const char *range[] = {"film.width=0"};
    bad.overrides = range;
    expect_error(__LINE__, p, &bad, "--set film.width=0", "width = 0 is out of range", NULL);

    const char *noeq[] = {"film.width"};
    bad.overrides = noeq;
    expect_error(__LINE__, p, &bad, "--set film.width", "path=value", NULL);

    const char *nopath[] = {"=3"};
    bad.overrides = nopath;
    expect_error(__LINE__, p, &bad, "--set =3", "empty", NULL);

    const char *dots[] = {"film..width=3"};
    bad.overrides = dots;
    expect_error(__LINE__, p, &bad, "--set film..width=3", "malformed", NULL);

    const char *notgroup[] = {"scene.x=3"};
    bad.overrides = notgroup;
    expect_error(__LINE__, p, &bad, "--set scene.x=3", "not a group", "over.cfg:1", NULL);

    const char *mixed[] = {"camera.position=[1, a, 3]"};
    bad.overrides = mixed;
    expect_error(__LINE__, p, &bad, "--set camera.position=[1, a, 3]", "numbers or strings", NULL);
}

/* Every bad key and --set entry is reported in one error, not just the
 * first (the film group's was the only one shown when the integrator's
 * came first on the command line). */
static void test_all_errors(void)
{
    const char *p = write_file("many.cfg", "scene = \"m.obj\";\nfilm = {\n  widht = 3;\n  hieght = 4; };\n");
    expect_error(__LINE__, p, NULL, "2 errors:", "many.cfg:3", "did you mean 'width'", "many.cfg:4",
                 "did you mean 'height'", NULL);
    p = write_file("many_set.cfg", "scene = \"m.obj\";\n");
    const char *set[] = {"integrator.bogus=1", "film.widht=3", "a..b=1", "film.spp=0", "camera"};
    rtk_config_options opts = {.size = sizeof opts, .overrides = set, .override_count = RTK_COUNTOF(set)};
    expect_error(__LINE__, p, &opts, "5 errors:", "--set integrator.bogus=1", "'bogus'", "--set film.widht=3",
                 "did you mean 'width'", "--set a..b=1: malformed", "--set film.spp=0: film: spp = 0 is out of range",
                 "--set camera: expected path=value", NULL);
    /* One error alone reads as before. */
    const char *one[] = {"film.widht=3"};
    opts.overrides = one;
    opts.override_count = 1;
    expect_error(__LINE__, p, &opts, "--set film.widht=3: film: unknown key 'widht'", NULL);
    checks++;
    if (strstr(rtk_error_message(), "errors:")) {
        failures++;
        fprintf(stderr, "%s:%d: one error counted as several: %s\n", __FILE__, __LINE__, rtk_error_message());
    }
}

/* threads above the cores this process may use are capped to them (999 threads on 2
 * cores ran 999), unless oversubscribe says otherwise. */
static void test_threads_limit(void)
{
    uint32_t cores = rtk_core_count();
    if (cores >= 1024) {
        printf("skip: %u cores leave no thread count above them\n", cores);
        return;
    }
    char text[128];
    snprintf(text, sizeof text, "scene = \"m.obj\";\nthreads = %u;\n", cores + 1);
    const char *p = write_file("threads_many.cfg", text);
    rtk_config *cfg = expect_ok(__LINE__, p, NULL);
    if (cfg)
        CHECK(cfg->threads == cores);
    rtk_config_destroy(cfg);
    rtk_config_options over = {.size = sizeof over, .oversubscribe = 1};
    cfg = expect_ok(__LINE__, p, &over);
    if (cfg)
        CHECK(cfg->threads == cores + 1);
    rtk_config_destroy(cfg);
    snprintf(text, sizeof text, "scene = \"m.obj\";\nthreads = %u;\noversubscribe = true;\n", cores + 1);
    cfg = expect_ok(__LINE__, write_file("threads_over.cfg", text), NULL);
    if (cfg)
        CHECK(cfg->threads == cores + 1);
    rtk_config_destroy(cfg);
    CHECK(rtk_threads_limit(0, 0, "test") == 0);
    CHECK(rtk_threads_limit(cores, 0, "test") == cores);
    CHECK(rtk_threads_limit(cores + 1, 0, "test") == cores);
    CHECK(rtk_threads_limit(cores + 1, 1, "test") == cores + 1);
}

/* ao's default distance is inf, which libconfig cannot read: the string
 * "inf" stands for it, and a bare inf gets a message saying so. */
static void test_inf(void)
{
    const char *p = write_file("inf.cfg", "scene = \"m.obj\";\nintegrator = { plugin = \"ao\"; distance = \"inf\"; };\n");
    rtk_config *cfg = expect_ok(__LINE__, p, NULL);
    if (cfg)
        CHECK(isinf(rtk_params_float(cfg->integrator.params, "distance")));
    rtk_config_destroy(cfg);
    p = write_file("infinity.cfg", "scene = \"m.obj\";\nintegrator = { plugin = \"ao\"; distance = \"Infinity\"; };\n");
    cfg = expect_ok(__LINE__, p, NULL);
    if (cfg)
        CHECK(isinf(rtk_params_float(cfg->integrator.params, "distance")));
    rtk_config_destroy(cfg);
    p = write_file("inf_bare.cfg", "scene = \"m.obj\";\nintegrator = { plugin = \"ao\";\n  distance = inf; };\n");
    expect_error(__LINE__, p, NULL, "inf_bare.cfg:3", "libconfig cannot read inf", "distance = \"inf\";", NULL);
    p = write_file("inf_neg.cfg", "scene = \"m.obj\";\nintegrator = { plugin = \"ao\"; distance = -inf; };\n");
    expect_error(__LINE__, p, NULL, "inf_neg.cfg:2", "distance = \"-inf\";", NULL);
    p = write_file("inf_range.cfg", "scene = \"m.obj\";\nintegrator = { plugin = \"ao\"; distance = \"-inf\"; };\n");
    expect_error(__LINE__, p, NULL, "inf_range.cfg:2", "distance = -inf is out of range", NULL);
    p = write_file("inf_int.cfg", "scene = \"m.obj\";\nintegrator = { plugin = \"ao\"; rays = \"inf\"; };\n");
    expect_error(__LINE__, p, NULL, "inf_int.cfg:2", "rays: expected an integer, found a string", NULL);
    /* A name that is only spelled like it, and inf as text, stay as they are. */
    p = write_file("inf_name.cfg", "scene = \"inf.obj\";\n");
    cfg = expect_ok(__LINE__, p, NULL);
    if (cfg)
        CHECK(ends_with(cfg->scene_path, "/inf.obj"));
    rtk_config_destroy(cfg);
}

/* Strings where libconfig's grammar wants none: libconfig leaked the
 * string on that syntax error (LeakSanitizer in the ASan run), so the
 * check refuses them first; strings in their places pass, also at the
 * start of an included file. */
static void test_string_places(void)
{
    const char *p = write_file("str_name.cfg", "scene = \"m.obj\";\n\"oops\" = 1;\n");
    expect_error(__LINE__, p, NULL, "str_name.cfg:2", "syntax error at the string \"oops\"", NULL);
    p = write_file("str_after.cfg", "scene = \"m.obj\";\nfilm = { width = 3 \"x\"; };\n");
    expect_error(__LINE__, p, NULL, "str_after.cfg:2", "syntax error at the string \"x\"", NULL);
    p = write_file("str_open.cfg", "scene = \"m.obj\";\nfilm = { output = \"a.png; };\n");
    expect_error(__LINE__, p, NULL, "str_open.cfg:2", "the string opened here is not closed", NULL);
    p = write_file("str_comment.cfg", "scene = \"m.obj\";\n/* note\n");
    expect_error(__LINE__, p, NULL, "str_comment.cfg:2", "the comment /* opened here is not closed", NULL);
    write_file("inc_scene.cfg", "\"m\" \".obj\"\n");
    write_file("inc_aovs.cfg", "\"albedo\",\n\"depth\"\n");
    p = write_file("str_inc.cfg", "scene =\n@include \"inc_scene.cfg\"\n;\n"
                                  "film = { output = \"o.exr\"; aovs = [\n@include \"inc_aovs.cfg\"\n]; };\n"
                                  "lights = ( { type = \"point\"; position = [0, 1, 0]; intensity = [1, 1, 1]; },\n"
                                  "  { type = \"point\"; position = [0, 2, 0]; intensity = [1, 1, 1]; } );\n");
    rtk_config *cfg = expect_ok(__LINE__, p, NULL);
    if (cfg) {
        CHECK(ends_with(cfg->scene_path, "/m.obj"));
        CHECK(cfg->aov_albedo && cfg->aov_depth && !cfg->aov_normal);
        CHECK(cfg->light_count == 2);
    }
    rtk_config_destroy(cfg);
    /* What an included file leaves open, and a string it ends with, seen from the file including it. */
    write_file("inc_open.cfg", "film = {\n");
    p = write_file("str_inc_open.cfg", "scene = \"m.obj\";\n@include \"inc_open.cfg\"\n};\n");
    expect_error(__LINE__, p, NULL, "inc_open.cfg:1", "the group { } opened here is not closed in this file", NULL);
    write_file("inc_end.cfg", "cache = \"off\";\n");
    p = write_file("str_inc_end.cfg", "scene = \"m.obj\";\n@include \"inc_end.cfg\"\n\"oops\" = 1;\n");
    expect_error(__LINE__, p, NULL, "str_inc_end.cfg:3", "syntax error at the string \"oops\"", NULL);
    /* A character outside libconfig's syntax before a string (found by tests/fuzz: libconfig leaked the string). */
    p = write_file("str_garbage.cfg", "scene = \"m.obj\";\naccelerator = { plugin =. \"sah\"; };\n");
    expect_error(__LINE__, p, NULL, "str_garbage.cfg:2", "syntax error at '.'", NULL);
    p = write_file("str_byte.cfg", "scene = \"m.obj\";\ncache = \x01 \"off\";\n");
    expect_error(__LINE__, p, NULL, "str_byte.cfg:2", "syntax error at byte 0x01", NULL);
    p = write_file("bad_include.cfg", "scene = \"m.obj\";\n@include inc_end.cfg\n");
    expect_error(__LINE__, p, NULL, "bad_include.cfg:2", "@include needs a file name in double quotes", NULL);
    p = write_file("abs_include.cfg", "scene = \"m.obj\";\n@include \"/etc/hostname\"\n");
    expect_error(__LINE__, p, NULL, "abs_include.cfg:2", "@include \"/etc/hostname\": an absolute path, which libconfig",
                 "name the file relative to that folder", NULL);
    /* Floats that start with a point are numbers, not stray characters. */
    p = write_file("point_float.cfg", "scene = \"m.obj\";\nintegrator = { plugin = \"ao\"; distance = .5; };\n"
                                      "camera = { position = [-.5, +.25, 1.]; look_at = [0.0, 0.0, 0.0]; };\n");
    cfg = expect_ok(__LINE__, p, NULL);
    rtk_config_destroy(cfg);
}

/* @include: each file read once however often it is included (a chain of
 * 6 levels, each including the next 3 times, read 3^6 = 729 leaves where
 * it read 8 files), an expansion that libconfig would take forever over,
 * cycles, depth and files that are not configs, each with a message. */
static void test_includes(void)
{
    char text[512], name[64];
    for (int level = 0; level < 6; level++) {
        snprintf(text, sizeof text, "@include \"chain%d.cfg\"\n@include \"chain%d.cfg\"\n@include \"chain%d.cfg\"\n",
                 level + 1, level + 1, level + 1);
        snprintf(name, sizeof name, "chain%d.cfg", level);
        write_file(name, text);
    }
    write_file("chain6.cfg", "# the leaf: a comment, so that 729 copies of it are valid\n");
    const char *p = write_file("chain.cfg", "scene = \"m.obj\";\n@include \"chain0.cfg\"\n");
    rtk_config *cfg = expect_ok(__LINE__, p, NULL);
    rtk_config_destroy(cfg);
    CHECK(rtk_config_files_read() == 8);

    for (int level = 0; level < 6; level++) {
        size_t used = 0;
        for (int k = 0; k < 8; k++)
            used += (size_t)snprintf(text + used, sizeof text - used, "@include \"wide%d.cfg\"\n", level + 1);
        snprintf(name, sizeof name, "wide%d.cfg", level);
        write_file(name, text);
    }
    write_file("wide6.cfg", "# leaf\n");
    p = write_file("wide.cfg", "scene = \"m.obj\";\n@include \"wide0.cfg\"\n");
    expect_error(__LINE__, p, NULL, "@include \"wide", "include each file once", NULL);
    CHECK(rtk_config_files_read() <= 8);

    p = write_file("self.cfg", "scene = \"m.obj\";\n@include \"self.cfg\"\n@include \"self.cfg\"\n");
    expect_error(__LINE__, p, NULL, "self.cfg:2", "@include \"self.cfg\" includes itself", NULL);
    write_file("ring_a.cfg", "@include \"ring_b.cfg\"\n");
    write_file("ring_b.cfg", "# b\n@include \"ring_a.cfg\"\n");
    p = write_file("ring.cfg", "scene = \"m.obj\";\n@include \"ring_a.cfg\"\n");
    expect_error(__LINE__, p, NULL, "ring_b.cfg:2", "@include \"ring_a.cfg\" includes itself", NULL);

    for (int level = 0; level < 11; level++) {
        snprintf(text, sizeof text, "@include \"deep%d.cfg\"\n", level + 1);
        snprintf(name, sizeof name, "deep%d.cfg", level);
        write_file(name, text);
    }
    write_file("deep11.cfg", "# leaf\n");
    p = write_file("deep.cfg", "scene = \"m.obj\";\n@include \"deep0.cfg\"\n");
    expect_error(__LINE__, p, NULL, "deep9.cfg:1", "nests includes more than 10 deep", NULL);
    p = write_file("deep_ok.cfg", "scene = \"m.obj\";\n@include \"deep2.cfg\"\n");
    rtk_config_destroy(expect_ok(__LINE__, p, NULL));

    char dir[512];
    snprintf(dir, sizeof dir, "%s/incdir", tmpdir);
    mkdir(dir, 0755);
    p = write_file("inc_dir.cfg", "scene = \"m.obj\";\n\n@include \"incdir\"\n");
    expect_error(__LINE__, p, NULL, "inc_dir.cfg:3", "incdir is a directory, not a config file", NULL);
    p = write_file("inc_none.cfg", "scene = \"m.obj\";\n@include \"none.cfg\"\n");
    expect_error(__LINE__, p, NULL, "inc_none.cfg:2", "none.cfg: No such file", NULL);
}

static void test_paths(void)
{
    char sub[512];
    snprintf(sub, sizeof sub, "%s/sub", tmpdir);
    mkdir(sub, 0755);
    const char *p = write_file("sub/rel.cfg", "scene = \"../models/a.obj\";\nfilm = { output = \"img.png\"; };\n");
    rtk_config *cfg = expect_ok(__LINE__, p, NULL);
    if (cfg) {
        char want[600];
        snprintf(want, sizeof want, "%s/sub/../models/a.obj", tmpdir);
        CHECK(strcmp(cfg->scene_path, want) == 0);
        snprintf(want, sizeof want, "%s/sub/img.png", tmpdir);
        CHECK(strcmp(cfg->output, want) == 0);
        rtk_config_destroy(cfg);
    }

    write_file("sub/part.cfg", "film = {\n  spp = 0;\n};\n");
    p = write_file("sub/main.cfg", "scene = \"m.obj\";\n@include \"part.cfg\"\n");
    expect_error(__LINE__, p, NULL, "sub/part.cfg:2", "spp = 0", NULL);
}

/* Every config in scenes/bad/ must fail; its first line reads
 * "// expect: <text>" and the error must contain the file name and text. */
static void test_bad_scenes(void)
{
    const char *dir = TEST_DIR "/../../scenes/bad";
    DIR *d = opendir(dir);
    CHECK(d != NULL);
    if (!d)
        return;
    int seen = 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        size_t n = strlen(e->d_name);
        if (n < 5 || strcmp(e->d_name + n - 4, ".cfg") != 0)
            continue;
        char path[1024], line[512] = "";
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        FILE *f = fopen(path, "r");
        if (!f || !fgets(line, sizeof line, f)) {
            if (f)
                fclose(f);
            CHECK(!"unreadable scenes/bad file");
            continue;
        }
        fclose(f);
        line[strcspn(line, "\r\n")] = '\0';
        const char *tag = "// expect: ";
        CHECK(strncmp(line, tag, strlen(tag)) == 0);
        char where[300];
        snprintf(where, sizeof where, "%s:", e->d_name);
        expect_error(__LINE__, path, NULL, where, line + strlen(tag), NULL);
        seen++;
    }
    closedir(d);
    CHECK(seen > 0);
}

/* Writes a width x height RGB (nchannels 3) or grey (1) EXR of value v
 * into the temporary directory. */
static void write_map(const char *name, int nchannels, float v)
{
    float px[4 * 2 * 3];
    for (int i = 0; i < 24; i++)
        px[i] = i == 4 ? v : 0.5f;
    static const char *const rgb[] = {"R", "G", "B"}, *const grey[] = {"Y"};
    char path[512];
    snprintf(path, sizeof path, "%s/%s", tmpdir, name);
    CHECK(rtk_image_write(path, 4, 2, nchannels, nchannels == 3 ? rgb : grey, px, 0) == RTK_OK);
}

/* Loads the scene of config path with needs and expects every string
 * after needs in the error (none: success, and an environment exactly
 * when needs has RTK_NEED_LIGHTS). */
static void expect_scene(int line, const char *path, uint32_t needs, ...)
{
    rtk_config *cfg = expect_ok(line, path, NULL);
    if (!cfg)
        return;
    rtk_scene *scene = NULL;
    rtk_status st = rtk_config_load_scene(cfg, needs, &scene);
    va_list ap;
    va_start(ap, needs);
    const char *needle = va_arg(ap, const char *);
    checks++;
    if (!needle && (st != RTK_OK || (scene->lights && scene->lights->environment) != !!(needs & RTK_NEED_LIGHTS))) {
        failures++;
        fprintf(stderr, "%s:%d: %s: scene %s: %s\n", __FILE__, line, path, st ? "failed" : "loaded with the wrong environment",
                st ? rtk_error_message() : "");
    } else if (needle && (st == RTK_OK || scene)) {
        failures++;
        fprintf(stderr, "%s:%d: %s: scene loaded, expected an error\n", __FILE__, line, path);
    }
    for (; needle && st != RTK_OK; needle = va_arg(ap, const char *)) {
        checks++;
        if (!strstr(rtk_error_message(), needle)) {
            failures++;
            fprintf(stderr, "%s:%d: error lacks \"%s\":\n  %s\n", __FILE__, line, needle, rtk_error_message());
        }
    }
    va_end(ap);
    rtk_scene_free(scene);
    rtk_config_destroy(cfg);
}

/* The environment group: a file or a colour, and each way to get it wrong. */
static void test_environment(void)
{
    write_file("tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    write_map("sky.exr", 3, 2.0f);
    const char *p = write_file("env.cfg", "scene = \"tri.obj\";\nenvironment = { file = \"sky.exr\"; strength = 2.5;\n"
                                          "  rotation = -30; };\n");
    rtk_config *cfg = expect_ok(__LINE__, p, NULL);
    if (cfg) {
        CHECK(cfg->environment.given && ends_with(cfg->environment.file, "/sky.exr"));
        CHECK(cfg->environment.strength == 2.5f && cfg->environment.rotation == -30.0f);
        rtk_config_destroy(cfg);
    }
    expect_scene(__LINE__, p, RTK_NEED_LIGHTS, NULL);
    expect_scene(__LINE__, p, 0, NULL);
    p = write_file("env_color.cfg", "scene = \"tri.obj\";\nenvironment = { color = [0.5, 1.0, 2.0]; };\n");
    cfg = expect_ok(__LINE__, p, NULL);
    if (cfg) {
        CHECK(cfg->environment.given && !cfg->environment.file && cfg->environment.strength == 1.0f);
        CHECK(cfg->environment.color.r == 0.5f && cfg->environment.color.g == 1.0f && cfg->environment.color.b == 2.0f);
        rtk_config_destroy(cfg);
    }
    expect_scene(__LINE__, p, RTK_NEED_LIGHTS, NULL);

    p = write_file("env_both.cfg", "scene = \"tri.obj\";\nenvironment = { file = \"sky.exr\";\n color = [1, 1, 1]; };\n");
    expect_error(__LINE__, p, NULL, "env_both.cfg:3", "both file and color", "keep one", NULL);
    p = write_file("env_none.cfg", "scene = \"tri.obj\";\nenvironment = { strength = 2.0; };\n");
    expect_error(__LINE__, p, NULL, "env_none.cfg:2", "environment: give file", "color = [r, g, b]", NULL);
    p = write_file("env_missing.cfg", "scene = \"tri.obj\";\nenvironment = {\n file = \"nosky.exr\"; };\n");
    expect_error(__LINE__, p, NULL, "env_missing.cfg:3", "environment: file", "nosky.exr", "cannot be read",
                 "relative to the config's folder", NULL);
    p = write_file("env_key.cfg", "scene = \"tri.obj\";\nenvironment = { file = \"sky.exr\";\n strenght = 2.0; };\n");
    expect_error(__LINE__, p, NULL, "env_key.cfg:3", "unknown key 'strenght'", "did you mean 'strength'", NULL);
    p = write_file("env_neg.cfg", "scene = \"tri.obj\";\nenvironment = { color = [1, -1, 1]; };\n");
    expect_error(__LINE__, p, NULL, "env_neg.cfg:2", "negative", NULL);
    p = write_file("env_strength.cfg", "scene = \"tri.obj\";\nenvironment = { color = [1, 1, 1]; strength = -1; };\n");
    expect_error(__LINE__, p, NULL, "env_strength.cfg:2", "strength", "out of range", NULL);
    p = write_file("env_string.cfg", "scene = \"tri.obj\";\nenvironment = \"sky.exr\";\n");
    expect_error(__LINE__, p, NULL, "env_string.cfg:2", "expected a group like environment = { file", NULL);
    p = write_file("env_dir.cfg", "scene = \"tri.obj\";\nenvironment = { file = \".\"; };\n");
    expect_error(__LINE__, p, NULL, "env_dir.cfg:2", "is not a regular file", NULL);

    /* Pixels are read with the scene, when the integrator wants lights. */
    write_map("nan.exr", 3, NAN);
    p = write_file("env_nan.cfg", "scene = \"tri.obj\";\n\nenvironment = { file = \"nan.exr\"; };\n");
    expect_scene(__LINE__, p, RTK_NEED_LIGHTS, "env_nan.cfg:3: environment", "nan.exr", "pixel (1, 0) channel 1 is nan",
                 "fix or clamp", NULL);
    expect_scene(__LINE__, p, 0, NULL);
    write_map("neg.exr", 3, -2.0f);
    p = write_file("env_negpx.cfg", "scene = \"tri.obj\";\nenvironment = { file = \"neg.exr\"; };\n");
    expect_scene(__LINE__, p, RTK_NEED_LIGHTS, "env_negpx.cfg:2: environment", "is -2", NULL);
    write_map("grey.exr", 1, 1.0f);
    p = write_file("env_grey.cfg", "scene = \"tri.obj\";\nenvironment = { file = \"grey.exr\"; };\n");
    expect_scene(__LINE__, p, RTK_NEED_LIGHTS, "env_grey.cfg:2: environment", "has 1 channel", "RGB (3) or RGBA (4)",
                 NULL);
    p = write_file("notimage.exr", "this is not an image\n");
    p = write_file("env_text.cfg", "scene = \"tri.obj\";\nenvironment = { file = \"notimage.exr\"; };\n");
    expect_scene(__LINE__, p, RTK_NEED_LIGHTS, "env_text.cfg:2: environment", "notimage.exr", NULL);
}

/* Removes the temporary tree (files and one level of directories). */
static void remove_tree(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0)
            continue;
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        struct stat st;
        if (lstat(path, &st) == 0 && S_ISDIR(st.st_mode))
            remove_tree(path);
        else
            unlink(path);
    }
    closedir(d);
    rmdir(dir);
}

int main(void)
{
    const char *base = getenv("TMPDIR");
    snprintf(tmpdir, sizeof tmpdir, "%s/rtk-test-config-XXXXXX", base && base[0] ? base : "/tmp");
    if (!mkdtemp(tmpdir)) {
        perror("mkdtemp");
        return 1;
    }
    if (rtk_registry_create(&registry) != RTK_OK) {
        fprintf(stderr, "registry: %s\n", rtk_error_message());
        remove_tree(tmpdir);
        return 1;
    }
    test_minimal();
    test_full();
    test_errors();
    test_int_literals();
    test_plugins();
    test_overrides();
    test_all_errors();
    test_threads_limit();
    test_inf();
    test_string_places();
    test_includes();
    test_paths();
    test_bad_scenes();
    test_environment();
    rtk_registry_destroy(registry);
    remove_tree(tmpdir);
    printf("%d checks, %d failed\n", checks, failures);
    return failures ? 1 : 0;
}

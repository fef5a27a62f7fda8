/* Tests for kernel/image/image_module.cpp and kernel/scene/texture.c: exact round trips,
 * channel names, atomic writes, sRGB decoding, texture lookups and broken
 * or hostile files. Files go to a fresh directory under $TMPDIR. */
#include "config/config.h"
#include "render/render.h"
#include "image/image.h"
#include "oiio_check.h"

#include <dirent.h>
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static int failures;
static char scratch[512];

#define CHECK(cond, ...)                                                                           \
    do {                                                                                           \
        if (!(cond)) {                                                                             \
            failures++;                                                                            \
            fprintf(stderr, "FAIL %s:%d: %s: ", __FILE__, __LINE__, #cond);                        \
            fprintf(stderr, __VA_ARGS__);                                                          \
            fputc('\n', stderr);                                                                   \
        }                                                                                          \
    } while (0)

/* scratch/name in a static buffer (one live result per slot). */
static const char *file_in(int slot, const char *name)
{
    static char paths[4][1024];
    snprintf(paths[slot], sizeof paths[slot], "%s/%s", scratch, name);
    return paths[slot];
}

static char *read_whole(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *data = malloc(n > 0 ? (size_t)n : 1);
    if (data && fread(data, 1, (size_t)n, f) != (size_t)n) {
        free(data);
        data = NULL;
    }
    fclose(f);
    *size = (size_t)n;
    return data;
}

static int write_whole(const char *path, const void *data, size_t size)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return 0;
    int ok = fwrite(data, 1, size, f) == size;
    return fclose(f) == 0 && ok;
}

/* Number of entries in scratch whose name contains ".tmp". */
static int count_temp_files(void)
{
    DIR *d = opendir(scratch);
    int n = 0;
    struct dirent *e;
    while (d && (e = readdir(d)) != NULL)
        if (strstr(e->d_name, ".tmp"))
            n++;
    if (d)
        closedir(d);
    return n;
}

static double srgb_encode(double l)
{
    return l <= 0.0031308 ? 12.92 * l : 1.055 * pow(l, 1.0 / 2.4) - 0.055;
}

static double srgb_decode(double c)
{
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

/* A w x h x n image whose values differ per pixel and channel. */
static float *make_pixels(int w, int h, int n)
{
    float *p = malloc(sizeof(float) * (size_t)(w * h * n));
    for (int i = 0; i < w * h * n; i++)
        p[i] = (float)((i * 37 % 101) / 100.0);
    return p;
}

/* Whether the image module (OpenImageIO) is mapped into this process. */
static int module_loaded(void)
{
    FILE *f = fopen("/proc/self/maps", "r");
    char line[4096];
    int loaded = 0;
    while (f && !loaded && fgets(line, sizeof line, f))
        loaded = strstr(line, "rtk_image.so") != NULL;
    if (f)
        fclose(f);
    return loaded;
}

/* PNG and EXR are written by the kernel itself: without loading the image
 * module, the same image twice to the same bytes, with OpenImageIO's
 * default channel names. Runs before anything reads an image. */
static void test_builtin_writers(void)
{
    const int w = 5, h = 4;
    float *px = make_pixels(w, h, 5);
    const char *names[2][2] = {{"a.exr", "b.EXR"}, {"a.png", "b.PNG"}};
    for (int f = 0; f < 2; f++) {
        for (int k = 0; k < 2; k++)
            CHECK(rtk_image_write(file_in(k, names[f][k]), w, h, 3, NULL, px, f == 0) == RTK_OK, "%s: %s",
                  names[f][k], rtk_error_message());
        size_t size_a = 0, size_b = 0;
        char *a = read_whole(file_in(0, names[f][0]), &size_a);
        char *b = read_whole(file_in(1, names[f][1]), &size_b);
        CHECK(a && b && size_a > 0 && size_a == size_b && memcmp(a, b, size_a) == 0,
              "%s and %s: the same image written twice differs (%zu and %zu bytes)", names[f][0], names[f][1],
              size_a, size_b);
        free(a);
        free(b);
    }
    CHECK(rtk_image_write(file_in(0, "grey.exr"), w, h, 1, NULL, px, 0) == RTK_OK, "%s", rtk_error_message());
    CHECK(rtk_image_write(file_in(1, "five.exr"), w, h, 5, NULL, px, 0) == RTK_OK, "%s", rtk_error_message());
    CHECK(!module_loaded(), "writing PNG and EXR loaded the image module");
    char got[256], format[32];
    float value = -1.0f;
    int n = check_exr_channels(file_in(0, "grey.exr"), got, sizeof got, "Y", 3, 2, &value, format, sizeof format);
    CHECK(n == 1 && strcmp(got, "Y") == 0 && value == px[2 * w + 3], "one channel: %d named %s, Y %g", n, got,
          value);
    n = check_exr_channels(file_in(1, "five.exr"), got, sizeof got, "channel4", 1, 3, &value, format, sizeof format);
    CHECK(n == 5 && strcmp(got, "R,G,B,A,channel4") == 0 && value == px[(3 * w + 1) * 5 + 4],
          "five channels: %d named %s, channel4 %g", n, got, value);
    free(px);
}

static void test_exr_float_roundtrip(void)
{
    const int w = 7, h = 5;
    float *px = make_pixels(w, h, 4);
    px[0] = -2.5f;
    px[5] = 1234.5678f;
    px[6] = 1e-30f;
    px[7] = 3.0e38f;
    const char *names[] = {"R", "G", "B", "A"};
    const char *path = file_in(0, "float.exr");
    rtk_status s = rtk_image_write(path, w, h, 4, names, px, 0);
    CHECK(s == RTK_OK, "%s", rtk_error_message());
    rtk_image img;
    s = rtk_image_read(path, NULL, 0, 1, &img);
    CHECK(s == RTK_OK, "%s", rtk_error_message());
    if (s == RTK_OK) {
        CHECK(img.width == w && img.height == h, "size %dx%d", img.width, img.height);
        int exact = 1;
        for (int i = 0; i < w * h * 4; i++)
            exact &= memcmp(&img.rgba[i], &px[i], sizeof(float)) == 0;
        CHECK(exact, "float EXR did not round-trip bit for bit");
        free(img.rgba);
    }
    free(px);
}

static void test_exr_half_roundtrip(void)
{
    const int w = 6, h = 4;
    float *px = make_pixels(w, h, 3);
    px[0] = 0.0f;
    px[1] = 1000.123f;
    px[2] = 0.000123f;
    px[3] = -7.77f;
    const char *path = file_in(0, "half.exr");
    rtk_status s = rtk_image_write(path, w, h, 3, NULL, px, 1);
    CHECK(s == RTK_OK, "%s", rtk_error_message());
    char names[256], format[32];
    int n = check_exr_channels(path, names, sizeof names, NULL, 0, 0, NULL, format, sizeof format);
    CHECK(n == 3 && strcmp(format, "half") == 0, "channels %d format %s", n, format);
    rtk_image img;
    s = rtk_image_read(path, NULL, 0, 1, &img);
    CHECK(s == RTK_OK, "%s", rtk_error_message());
    if (s == RTK_OK) {
        double worst = 0.0;
        for (int i = 0; i < w * h; i++) {
            for (int c = 0; c < 3; c++) {
                double want = px[3 * i + c], got = img.rgba[4 * i + c];
                double err = fabs(got - want) / fmax(fabs(want), 6.103515625e-05);
                if (err > worst)
                    worst = err;
            }
            CHECK(img.rgba[4 * i + 3] == 1.0f, "alpha %g", img.rgba[4 * i + 3]);
        }
        CHECK(worst <= ldexp(1.0, -11), "half error %g over half an ulp", worst);
        free(img.rgba);
    }
    free(px);
}

static void test_png_roundtrip(void)
{
    const int w = 9, h = 3;
    float *px = make_pixels(w, h, 4);
    px[0] = -1.0f;     /* clamps to 0 */
    px[1] = 7.0f;      /* clamps to 1 */
    px[2] = NAN;       /* becomes 0 */
    px[3] = 0.001f;    /* linear segment of the sRGB curve */
    const char *path = file_in(0, "rgb.png");
    rtk_status s = rtk_image_write(path, w, h, 4, NULL, px, 0);
    CHECK(s == RTK_OK, "%s", rtk_error_message());
    rtk_image raw, lin;
    CHECK(rtk_image_read(path, NULL, 0, 0, &raw) == RTK_OK, "%s", rtk_error_message());
    CHECK(rtk_image_read(path, NULL, 0, 1, &lin) == RTK_OK, "%s", rtk_error_message());
    if (raw.rgba && lin.rgba) {
        double worst_code = 0.0, worst_linear = 0.0;
        for (int i = 0; i < w * h; i++) {
            for (int c = 0; c < 3; c++) {
                double v = px[4 * i + c];
                v = v > 0.0 ? (v < 1.0 ? v : 1.0) : 0.0;
                double code = srgb_encode(v);
                double err = fabs(raw.rgba[4 * i + c] - code);
                if (err > worst_code)
                    worst_code = err;
                double back = srgb_decode(raw.rgba[4 * i + c]);
                double lerr = fabs(lin.rgba[4 * i + c] - back);
                if (lerr > worst_linear)
                    worst_linear = lerr;
                CHECK(fabs(srgb_encode(lin.rgba[4 * i + c]) - code) <= 1.0 / 255.0,
                      "pixel %d channel %d: %g vs %g", i, c, lin.rgba[4 * i + c], v);
            }
            CHECK(lin.rgba[4 * i + 3] == 1.0f, "alpha of an RGB PNG %g", lin.rgba[4 * i + 3]);
        }
        CHECK(worst_code <= 0.5 / 255.0 + 1e-7, "8-bit code off by %g", worst_code * 255.0);
        CHECK(worst_linear <= 1e-7, "decode differs from the sRGB EOTF by %g", worst_linear);
        CHECK(raw.rgba[0] == 0.0f && raw.rgba[1] == 1.0f && raw.rgba[2] == 0.0f,
              "clamping gave %g %g %g", raw.rgba[0], raw.rgba[1], raw.rgba[2]);
    }
    free(raw.rgba);
    free(lin.rgba);
    free(px);
}

static void test_aov_channel_names(void)
{
    static const char *const names[] = {"R",        "G",        "B",   "albedo.R", "albedo.G",
                                        "albedo.B", "N.X",      "N.Y", "N.Z",      "Z"};
    const int w = 3, h = 2, n = 10;
    float *px = malloc(sizeof(float) * (size_t)(w * h * n));
    for (int i = 0; i < w * h * n; i++)
        px[i] = (float)(i % n) + 0.25f * (float)(i / n);
    const char *path = file_in(0, "aov.exr");
    rtk_status s = rtk_image_write(path, w, h, n, names, px, 0);
    CHECK(s == RTK_OK, "%s", rtk_error_message());
    char got[512], format[32];
    int count = check_exr_channels(path, got, sizeof got, NULL, 0, 0, NULL, format, sizeof format);
    CHECK(count == n, "%d channels: %s", count, got);
    for (int c = 0; c < n; c++) {
        char want[64];
        snprintf(want, sizeof want, ",%s,", names[c]);
        char padded[520];
        snprintf(padded, sizeof padded, ",%s,", got);
        CHECK(strstr(padded, want) != NULL, "channel %s missing from %s", names[c], got);
        float value = -1.0f;
        check_exr_channels(path, got, sizeof got, names[c], 2, 1, &value, format, sizeof format);
        int pixel = 1 * w + 2;
        CHECK(value == px[pixel * n + c], "channel %s at (2,1) is %g, wrote %g", names[c], value,
              px[pixel * n + c]);
    }
    CHECK(strcmp(format, "float") == 0, "format %s", format);
    rtk_image img;
    s = rtk_image_read(path, NULL, 0, 1, &img);
    CHECK(s == RTK_OK, "%s", rtk_error_message());
    if (s == RTK_OK) {
        int pixel = 1 * w + 2;
        CHECK(img.rgba[4 * pixel] == px[pixel * n] && img.rgba[4 * pixel + 2] == px[pixel * n + 2] &&
                  img.rgba[4 * pixel + 3] == 1.0f,
              "AOV EXR read as rgba %g %g %g %g", img.rgba[4 * pixel], img.rgba[4 * pixel + 1],
              img.rgba[4 * pixel + 2], img.rgba[4 * pixel + 3]);
        free(img.rgba);
    }
    static const char *const twice[] = {"R", "G", "R"};
    s = rtk_image_write(file_in(0, "twice.exr"), w, h, 3, twice, px, 0);
    CHECK(s == RTK_ERR_INVALID && strstr(rtk_error_message(), "'R'"), "duplicate names: %d %s", s,
          rtk_error_message());
    free(px);
}

static void test_atomic_write(void)
{
    float px[12] = {0.1f, 0.2f, 0.3f, 0.4f, 0.5f, 0.6f, 0.7f, 0.8f, 0.9f, 1.0f, 0.0f, 0.5f};
    const char *path = file_in(0, "no/such/dir/out.png");
    rtk_status s = rtk_image_write(path, 2, 2, 3, NULL, px, 0);
    CHECK(s == RTK_ERR_IO, "status %d", s);
    CHECK(strstr(rtk_error_message(), path) != NULL, "message does not name the path: %s",
          rtk_error_message());
    CHECK(count_temp_files() == 0, "a temporary file was left behind");

    const char *old = file_in(0, "old.xyz");
    CHECK(write_whole(old, "keep me", 7), "cannot create %s", old);
    s = rtk_image_write(old, 2, 2, 3, NULL, px, 0);
    CHECK(s == RTK_ERR_UNSUPPORTED, "status %d", s);
    CHECK(strstr(rtk_error_message(), old) && strstr(rtk_error_message(), ".exr"),
          "message should name the file and list formats: %s", rtk_error_message());
    size_t size = 0;
    char *kept = read_whole(old, &size);
    CHECK(kept && size == 7 && memcmp(kept, "keep me", 7) == 0, "existing file was changed");
    free(kept);

    s = rtk_image_write(file_in(0, "noext"), 2, 2, 3, NULL, px, 0);
    CHECK(s == RTK_ERR_UNSUPPORTED && strstr(rtk_error_message(), "extension"), "no extension: %s",
          rtk_error_message());

    const char *over = file_in(1, "over.png");
    CHECK(write_whole(over, "old", 3), "cannot create %s", over);
    s = rtk_image_write(over, 2, 2, 3, NULL, px, 0);
    CHECK(s == RTK_OK, "%s", rtk_error_message());
    rtk_image img;
    CHECK(rtk_image_read(over, NULL, 0, 0, &img) == RTK_OK && img.width == 2,
          "overwritten file does not read back: %s", rtk_error_message());
    free(img.rgba);

    const char *dir = file_in(0, "dir.png");
    CHECK(mkdir(dir, 0700) == 0, "cannot create %s", dir);
    s = rtk_image_write(dir, 2, 2, 3, NULL, px, 0);
    CHECK(s == RTK_ERR_IO && strstr(rtk_error_message(), dir), "writing over a directory: %d %s", s,
          rtk_error_message());
    rmdir(dir);
    CHECK(rtk_image_write(file_in(0, "out.jpg"), 2, 2, 3, NULL, px, 0) == RTK_OK, "%s",
          rtk_error_message());
    CHECK(rtk_image_write(file_in(0, "out.hdr"), 2, 2, 3, NULL, px, 0) == RTK_OK, "%s",
          rtk_error_message());
    CHECK(rtk_image_write(file_in(0, "out.tif"), 2, 2, 3, NULL, px, 0) == RTK_OK, "%s",
          rtk_error_message());
    CHECK(rtk_image_write(file_in(0, "bad.png"), 0, 2, 3, NULL, px, 0) == RTK_ERR_INVALID, "zero width");
    CHECK(count_temp_files() == 0, "a temporary file was left behind");
}

static void test_srgb_decode(void)
{
    unsigned char rgb[6] = {128, 0, 255, 1, 10, 11};
    const char *path = file_in(0, "u8.png");
    CHECK(check_write_u8(path, 2, 1, 3, rgb), "cannot write %s", path);
    rtk_image img;
    CHECK(rtk_image_read(path, NULL, 0, 1, &img) == RTK_OK, "%s", rtk_error_message());
    if (img.rgba) {
        CHECK(fabsf(img.rgba[0] - 0.2158605f) <= 1e-7f, "128 decodes to %.9g", img.rgba[0]);
        CHECK(img.rgba[1] == 0.0f && img.rgba[2] == 1.0f, "0 and 255 decode to %g %g", img.rgba[1],
              img.rgba[2]);
        CHECK(img.rgba[4] == (float)(1.0 / 255.0 / 12.92), "1 decodes to %.9g", img.rgba[4]);
        CHECK(img.rgba[3] == 1.0f, "alpha %g", img.rgba[3]);
        free(img.rgba);
    }
    CHECK(rtk_image_read(path, NULL, 0, 0, &img) == RTK_OK, "%s", rtk_error_message());
    if (img.rgba) {
        CHECK(img.rgba[0] == (float)(128.0 / 255.0), "non-colour 128 reads %.9g", img.rgba[0]);
        free(img.rgba);
    }

    unsigned char gray[2] = {128, 64};
    path = file_in(0, "gray.png");
    CHECK(check_write_u8(path, 2, 1, 1, gray), "cannot write %s", path);
    CHECK(rtk_image_read(path, NULL, 0, 1, &img) == RTK_OK, "%s", rtk_error_message());
    if (img.rgba) {
        CHECK(img.rgba[0] == img.rgba[1] && img.rgba[1] == img.rgba[2] &&
                  fabsf(img.rgba[0] - 0.2158605f) <= 1e-7f && img.rgba[3] == 1.0f,
              "gray expands to %g %g %g %g", img.rgba[0], img.rgba[1], img.rgba[2], img.rgba[3]);
        free(img.rgba);
    }

    unsigned char ga[4] = {128, 128, 255, 0};
    path = file_in(0, "gray_alpha.png");
    CHECK(check_write_u8(path, 2, 1, 2, ga), "cannot write %s", path);
    CHECK(rtk_image_read(path, NULL, 0, 1, &img) == RTK_OK, "%s", rtk_error_message());
    if (img.rgba) {
        CHECK(fabsf(img.rgba[0] - 0.2158605f) <= 1e-7f && img.rgba[3] == (float)(128.0 / 255.0),
              "gray+alpha expands to %g %g %g %g", img.rgba[0], img.rgba[1], img.rgba[2], img.rgba[3]);
        CHECK(img.rgba[4] == 1.0f && img.rgba[7] == 0.0f,
              "colour under zero alpha must stay unpremultiplied: %g %g", img.rgba[4], img.rgba[7]);
        free(img.rgba);
    }

    unsigned char rgba[8] = {128, 255, 0, 0, 255, 255, 255, 128};
    path = file_in(0, "rgba.png");
    CHECK(check_write_u8(path, 2, 1, 4, rgba), "cannot write %s", path);
    CHECK(rtk_image_read(path, NULL, 0, 1, &img) == RTK_OK, "%s", rtk_error_message());
    if (img.rgba) {
        CHECK(fabsf(img.rgba[0] - 0.2158605f) <= 1e-7f && img.rgba[1] == 1.0f && img.rgba[3] == 0.0f,
              "rgba pixel 0: %g %g %g %g", img.rgba[0], img.rgba[1], img.rgba[2], img.rgba[3]);
        CHECK(img.rgba[4] == 1.0f && img.rgba[7] == (float)(128.0 / 255.0), "rgba pixel 1: %g %g",
              img.rgba[4], img.rgba[7]);
        free(img.rgba);
    }
}

/* 16-bit data, and the file's own colour space winning over the caller's
 * "this is sRGB colour": a linear PNG is not decoded, a gamma one uses it. */
static void test_colour_metadata(void)
{
    const uint16_t px[3] = {32768, 0, 65535};
    const double code = 32768.0 / 65535.0;
    static const struct {
        const char *file, *space;
    } cases[] = {
        {"srgb16.png", NULL},
        {"linear16.png", "linear"},
        {"gamma16.png", "GammaCorrected2.2"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        double want = i == 0 ? srgb_decode(code) : i == 1 ? code : pow(code, 2.2);
        const char *path = file_in(0, cases[i].file);
        CHECK(check_write_raw(path, 1, 1, 3, 16, cases[i].space, px), "cannot write %s", path);
        rtk_image img;
        CHECK(rtk_image_read(path, NULL, 0, 1, &img) == RTK_OK, "%s", rtk_error_message());
        if (img.rgba) {
            CHECK(img.rgba[0] == (float)want && img.rgba[1] == 0.0f && img.rgba[2] == 1.0f &&
                      img.rgba[3] == 1.0f,
                  "%s: 32768 decodes to %.9g, want %.9g", cases[i].file, img.rgba[0], want);
            free(img.rgba);
        }
        CHECK(rtk_image_read(path, NULL, 0, 0, &img) == RTK_OK, "%s", rtk_error_message());
        if (img.rgba) {
            CHECK(img.rgba[0] == (float)code, "%s as data reads %.9g", cases[i].file, img.rgba[0]);
            free(img.rgba);
        }
    }
}

static void test_read_errors(void)
{
    rtk_image img;
    const char *missing = file_in(0, "missing.png");
    rtk_status s = rtk_image_read(missing, NULL, 0, 1, &img);
    CHECK(s == RTK_ERR_IO && strstr(rtk_error_message(), missing), "missing file: %d %s", s,
          rtk_error_message());
    CHECK(img.rgba == NULL && img.width == 0, "output not cleared");

    const char *junk = file_in(0, "junk.png");
    write_whole(junk, "this is not an image at all", 27);
    s = rtk_image_read(junk, NULL, 0, 1, &img);
    CHECK(s == RTK_ERR_PARSE && strstr(rtk_error_message(), junk), "junk file: %d %s", s,
          rtk_error_message());

    s = rtk_image_read(scratch, NULL, 0, 1, &img);
    CHECK(s == RTK_ERR_IO, "directory: %d %s", s, rtk_error_message());

    float *px = make_pixels(64, 64, 3);
    const char *whole = file_in(0, "whole.png");
    CHECK(rtk_image_write(whole, 64, 64, 3, NULL, px, 0) == RTK_OK, "%s", rtk_error_message());
    free(px);
    size_t size = 0;
    char *data = read_whole(whole, &size);
    const char *cut = file_in(1, "truncated.png");
    CHECK(data && write_whole(cut, data, size / 2), "cannot write %s", cut);
    s = rtk_image_read(cut, NULL, 0, 1, &img);
    CHECK(s == RTK_ERR_PARSE && strstr(rtk_error_message(), cut), "truncated PNG: %d %s", s,
          rtk_error_message());
    CHECK(img.rgba == NULL, "truncated PNG returned pixels");

    s = rtk_image_read("glb image 1", data, size / 2, 1, &img);
    CHECK(s == RTK_ERR_PARSE && strstr(rtk_error_message(), "glb image 1"), "truncated bytes: %d %s", s,
          rtk_error_message());
    s = rtk_image_read("glb image 2", "garbage!", 8, 1, &img);
    CHECK(s == RTK_ERR_PARSE && strstr(rtk_error_message(), "glb image 2"), "garbage bytes: %d %s", s,
          rtk_error_message());
    s = rtk_image_read("glb image 3", data, 0, 1, &img);
    CHECK(s == RTK_ERR_PARSE, "empty bytes: %d %s", s, rtk_error_message());
    for (size_t n = 1; n < size; n = n * 3 / 2 + 1) {
        s = rtk_image_read("glb prefix", data, n, 1, &img);
        CHECK(s != RTK_OK, "a %zu-byte prefix of a PNG decoded", n);
    }
    free(data);
}

/* PFM, which the kernel writes itself: the exact header and floats (rows
 * from the bottom, little-endian), read back exactly through the image
 * module; 1 and 3 channels only; damaged files refused, naming the fault. */
static void test_pfm(void)
{
    const int w = 5, h = 3;
    float *px = make_pixels(w, h, 3);
    px[0] = -2.5f, px[1] = 1e-30f, px[2] = 65504.5f;
    const char *path = file_in(0, "out.pfm");
    CHECK(rtk_image_write(path, w, h, 3, NULL, px, 0) == RTK_OK, "%s", rtk_error_message());
    size_t size = 0;
    char *data = read_whole(path, &size);
    const char header[] = "PF\n5 3\n-1.0\n";
    const size_t hl = sizeof header - 1;
    CHECK(data && size == hl + (size_t)w * h * 3 * 4 && memcmp(data, header, hl) == 0, "PFM header or size (%zu)",
          size);
    int exact = data != NULL && size == hl + (size_t)w * h * 3 * 4;
    for (int y = 0; exact && y < h; y++)
        for (int i = 0; i < w * 3; i++) {
            const unsigned char *b = (const unsigned char *)data + hl + 4 * ((size_t)(h - 1 - y) * w * 3 + i);
            uint32_t bits = (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24;
            float v;
            memcpy(&v, &bits, 4);
            exact &= memcmp(&v, &px[(size_t)y * w * 3 + i], 4) == 0;
        }
    CHECK(exact, "PFM floats differ from the pixels (rows bottom-up, little-endian)");
    rtk_image img;
    CHECK(rtk_image_read(path, NULL, 0, 0, &img) == RTK_OK, "%s", rtk_error_message());
    int same = img.rgba && img.width == w && img.height == h && img.channels == 3;
    for (int i = 0; same && i < w * h; i++)
        for (int c = 0; c < 3; c++)
            same &= memcmp(&img.rgba[4 * i + c], &px[3 * i + c], 4) == 0;
    CHECK(same, "the PFM read back differs (%dx%d, %d channels)", img.width, img.height, img.channels);
    free(img.rgba);

    const char *grey = file_in(1, "grey.pfm");
    CHECK(rtk_image_write(grey, w, h, 1, NULL, px, 0) == RTK_OK, "%s", rtk_error_message());
    char *g = read_whole(grey, &size);
    CHECK(g && size == 12 + (size_t)w * h * 4 && memcmp(g, "Pf\n5 3\n-1.0\n", 12) == 0, "grey PFM header");
    free(g);
    rtk_status s = rtk_image_write(file_in(1, "aovs.PFM"), w, h, 10, NULL, px, 0);
    CHECK(s == RTK_ERR_INVALID && strstr(rtk_error_message(), "a PFM holds 1 or 3 channels"), "10 channels: %d %s",
          s, rtk_error_message());
    s = rtk_image_write(file_in(1, "empty.pfm"), 0, h, 3, NULL, px, 0);
    CHECK(s == RTK_ERR_INVALID, "zero width: %d %s", s, rtk_error_message());

    static const struct {
        const char *name, *text, *fault;
    } broken[] = {
        {"cut.pfm", NULL, "is truncated: it ends before its last pixel"},
        {"scale0.pfm", "PF\n5 3\n0\n", "its scale"},
        {"scalex.pfm", "PF\n5 3\nabc\n", "its scale"},
        {"noheight.pfm", "Pf\n5\n", "its header lacks a number"},
        {"huge.pfm", "Pf\n99999999 99999999\n-1.0\n", "declares an impossible size"},
    };
    for (size_t k = 0; k < sizeof broken / sizeof broken[0]; k++) {
        const char *p = file_in(2, broken[k].name);
        if (broken[k].text)
            write_whole(p, broken[k].text, strlen(broken[k].text));
        else
            write_whole(p, data, size - 1);
        s = rtk_image_read(p, NULL, 0, 0, &img);
        CHECK(s == RTK_ERR_PARSE && strstr(rtk_error_message(), broken[k].fault) && strstr(rtk_error_message(), p),
              "%s: %d %s", broken[k].name, s, rtk_error_message());
    }
    free(data);
    free(px);
}

/* Embedded images decode exactly as the same bytes from a file, whatever
 * the name given (glTF names have no extension). */
static void test_embedded(void)
{
    static const char *const files[] = {"embedded.jpg", "embedded.exr", "embedded.png", "embedded.hdr"};
    float *px = make_pixels(5, 3, 3);
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        const char *path = file_in(0, files[i]);
        CHECK(rtk_image_write(path, 5, 3, 3, NULL, px, 0) == RTK_OK, "%s", rtk_error_message());
        size_t size = 0;
        char *data = read_whole(path, &size);
        rtk_image from_file, from_bytes;
        rtk_status a = rtk_image_read(path, NULL, 0, 1, &from_file);
        rtk_status b = rtk_image_read("glb image 7", data, size, 1, &from_bytes);
        CHECK(a == RTK_OK && b == RTK_OK, "%s: %d %d %s", files[i], a, b, rtk_error_message());
        if (a == RTK_OK && b == RTK_OK)
            CHECK(from_file.width == 5 && from_bytes.width == 5 && from_bytes.height == 3 &&
                      memcmp(from_file.rgba, from_bytes.rgba, sizeof(float) * 4 * 15) == 0,
                  "%s: embedded decode differs from the file", files[i]);
        free(from_file.rgba);
        free(from_bytes.rgba);
        free(data);
    }
    free(px);
}

/* Every prefix of a small image of each format rtk decodes, as bytes in a
 * buffer of exactly that size (so that the sanitizers see a read past
 * it): none that ends inside the header decodes, and none faults. */
static void test_prefixes(void)
{
    static const char *const files[] = {"cut.png", "cut.jpg", "cut.exr", "cut.hdr", "cut.tif",
                                        "cut.bmp", "cut.tga", "cut.ppm", "cut.pfm"};
    float *px = make_pixels(6, 4, 3);
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        const char *path = file_in(0, files[i]);
        CHECK(rtk_image_write(path, 6, 4, 3, NULL, px, 0) == RTK_OK, "%s: %s", files[i], rtk_error_message());
        size_t size = 0;
        char *data = read_whole(path, &size);
        CHECK(data && size > 18, "%s: cannot read it back", files[i]);
        for (size_t n = 0; data && n < size; n = n < 64 ? n + 1 : n * 5 / 4) {
            char *copy = malloc(n ? n : 1);
            memcpy(copy, data, n);
            rtk_image img;
            rtk_status s = rtk_image_read(path, copy, n, 1, &img);
            if (n <= 18)
                CHECK(s == RTK_ERR_PARSE && strstr(rtk_error_message(), path), "%s: a %zu-byte prefix: %d %s",
                      files[i], n, s, rtk_error_message());
            free(img.rgba);
            free(copy);
        }
        free(data);
    }
    free(px);
}

static uint32_t crc32_of(const unsigned char *p, size_t n)
{
    uint32_t c = 0xffffffffu;
    for (size_t i = 0; i < n; i++) {
        c ^= p[i];
        for (int k = 0; k < 8; k++)
            c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
    }
    return c ^ 0xffffffffu;
}

static void put_be32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)(v >> 24);
    p[1] = (unsigned char)(v >> 16);
    p[2] = (unsigned char)(v >> 8);
    p[3] = (unsigned char)v;
}

/* Appends a PNG chunk with its length and CRC; returns the new end. */
static unsigned char *put_chunk(unsigned char *p, const char *type, const unsigned char *data, uint32_t n)
{
    put_be32(p, n);
    memcpy(p + 4, type, 4);
    if (n)
        memcpy(p + 8, data, n);
    put_be32(p + 8 + n, crc32_of(p + 4, n + 4));
    return p + 12 + n;
}

/* A PNG whose header claims 70000 x 70000 pixels (4.9 G) over an empty IDAT. */
static void test_hostile_size(void)
{
    unsigned char png[8 + 25 + 12 + 12] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    unsigned char ihdr[13] = {0};
    put_be32(ihdr, 70000);
    put_be32(ihdr + 4, 70000);
    ihdr[8] = 8; /* bit depth */
    ihdr[9] = 2; /* RGB */
    unsigned char *p = put_chunk(png + 8, "IHDR", ihdr, 13);
    p = put_chunk(p, "IDAT", NULL, 0);
    put_chunk(p, "IEND", NULL, 0);
    const char *path = file_in(0, "huge.png");
    CHECK(write_whole(path, png, sizeof png), "cannot write %s", path);
    rtk_image img;
    rtk_status s = rtk_image_read(path, NULL, 0, 1, &img);
    CHECK(s != RTK_OK && strstr(rtk_error_message(), path), "huge PNG: %d %s", s, rtk_error_message());
    CHECK(strstr(rtk_error_message(), "70000"), "message should give the size: %s", rtk_error_message());
    s = rtk_image_read("huge embedded", png, sizeof png, 1, &img);
    CHECK(s != RTK_OK, "huge embedded PNG decoded");

    /* Sizes rtk allows, in files too short for them: refused before the
     * decoder allocates for the pixels (16000 x 16000 RGBA floats: 4 GB). */
    put_be32(ihdr, 16000);
    put_be32(ihdr + 4, 16000);
    unsigned char idat[64] = {0x78, 0x9c};
    p = put_chunk(png + 8, "IHDR", ihdr, 13);
    unsigned char small[8 + 25 + 12 + sizeof idat + 12];
    memcpy(small, png, 8 + 25);
    p = put_chunk(small + 8 + 25, "IDAT", idat, sizeof idat);
    put_chunk(p, "IEND", NULL, 0);
    s = rtk_image_read("short PNG", small, sizeof small, 1, &img);
    CHECK(s == RTK_ERR_PARSE && strstr(rtk_error_message(), "too short for its size") &&
              strstr(rtk_error_message(), "16000x16000"),
          "a 16000x16000 PNG of 64 bytes of data: %d %s", s, rtk_error_message());
    /* Run-length TGA: a packet holds at most 128 pixels. */
    unsigned char tga[18 + 40] = {0, 0, 10};
    tga[12] = 16000 & 0xff, tga[13] = 16000 >> 8, tga[14] = 16000 & 0xff, tga[15] = 16000 >> 8, tga[16] = 32;
    s = rtk_image_read("short.tga", tga, sizeof tga, 1, &img);
    CHECK(s == RTK_ERR_PARSE && strstr(rtk_error_message(), "truncated"),
          "a 16000x16000 run-length TGA of 40 bytes: %d %s", s, rtk_error_message());
}

/* A 4 x 4 texture whose texel (x, y) holds (x, y, 10 x + y, 1). */
static rtk_texture grid_texture(void)
{
    rtk_texture tex;
    memset(&tex, 0, sizeof tex);
    tex.name = rtk_strdup("grid");
    tex.width = tex.height = 4;
    tex.rgba = malloc(sizeof(float) * 4 * 16);
    for (int y = 0; y < 4; y++) {
        for (int x = 0; x < 4; x++) {
            float *t = tex.rgba + 4 * (y * 4 + x);
            t[0] = (float)x;
            t[1] = (float)y;
            t[2] = (float)(10 * x + y);
            t[3] = 1.0f;
        }
    }
    tex.decoded = 1;
    return tex;
}

static int same4(const float *a, const float *b)
{
    return memcmp(a, b, 4 * sizeof(float)) == 0;
}

static void test_texture_lookup(void)
{
    rtk_texture tex = grid_texture();
    float got[4];
    for (int y = 0; y < 4; y++) {
        for (int x = 0; x < 4; x++) {
            rtk_texture_lookup(&tex, ((float)x + 0.5f) / 4.0f, ((float)y + 0.5f) / 4.0f, got);
            CHECK(same4(got, tex.rgba + 4 * (y * 4 + x)), "texel (%d,%d) centre gave %g %g %g %g", x, y,
                  got[0], got[1], got[2], got[3]);
        }
    }
    rtk_texture_lookup(&tex, 0.25f, 0.125f, got);
    CHECK(got[0] == 0.5f && got[1] == 0.0f && got[2] == 5.0f && got[3] == 1.0f,
          "midpoint of texels (0,0) and (1,0): %g %g %g %g", got[0], got[1], got[2], got[3]);
    rtk_texture_lookup(&tex, 0.25f, 0.25f, got);
    CHECK(got[0] == 0.5f && got[1] == 0.5f && got[2] == 5.5f, "centre of 4 texels: %g %g %g", got[0],
          got[1], got[2]);
    float ref[4];
    rtk_texture_lookup(&tex, 0.25f, 0.375f, ref);
    rtk_texture_lookup(&tex, 1.25f, 0.375f, got);
    CHECK(same4(got, ref), "u = 1.25 differs from u = 0.25");
    rtk_texture_lookup(&tex, -0.75f, 1.375f, got);
    CHECK(same4(got, ref), "u = -0.75, v = 1.375 differs from (0.25, 0.375)");
    rtk_texture_lookup(&tex, 0.0f, 0.125f, got);
    CHECK(got[0] == 1.5f && got[2] == 15.0f, "u = 0 blends the first and last column: %g", got[0]);

    const float odd[] = {NAN, -NAN, INFINITY, -INFINITY, FLT_MAX, -FLT_MAX, 1e30f, -1e30f,
                         16777216.0f, -1e-30f, 1e-45f, -0.0f, 0.99999994f, 1.0f};
    size_t n = sizeof odd / sizeof odd[0];
    for (size_t i = 0; i < n; i++) {
        for (size_t j = 0; j < n; j++) {
            rtk_texture_lookup(&tex, odd[i], odd[j], got);
            CHECK(isfinite(got[0]) && isfinite(got[1]) && got[3] == 1.0f && got[0] >= 0.0f &&
                      got[0] <= 3.0f,
                  "uv (%g, %g) gave %g %g %g %g", odd[i], odd[j], got[0], got[1], got[2], got[3]);
        }
    }
    rtk_texture_lookup(&tex, NAN, 0.5f, got);
    CHECK(same4(got, tex.rgba), "NaN u should give texel (0,0)");
    rtk_texture_lookup(&tex, 0.5f, INFINITY, got);
    CHECK(same4(got, tex.rgba), "infinite v should give texel (0,0)");
    rtk_texture_free(&tex);
    CHECK(tex.rgba == NULL && tex.name == NULL, "free left pointers");
    rtk_texture_free(&tex);
}

static void test_texture_decode(void)
{
    rtk_texture tex;
    memset(&tex, 0, sizeof tex);
    tex.name = rtk_strdup("missing.png");
    tex.path = rtk_strdup(file_in(0, "missing.png"));
    tex.srgb = 1;
    rtk_texture_decode(&tex);
    CHECK(tex.decoded == 1 && tex.missing == 1 && tex.rgba == NULL, "decoded %d missing %d", tex.decoded,
          tex.missing);
    float got[4];
    rtk_texture_lookup(&tex, 0.3f, 0.7f, got);
    CHECK(got[0] == 1.0f && got[1] == 1.0f && got[2] == 1.0f && got[3] == 1.0f, "missing is not white");
    rtk_texture_free(&tex);

    memset(&tex, 0, sizeof tex);
    tex.name = rtk_strdup("never decoded");
    rtk_texture_lookup(&tex, 0.3f, 0.7f, got);
    CHECK(got[0] == 1.0f && got[3] == 1.0f, "undecoded is not white");
    rtk_texture_free(&tex);

    /* Top row red, bottom row blue: v = 0 must be the top. */
    unsigned char rgb[2 * 2 * 3] = {255, 0, 0, 255, 0, 0, 0, 0, 255, 0, 0, 255};
    const char *path = file_in(0, "topbottom.png");
    CHECK(check_write_u8(path, 2, 2, 3, rgb), "cannot write %s", path);
    memset(&tex, 0, sizeof tex);
    tex.name = rtk_strdup("topbottom.png");
    tex.path = rtk_strdup(path);
    tex.srgb = 1;
    rtk_texture_decode(&tex);
    CHECK(tex.decoded == 1 && tex.missing == 0 && tex.width == 2 && tex.height == 2, "decode: %s",
          rtk_error_message());
    rtk_texture_lookup(&tex, 0.25f, 0.25f, got);
    CHECK(got[0] == 1.0f && got[2] == 0.0f, "v = 0.25 is not the top (red) row: %g %g %g", got[0], got[1],
          got[2]);
    rtk_texture_lookup(&tex, 0.25f, 0.75f, got);
    CHECK(got[0] == 0.0f && got[2] == 1.0f, "v = 0.75 is not the bottom (blue) row");

    size_t size = 0;
    char *data = read_whole(path, &size);
    rtk_texture emb;
    memset(&emb, 0, sizeof emb);
    emb.name = rtk_strdup("glb image 0");
    emb.bytes = (unsigned char *)data;
    emb.byte_count = size;
    emb.srgb = 1;
    rtk_texture_decode(&emb);
    CHECK(emb.missing == 0 && emb.width == 2 && emb.rgba &&
              memcmp(emb.rgba, tex.rgba, sizeof(float) * 16) == 0,
          "embedded decode differs from the file: %s", rtk_error_message());
    rtk_texture_free(&emb);
    rtk_texture_free(&tex);

    data = read_whole(path, &size);
    const char *cut = file_in(1, "cut.png");
    write_whole(cut, data, size / 2);
    free(data);
    memset(&tex, 0, sizeof tex);
    tex.name = rtk_strdup("cut.png");
    tex.path = rtk_strdup(cut);
    rtk_texture_decode(&tex);
    CHECK(tex.missing == 1 && tex.rgba == NULL, "truncated texture not marked missing");
    rtk_texture_free(&tex);

    float bad[4 * 2] = {NAN, 1.0f, INFINITY, 1.0f, 0.5f, 0.5f, 0.5f, 1.0f};
    path = file_in(0, "nan.exr");
    CHECK(rtk_image_write(path, 2, 1, 4, NULL, bad, 0) == RTK_OK, "%s", rtk_error_message());
    memset(&tex, 0, sizeof tex);
    tex.name = rtk_strdup("nan.exr");
    tex.path = rtk_strdup(path);
    rtk_texture_decode(&tex);
    CHECK(tex.missing == 0 && tex.rgba && tex.rgba[0] == 0.0f && tex.rgba[2] == 0.0f &&
              tex.rgba[4] == 0.5f,
          "non-finite texels not replaced");
    rtk_texture_free(&tex);
}

static void remove_scratch(void)
{
    DIR *d = opendir(scratch);
    struct dirent *e;
    while (d && (e = readdir(d)) != NULL) {
        if (strcmp(e->d_name, ".") && strcmp(e->d_name, ".."))
            remove(file_in(3, e->d_name));
    }
    if (d)
        closedir(d);
    rmdir(scratch);
}

int main(void)
{
    const char *tmp = getenv("TMPDIR");
    snprintf(scratch, sizeof scratch, "%s/rtk-test-image-XXXXXX", tmp && tmp[0] ? tmp : "/tmp");
    if (!mkdtemp(scratch)) {
        fprintf(stderr, "cannot create a scratch directory under %s\n", tmp ? tmp : "/tmp");
        return 1;
    }
    test_builtin_writers();
    test_exr_float_roundtrip();
    test_exr_half_roundtrip();
    test_png_roundtrip();
    test_aov_channel_names();
    test_atomic_write();
    test_srgb_decode();
    test_colour_metadata();
    test_read_errors();
    test_embedded();
    test_prefixes();
    test_pfm();
    test_hostile_size();
    test_texture_lookup();
    test_texture_decode();
    CHECK(module_loaded(), "the image module is not seen in /proc/self/maps after reading images, so the "
          "check that PNG and EXR writes do without it proves nothing");
    CHECK(count_temp_files() == 0, "a temporary file was left behind");
    remove_scratch();
    if (failures) {
        fprintf(stderr, "%d check(s) failed\n", failures);
        return 1;
    }
    printf("image: all checks passed\n");
    return 0;
}

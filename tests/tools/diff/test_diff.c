/* Tests for tools/diff/diff.c: every metric against values worked out by hand
 * on small buffers, NaN/Inf counting, options, and the file path (sizes
 * that differ, missing files, error images) through files written with
 * rtk_image_write to a fresh directory under $TMPDIR.
 * `test_diff --fixtures DIR` only writes the images test_diff_cli.sh uses. */
#include "tools.h"
#include "config/config.h"
#include "render/render.h"
#include "image/image.h"

#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
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

/* got equals want up to double rounding (a few ulps of the sums). */
#define NEAR(got, want)                                                                            \
    CHECK(near((got), (want)), "%s = %.17g, expected %.17g", #got, (double)(got), (double)(want))

static int near(double got, double want)
{
    if (isinf(want))
        return got == want;
    return fabs(got - want) <= 1e-13 * fabs(want) + 1e-16;
}

static const char *file_in(int slot, const char *name)
{
    static char paths[4][1024];
    snprintf(paths[slot], sizeof paths[slot], "%s/%s", scratch, name);
    return paths[slot];
}

static rtk_diff_result diff(const float *a, const float *b, uint32_t w, uint32_t h, uint32_t channels,
                            const rtk_diff_options *o, rtk_status *st)
{
    rtk_diff_result r;
    memset(&r, 0, sizeof r);
    r.size = sizeof r;
    *st = rtk_diff_buffers(a, b, w, h, channels, NULL, o, &r);
    return r;
}

/* Two pixels of R, G, B, eps 0.01. Differences a - b:
 *   R: 0.25, -0.5 (b 0.25, 0.5; a 0.5, 0)
 *   G: 0,     1   (b 0.25, 1;   a 0.25, 2)
 *   B: 0.5,   0   (b 0.5, 0.5;  a 1, 0.5) */
static void test_hand_computed(void)
{
    const float a[] = {0.5f, 0.25f, 1.0f, 0.0f, 2.0f, 0.5f};
    const float b[] = {0.25f, 0.25f, 0.5f, 0.5f, 1.0f, 0.5f};
    rtk_status st;
    rtk_diff_result r = diff(a, b, 2, 1, 3, NULL, &st);
    CHECK(st == RTK_OK, "%s", rtk_error_message());
    CHECK(r.compared == 1 && r.width == 2 && r.height == 1 && r.channel_count == 3 && r.colour_channels == 3,
          "shape %ux%u, %u channels, %u colour", r.width, r.height, r.channel_count, r.colour_channels);
    NEAR(r.epsilon, 0.01);
    NEAR(r.peak, 1.0);
    CHECK(strcmp(r.channels[0].name, "R") == 0 && strcmp(r.channels[2].name, "B") == 0 &&
              strcmp(r.overall.name, "overall") == 0,
          "names %s %s %s", r.channels[0].name, r.channels[2].name, r.overall.name);

    const rtk_diff_channel *R = &r.channels[0], *G = &r.channels[1], *B = &r.channels[2], *all = &r.overall;
    CHECK(R->samples == 2 && all->samples == 6 && all->excluded == 0, "samples %llu, %llu",
          (unsigned long long)R->samples, (unsigned long long)all->samples);

    NEAR(R->mean_error, (0.25 - 0.5) / 2);
    NEAR(R->mse, (0.0625 + 0.25) / 2);
    NEAR(R->rmse, sqrt(0.15625));
    NEAR(R->relmse, (0.0625 / 0.0725 + 0.25 / 0.26) / 2);
    NEAR(R->mape, (0.25 / 0.26 + 0.5 / 0.51) / 2);
    NEAR(R->smape, (0.5 / 0.76 + 1.0 / 0.51) / 2);
    NEAR(R->psnr, 10.0 * log10(1.0 / 0.15625));

    NEAR(G->mean_error, 0.5);
    NEAR(G->mse, 0.5);
    NEAR(G->rmse, sqrt(0.5));
    NEAR(G->relmse, (1.0 / 1.01) / 2);
    NEAR(G->mape, (1.0 / 1.01) / 2);
    NEAR(G->smape, (2.0 / 3.01) / 2);
    NEAR(G->psnr, 10.0 * log10(2.0));

    NEAR(B->mean_error, 0.25);
    NEAR(B->mse, 0.125);
    NEAR(B->relmse, (0.25 / 0.26) / 2);
    NEAR(B->mape, (0.5 / 0.51) / 2);
    NEAR(B->smape, (1.0 / 1.51) / 2);
    NEAR(B->psnr, 10.0 * log10(8.0));

    /* Overall pools the six pairs: the mean of the channel values here,
     * since no pair was left out; rmse and psnr come from the pooled mse. */
    NEAR(all->mean_error, (0.25 - 0.5 + 0.0 + 1.0 + 0.5 + 0.0) / 6);
    NEAR(all->mse, (0.0625 + 0.25 + 0.0 + 1.0 + 0.25 + 0.0) / 6);
    NEAR(all->rmse, sqrt(1.5625 / 6));
    NEAR(all->relmse, (0.0625 / 0.0725 + 0.25 / 0.26 + 1.0 / 1.01 + 0.25 / 0.26) / 6);
    NEAR(all->mape, (0.25 / 0.26 + 0.5 / 0.51 + 1.0 / 1.01 + 0.5 / 0.51) / 6);
    NEAR(all->smape, (0.5 / 0.76 + 1.0 / 0.51 + 2.0 / 3.01 + 1.0 / 1.51) / 6);
    NEAR(all->psnr, 10.0 * log10(6 / 1.5625));

    /* b is the reference: swapping the images changes the sign of the
     * mean error and the denominators, not the mse. */
    rtk_diff_result s = diff(b, a, 2, 1, 3, NULL, &st);
    NEAR(s.channels[0].mean_error, 0.125);
    NEAR(s.channels[0].mse, 0.15625);
    NEAR(s.channels[0].mape, (0.25 / 0.51 + 0.5 / 0.01) / 2);
}

/* epsilon: given, default, refused; colour_channels and channel names. */
static void test_options(void)
{
    const float a[] = {0.5f, 0.0f, 1.0f, 0.75f};
    const float b[] = {0.0f, 0.0f, 0.5f, 0.25f};
    rtk_diff_options o;
    memset(&o, 0, sizeof o);
    o.size = sizeof o;
    o.epsilon = 1.0;
    rtk_status st;
    rtk_diff_result r = diff(a, b, 1, 1, 4, &o, &st);
    CHECK(st == RTK_OK, "%s", rtk_error_message());
    NEAR(r.epsilon, 1.0);
    NEAR(r.channels[0].relmse, 0.25 / 1.0);
    NEAR(r.channels[0].mape, 0.5 / 1.0);
    NEAR(r.channels[0].smape, 1.0 / 1.5);
    NEAR(r.channels[2].relmse, 0.25 / 1.25);
    CHECK(r.colour_channels == 3 && strcmp(r.channels[3].name, "A") == 0, "%u colour, channel 3 '%s'",
          r.colour_channels, r.channels[3].name);
    /* Overall leaves out A (the fourth channel, error 0.5). */
    NEAR(r.overall.mse, (0.25 + 0.0 + 0.25) / 3);
    CHECK(r.overall.samples == 3, "%llu", (unsigned long long)r.overall.samples);

    o.epsilon = 0.0;
    o.colour_channels = 4;
    r = diff(a, b, 1, 1, 4, &o, &st);
    NEAR(r.epsilon, RTK_DIFF_EPSILON);
    NEAR(r.overall.mse, (0.25 + 0.0 + 0.25 + 0.25) / 4);

    /* A zero-initialised options struct (size 0) means every default. */
    rtk_diff_options zero;
    memset(&zero, 0, sizeof zero);
    r = diff(a, b, 1, 1, 4, &zero, &st);
    CHECK(st == RTK_OK && r.colour_channels == 3, "st %d, %u colour", (int)st, r.colour_channels);

    const double bad_eps[] = {-1.0, NAN, INFINITY};
    for (size_t k = 0; k < 3; k++) {
        o.epsilon = bad_eps[k];
        o.colour_channels = 0;
        r = diff(a, b, 1, 1, 4, &o, &st);
        CHECK(st == RTK_ERR_INVALID && r.compared == 0 && strstr(rtk_error_message(), "epsilon"),
              "epsilon %g: st %d, '%s'", bad_eps[k], (int)st, rtk_error_message());
    }

    const char *names[] = {"albedo.R", NULL, "Z"};
    memset(&r, 0, sizeof r);
    r.size = sizeof r;
    st = rtk_diff_buffers(a, b, 1, 1, 3, names, NULL, &r);
    CHECK(st == RTK_OK && strcmp(r.channels[0].name, "albedo.R") == 0 && strcmp(r.channels[1].name, "G") == 0 &&
              strcmp(r.channels[2].name, "Z") == 0,
          "names '%s' '%s' '%s'", r.channels[0].name, r.channels[1].name, r.channels[2].name);

    float many_a[RTK_DIFF_MAX_CHANNELS + 1], many_b[RTK_DIFF_MAX_CHANNELS + 1];
    for (int c = 0; c <= RTK_DIFF_MAX_CHANNELS; c++)
        many_a[c] = (float)c, many_b[c] = 0.0f;
    r = diff(many_a, many_b, 1, 1, RTK_DIFF_MAX_CHANNELS, NULL, &st);
    CHECK(st == RTK_OK && strcmp(r.channels[5].name, "C5") == 0 && r.colour_channels == 3, "st %d, '%s'",
          (int)st, r.channels[5].name);
    NEAR(r.channels[5].mse, 25.0);
    r = diff(many_a, many_b, 1, 1, RTK_DIFF_MAX_CHANNELS + 1, NULL, &st);
    CHECK(st == RTK_ERR_INVALID, "too many channels accepted");
    r = diff(a, b, 1, 1, 1, NULL, &st);
    CHECK(st == RTK_OK && r.colour_channels == 1, "one channel: st %d, %u colour", (int)st, r.colour_channels);

    r = diff(NULL, b, 1, 1, 3, NULL, &st);
    CHECK(st == RTK_ERR_INVALID, "NULL pixels accepted");
    r = diff(a, b, 0, 1, 3, NULL, &st);
    CHECK(st == RTK_ERR_INVALID, "empty image accepted");
    o.epsilon = 0.0;
    o.colour_channels = 4;
    r = diff(a, b, 1, 1, 3, &o, &st);
    CHECK(st == RTK_ERR_INVALID, "more colour channels than channels accepted");
    CHECK(rtk_diff_buffers(a, b, 1, 1, 3, NULL, NULL, NULL) == RTK_ERR_INVALID, "NULL result accepted");
}

/* Identical images: every error 0 and PSNR +inf. */
static void test_identical(void)
{
    float a[5 * 3 * 3];
    for (size_t i = 0; i < sizeof a / sizeof a[0]; i++)
        a[i] = (float)i * 0.37f - 3.0f;
    rtk_status st;
    rtk_diff_result r = diff(a, a, 5, 3, 3, NULL, &st);
    CHECK(st == RTK_OK, "%s", rtk_error_message());
    for (uint32_t c = 0; c <= 3; c++) {
        const rtk_diff_channel *ch = c < 3 ? &r.channels[c] : &r.overall;
        CHECK(ch->mse == 0.0 && ch->rmse == 0.0 && ch->relmse == 0.0 && ch->mape == 0.0 && ch->smape == 0.0 &&
                  ch->mean_error == 0.0 && isinf(ch->psnr) && ch->psnr > 0,
              "%s: mse %g psnr %g", ch->name, ch->mse, ch->psnr);
    }
    CHECK(r.overall.samples == 45, "%llu samples", (unsigned long long)r.overall.samples);
}

/* NaN and Inf in either image: counted per channel, left out. */
static void test_nonfinite(void)
{
    /* channel 0: a NaN, Inf, 0.5 against b 0, 1, 0.25 -> one pair, d 0.25
     * channel 1: a 1, 2, -Inf against b 1, NaN, -Inf -> one pair, d 0 */
    const float a[] = {NAN, 1.0f, INFINITY, 2.0f, 0.5f, -INFINITY};
    const float b[] = {0.0f, 1.0f, 1.0f, NAN, 0.25f, -INFINITY};
    rtk_status st;
    rtk_diff_result r = diff(a, b, 3, 1, 2, NULL, &st);
    CHECK(st == RTK_OK, "%s", rtk_error_message());
    const rtk_diff_channel *c0 = &r.channels[0], *c1 = &r.channels[1], *all = &r.overall;
    CHECK(c0->samples == 1 && c0->excluded == 2 && c0->nonfinite_a == 2 && c0->nonfinite_b == 0,
          "channel 0: %llu %llu %llu %llu", (unsigned long long)c0->samples, (unsigned long long)c0->excluded,
          (unsigned long long)c0->nonfinite_a, (unsigned long long)c0->nonfinite_b);
    CHECK(c1->samples == 1 && c1->excluded == 2 && c1->nonfinite_a == 1 && c1->nonfinite_b == 2,
          "channel 1: %llu %llu %llu %llu", (unsigned long long)c1->samples, (unsigned long long)c1->excluded,
          (unsigned long long)c1->nonfinite_a, (unsigned long long)c1->nonfinite_b);
    CHECK(all->samples == 2 && all->excluded == 4 && all->nonfinite_a == 3 && all->nonfinite_b == 2,
          "overall: %llu %llu %llu %llu", (unsigned long long)all->samples, (unsigned long long)all->excluded,
          (unsigned long long)all->nonfinite_a, (unsigned long long)all->nonfinite_b);
    NEAR(c0->mse, 0.0625);
    NEAR(c0->mean_error, 0.25);
    NEAR(c0->mape, 0.25 / 0.26);
    CHECK(c1->mse == 0.0 && isinf(c1->psnr), "channel 1 mse %g", c1->mse);
    NEAR(all->mse, 0.0625 / 2);
    NEAR(all->mean_error, 0.125);

    /* No finite pair at all: every metric NaN, nothing made up. */
    const float n = NAN, z = 0.0f;
    r = diff(&n, &z, 1, 1, 1, NULL, &st);
    CHECK(st == RTK_OK && r.channels[0].samples == 0 && r.channels[0].excluded == 1, "st %d", (int)st);
    CHECK(isnan(r.channels[0].mse) && isnan(r.channels[0].rmse) && isnan(r.channels[0].relmse) &&
              isnan(r.channels[0].mape) && isnan(r.channels[0].smape) && isnan(r.channels[0].psnr) &&
              isnan(r.channels[0].mean_error) && isnan(r.overall.mse),
          "mse %g psnr %g", r.channels[0].mse, r.channels[0].psnr);
}

/* A million pairs, each off by exactly 2^-10: the double sums stay exact. */
static void test_large_sums(void)
{
    const uint32_t w = 1000, h = 1000;
    float *a = malloc((size_t)w * h * sizeof *a), *b = malloc((size_t)w * h * sizeof *b);
    CHECK(a && b, "out of memory");
    if (!a || !b) {
        free(a);
        free(b);
        return;
    }
    for (size_t i = 0; i < (size_t)w * h; i++)
        a[i] = 0.5f + 0x1p-10f, b[i] = 0.5f;
    rtk_status st;
    rtk_diff_result r = diff(a, b, w, h, 1, NULL, &st);
    CHECK(st == RTK_OK && r.channels[0].samples == 1000000, "st %d", (int)st);
    CHECK(r.channels[0].mean_error == 0x1p-10 && r.channels[0].mse == 0x1p-20, "mean %.17g mse %.17g",
          r.channels[0].mean_error, r.channels[0].mse);
    NEAR(r.channels[0].psnr, 200.0 * log10(2.0));
    free(a);
    free(b);
}

/* Writes a w x h image of n channels with f(x, y, c) to scratch/name. */
static int write_test_image(const char *path, int w, int h, int n, float (*f)(int, int, int))
{
    static const char *const names[4] = {"R", "G", "B", "A"};
    float *px = malloc((size_t)w * h * n * sizeof *px);
    if (!px)
        return 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int c = 0; c < n; c++)
                px[((size_t)y * w + x) * n + c] = f(x, y, c);
    rtk_status st = rtk_image_write(path, w, h, n, names, px, 0);
    free(px);
    if (st != RTK_OK)
        fprintf(stderr, "cannot write %s: %s\n", path, rtk_error_message());
    return st == RTK_OK;
}

/* The CLI fixtures: reference 0.5 everywhere; test off by +0.5 in R of
 * pixel (0,0) and -0.25 in G of pixel (1,0); one NaN in B of (2,1);
 * zero.exr is RGBA 0 everywhere. */
static float ref_pixel(int x, int y, int c)
{
    (void)x, (void)y, (void)c;
    return 0.5f;
}

static float test_pixel(int x, int y, int c)
{
    if (x == 0 && y == 0 && c == 0)
        return 1.0f;
    if (x == 1 && y == 0 && c == 1)
        return 0.25f;
    return 0.5f;
}

static float nan_pixel(int x, int y, int c)
{
    return x == 2 && y == 1 && c == 2 ? NAN : test_pixel(x, y, c);
}

static float zero_pixel(int x, int y, int c)
{
    (void)x, (void)y, (void)c;
    return 0.0f;
}

static int write_fixtures(const char *dir)
{
    char path[1024];
    struct {
        const char *name;
        int w, h;
        float (*f)(int, int, int);
    } files[] = {
        {"ref.exr", 4, 2, ref_pixel}, {"test.exr", 4, 2, test_pixel}, {"nan.exr", 4, 2, nan_pixel},
        {"small.exr", 2, 2, ref_pixel}, {"ref.png", 4, 2, ref_pixel},
    };
    for (size_t k = 0; k < sizeof files / sizeof files[0]; k++) {
        snprintf(path, sizeof path, "%s/%s", dir, files[k].name);
        if (!write_test_image(path, files[k].w, files[k].h, 3, files[k].f))
            return 0;
    }
    snprintf(path, sizeof path, "%s/grey.exr", dir);
    if (!write_test_image(path, 4, 2, 1, ref_pixel))
        return 0;
    snprintf(path, sizeof path, "%s/zero.exr", dir);
    return write_test_image(path, 4, 2, 4, zero_pixel);
}

static float ramp_pixel(int x, int y, int c)
{
    (void)c;
    /* Reference 1; test 1 (error 0), 2 (relative error ~1), NaN. */
    if (y == 1)
        return 1.0f;
    return x == 0 ? 1.0f : (x == 1 ? 2.0f : NAN);
}

static void test_files(void)
{
    const char *ref = file_in(0, "ref.exr"), *test = file_in(1, "test.exr");
    CHECK(write_fixtures(scratch), "fixtures not written");

    rtk_diff_result r;
    memset(&r, 0, sizeof r);
    r.size = sizeof r;
    rtk_status st = rtk_diff_files(test, ref, NULL, &r);
    CHECK(st == RTK_OK, "%s", rtk_error_message());
    CHECK(r.width == 4 && r.height == 2 && r.channel_count == 4 && r.colour_channels == 3, "%ux%u, %u channels",
          r.width, r.height, r.channel_count);
    CHECK(strcmp(r.channels[3].name, "A") == 0 && r.channels[3].mse == 0.0, "A: '%s' %g", r.channels[3].name,
          r.channels[3].mse);
    NEAR(r.channels[0].mse, 0.25 / 8);
    NEAR(r.channels[1].mse, 0.0625 / 8);
    NEAR(r.channels[1].mean_error, -0.25 / 8);
    CHECK(r.channels[2].mse == 0.0, "B mse %g", r.channels[2].mse);
    NEAR(r.overall.mse, 0.3125 / 24);
    CHECK(r.overall.samples == 24, "%llu", (unsigned long long)r.overall.samples);

    /* A NaN read from a file is counted like one in a buffer. */
    st = rtk_diff_files(file_in(2, "nan.exr"), ref, NULL, &r);
    CHECK(st == RTK_OK && r.channels[2].excluded == 1 && r.channels[2].nonfinite_a == 1 &&
              r.overall.samples == 23,
          "st %d, excluded %llu", (int)st, (unsigned long long)r.channels[2].excluded);

    /* A PNG is decoded to linear before comparing: against itself, 0. */
    st = rtk_diff_files(file_in(2, "ref.png"), file_in(3, "ref.png"), NULL, &r);
    CHECK(st == RTK_OK && r.overall.mse == 0.0, "st %d, mse %g", (int)st, r.overall.mse);

    st = rtk_diff_files(test, file_in(2, "small.exr"), NULL, &r);
    const char *msg = rtk_error_message();
    CHECK(st == RTK_ERR_INVALID && r.compared == 0, "size mismatch: st %d", (int)st);
    CHECK(strstr(msg, test) && strstr(msg, "small.exr") && strstr(msg, "(4x2)") && strstr(msg, "(2x2)"),
          "size message '%s'", msg);

    st = rtk_diff_files(test, file_in(2, "missing.exr"), NULL, &r);
    msg = rtk_error_message();
    CHECK(st == RTK_ERR_IO && r.compared == 0, "missing reference: st %d", (int)st);
    CHECK(strstr(msg, "missing.exr") && strstr(msg, "No such file"), "missing message '%s'", msg);
    st = rtk_diff_files(file_in(2, "missing.exr"), ref, NULL, &r);
    CHECK(st == RTK_ERR_IO && strstr(rtk_error_message(), "missing.exr"), "missing test: '%s'",
          rtk_error_message());

    FILE *f = fopen(file_in(2, "junk.exr"), "wb");
    if (f) {
        fputs("not an image\n", f);
        fclose(f);
    }
    st = rtk_diff_files(file_in(2, "junk.exr"), ref, NULL, &r);
    CHECK(st != RTK_OK && r.compared == 0 && strstr(rtk_error_message(), "junk.exr"), "junk: st %d '%s'",
          (int)st, rtk_error_message());
    unlink(file_in(2, "junk.exr"));
}

static void test_error_images(void)
{
    const char *ref = file_in(0, "ramp_ref.exr"), *test = file_in(1, "ramp_test.exr");
    CHECK(write_test_image(ref, 3, 2, 3, ref_pixel) && write_test_image(test, 3, 2, 3, ramp_pixel),
          "ramp images not written");
    rtk_diff_options o;
    memset(&o, 0, sizeof o);
    o.size = sizeof o;
    rtk_diff_result r;
    memset(&r, 0, sizeof r);
    r.size = sizeof r;

    /* .exr: |a - b| per channel, NaN where an input is NaN. */
    o.error_image = file_in(2, "err.exr");
    rtk_status st = rtk_diff_files(test, ref, &o, &r);
    CHECK(st == RTK_OK, "%s", rtk_error_message());
    rtk_image img;
    st = rtk_image_read(o.error_image, NULL, 0, 0, &img);
    CHECK(st == RTK_OK && img.width == 3 && img.height == 2, "%s", rtk_error_message());
    if (st == RTK_OK) {
        /* test (x, 0) = 1, 2, NaN; row 1 = 1 everywhere; reference 0.5. */
        CHECK(img.rgba[0] == 0.5f && img.rgba[4] == 1.5f && isnan(img.rgba[8]) && img.rgba[12] == 0.5f &&
                  img.rgba[3] == 0.0f,
              "error values %g %g %g %g, alpha %g", img.rgba[0], img.rgba[4], img.rgba[8], img.rgba[12],
              img.rgba[3]);
        free(img.rgba);
    }

    /* Other formats: the heat map. Against reference 1: error 0 is grey,
     * relative error ~1 red, NaN magenta. */
    const char *ref1 = file_in(0, "ramp_ref1.exr");
    float one[3 * 2 * 3];
    for (size_t i = 0; i < sizeof one / sizeof one[0]; i++)
        one[i] = 1.0f;
    CHECK(rtk_image_write(ref1, 3, 2, 3, NULL, one, 0) == RTK_OK, "%s", rtk_error_message());
    o.error_image = file_in(2, "err.png");
    st = rtk_diff_files(test, ref1, &o, &r);
    CHECK(st == RTK_OK, "%s", rtk_error_message());
    st = rtk_image_read(o.error_image, NULL, 0, 0, &img);
    CHECK(st == RTK_OK && img.width == 3 && img.height == 2, "%s", rtk_error_message());
    if (st == RTK_OK) {
        /* Read back without decoding: the stored sRGB values, 8-bit. */
        const float *grey = img.rgba, *red = img.rgba + 4, *magenta = img.rgba + 8;
        CHECK(fabsf(grey[0] - 0.25f) < 0.004f && fabsf(grey[1] - 0.25f) < 0.004f && fabsf(grey[2] - 0.25f) < 0.004f,
              "grey %g %g %g", grey[0], grey[1], grey[2]);
        /* relative error 1 / 1.01, just under the top of the ramp */
        CHECK(red[0] > 0.85f && red[1] < 0.1f && red[2] < 0.1f, "red %g %g %g", red[0], red[1], red[2]);
        CHECK(magenta[0] == 1.0f && magenta[1] == 0.0f && magenta[2] == 1.0f, "magenta %g %g %g", magenta[0],
              magenta[1], magenta[2]);
        free(img.rgba);
    }

    /* A failed write still leaves the metrics, and says which file. */
    o.error_image = file_in(2, "no/such/dir/err.png");
    memset(&r, 0, sizeof r);
    r.size = sizeof r;
    st = rtk_diff_files(test, ref1, &o, &r);
    CHECK(st == RTK_ERR_IO && r.compared == 1 && strstr(rtk_error_message(), "err.png"), "st %d, '%s'",
          (int)st, rtk_error_message());
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

static void remove_scratch(void)
{
    DIR *d = opendir(scratch);
    struct dirent *e;
    while (d && (e = readdir(d)) != NULL)
        if (strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0)
            unlink(file_in(0, e->d_name));
    if (d)
        closedir(d);
    rmdir(scratch);
}

int main(int argc, char **argv)
{
    if (argc == 3 && strcmp(argv[1], "--fixtures") == 0)
        return write_fixtures(argv[2]) ? 0 : 1;
    const char *tmp = getenv("TMPDIR");
    snprintf(scratch, sizeof scratch, "%s/rtk-test-diff-XXXXXX", tmp && tmp[0] ? tmp : "/tmp");
    if (!mkdtemp(scratch)) {
        fprintf(stderr, "cannot create a scratch directory under %s\n", tmp ? tmp : "/tmp");
        return 1;
    }
    test_hand_computed();
    test_options();
    test_identical();
    test_nonfinite();
    test_large_sums();
    test_files();
    test_error_images();
    CHECK(count_temp_files() == 0, "a temporary file was left behind");
    remove_scratch();
    if (failures) {
        fprintf(stderr, "%d check(s) failed\n", failures);
        return 1;
    }
    printf("diff: all checks passed\n");
    return 0;
}

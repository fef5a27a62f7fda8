/* Image comparison behind `rtk diff`: error metrics of an image under test
 * against a reference, per channel and pooled over the colour channels, and
 * an optional error image. The metric definitions are in include/rtk/host.h.
 * Every sum is a double, summed per row and then into the image total so
 * that large images lose little to rounding. A pair where either value is
 * NaN or Inf is counted and left out of the metrics, never averaged in. */
#include "image/image.h"
#include "../tools.h"

#include <ctype.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Running sums of one channel. */
typedef struct diff_sums {
    uint64_t samples, excluded, nonfinite_a, nonfinite_b;
    double err, sq, rel_sq, ape, sape;
} diff_sums;

/* to += from, field by field. */
static void sums_add(diff_sums *to, const diff_sums *from)
{
    to->samples += from->samples;
    to->excluded += from->excluded;
    to->nonfinite_a += from->nonfinite_a;
    to->nonfinite_b += from->nonfinite_b;
    to->err += from->err;
    to->sq += from->sq;
    to->rel_sq += from->rel_sq;
    to->ape += from->ape;
    to->sape += from->sape;
}

/* Turns sums into metrics; NaN metrics when no pair was compared. */
static void sums_finish(const diff_sums *s, const char *name, double peak, rtk_diff_channel *out)
{
    memset(out, 0, sizeof *out);
    snprintf(out->name, sizeof out->name, "%s", name);
    out->samples = s->samples;
    out->excluded = s->excluded;
    out->nonfinite_a = s->nonfinite_a;
    out->nonfinite_b = s->nonfinite_b;
    if (s->samples == 0) {
        out->mean_error = out->mse = out->rmse = out->relmse = NAN;
        out->mape = out->smape = out->psnr = NAN;
        return;
    }
    double n = (double)s->samples;
    out->mean_error = s->err / n;
    out->mse = s->sq / n;
    out->rmse = sqrt(out->mse);
    out->relmse = s->rel_sq / n;
    out->mape = s->ape / n;
    out->smape = s->sape / n;
    out->psnr = out->mse > 0.0 ? 10.0 * log10(peak * peak / out->mse) : INFINITY;
}

/* Copies a finished result into the caller's, which may be an older,
 * smaller struct (out->size bytes; 0 means the current size). */
static void result_store(rtk_diff_result *out, const rtk_diff_result *r)
{
    size_t size = out->size ? out->size : sizeof *out;
    if (size > sizeof *out)
        size = sizeof *out;
    memcpy(out, r, size);
    out->size = (uint32_t)size;
}

/* 1 when path ends in ".exr", any case. */
static int is_exr(const char *path)
{
    const char *dot = strrchr(path, '.');
    const char *slash = strrchr(path, '/');
    if (!dot || (slash && dot < slash))
        return 0;
    const char *exr = ".exr";
    for (size_t i = 0; i < 5; i++)
        if (tolower((unsigned char)dot[i]) != exr[i])
            return 0;
    return 1;
}

/* sRGB-encoded value in [0, 1] to linear. */
static double srgb_decode(double v)
{
    return v <= 0.04045 ? v / 12.92 : pow((v + 0.055) / 1.055, 2.4);
}

/* Heat-map colour of a relative error, in linear RGB: the ramp's stops are
 * display (sRGB) colours at 1e-3, 1e-2, 1e-1 and 1, interpolated on log10. */
static void ramp_colour(double rel, float rgb[3])
{
    static const double stops[4][3] = {
        {0.25, 0.25, 0.25}, /* grey: <= 0.1 % */
        {0.15, 0.35, 1.00}, /* blue: 1 % */
        {1.00, 0.85, 0.10}, /* yellow: 10 % */
        {0.90, 0.05, 0.05}, /* red: >= 100 % */
    };
    double t = rel > 0.0 ? log10(rel) + 3.0 : 0.0;
    t = t < 0.0 ? 0.0 : (t > 3.0 ? 3.0 : t);
    int k = t >= 3.0 ? 2 : (int)t;
    double f = t - k;
    for (int c = 0; c < 3; c++)
        rgb[c] = (float)srgb_decode(stops[k][c] + f * (stops[k + 1][c] - stops[k][c]));
}

/* Writes the error image described at rtk_diff_buffers in host.h. */
static rtk_status write_error_image(const char *path, const float *a, const float *b, size_t pixels,
                                    uint32_t width, uint32_t height, uint32_t channels, uint32_t colour,
                                    const char *const *names, double eps)
{
    int exr = is_exr(path);
    uint32_t out_channels = exr ? channels : 3;
    float *img = rtk_alloc(pixels * out_channels * sizeof *img);
    if (!img)
        return rtk_error(RTK_ERR_NOMEM, "cannot write error image '%s': out of memory", path);
    for (size_t i = 0; i < pixels; i++) {
        const float *pa = a + i * channels, *pb = b + i * channels;
        float *o = img + i * out_channels;
        if (exr) {
            for (uint32_t c = 0; c < channels; c++)
                o[c] = isfinite(pa[c]) && isfinite(pb[c]) ? (float)fabs((double)pa[c] - (double)pb[c]) : NAN;
            continue;
        }
        double rel = 0.0;
        int finite = 1;
        for (uint32_t c = 0; c < colour; c++) {
            finite &= isfinite(pa[c]) && isfinite(pb[c]);
            rel += fabs((double)pa[c] - (double)pb[c]) / (fabs((double)pb[c]) + eps);
        }
        if (!finite) {
            o[0] = 1.0f, o[1] = 0.0f, o[2] = 1.0f;
            continue;
        }
        ramp_colour(rel / colour, o);
    }
    rtk_status st = rtk_image_write(path, (int)width, (int)height, (int)out_channels, exr ? names : NULL, img, 0);
    free(img);
    return st;
}

rtk_status rtk_diff_buffers(const float *a, const float *b, uint32_t width, uint32_t height,
                                    uint32_t channel_count, const char *const *names,
                                    const rtk_diff_options *options, rtk_diff_result *out)
{
    if (!out)
        return rtk_error(RTK_ERR_INVALID, "rtk_diff_buffers: no result given");
    rtk_diff_result r;
    memset(&r, 0, sizeof r);
    r.size = sizeof r;
    result_store(out, &r);

    rtk_diff_options o;
    memset(&o, 0, sizeof o);
    if (options) {
        size_t size = options->size ? options->size : sizeof o;
        memcpy(&o, options, size < sizeof o ? size : sizeof o);
    }
    if (!a || !b)
        return rtk_error(RTK_ERR_INVALID, "rtk_diff_buffers: no pixels given");
    if (width == 0 || height == 0)
        return rtk_error(RTK_ERR_INVALID, "rtk_diff_buffers: empty image (%ux%u)", width, height);
    if (channel_count == 0 || channel_count > RTK_DIFF_MAX_CHANNELS)
        return rtk_error(RTK_ERR_INVALID, "rtk_diff_buffers: %u channels; 1 to %d are supported", channel_count,
                         RTK_DIFF_MAX_CHANNELS);
    if (o.colour_channels > channel_count)
        return rtk_error(RTK_ERR_INVALID, "rtk_diff_buffers: %u colour channels of only %u", o.colour_channels,
                         channel_count);
    if (o.epsilon != 0.0 && !(o.epsilon > 0.0 && isfinite(o.epsilon)))
        return rtk_error(RTK_ERR_INVALID, "epsilon must be a finite number > 0, not %g", o.epsilon);
    uint64_t pixels = (uint64_t)width * height;
    if (pixels > SIZE_MAX / sizeof(float) / channel_count)
        return rtk_error(RTK_ERR_NOMEM, "rtk_diff_buffers: %ux%u pixels is too large", width, height);

    double eps = o.epsilon != 0.0 ? o.epsilon : RTK_DIFF_EPSILON;
    uint32_t colour = o.colour_channels ? o.colour_channels : (channel_count < 3 ? channel_count : 3);
    diff_sums total[RTK_DIFF_MAX_CHANNELS], row[RTK_DIFF_MAX_CHANNELS];
    memset(total, 0, sizeof total);
    for (uint32_t y = 0; y < height; y++) {
        memset(row, 0, sizeof row);
        size_t start = (size_t)y * width * channel_count;
        for (size_t i = start; i < start + (size_t)width * channel_count; i += channel_count) {
            for (uint32_t c = 0; c < channel_count; c++) {
                float fa = a[i + c], fb = b[i + c];
                diff_sums *s = &row[c];
                int bad_a = !isfinite(fa), bad_b = !isfinite(fb);
                if (bad_a || bad_b) {
                    s->excluded++;
                    s->nonfinite_a += (uint64_t)bad_a;
                    s->nonfinite_b += (uint64_t)bad_b;
                    continue;
                }
                double da = fa, db = fb, d = da - db, ad = fabs(d);
                s->samples++;
                s->err += d;
                s->sq += d * d;
                s->rel_sq += d * d / (db * db + eps);
                s->ape += ad / (fabs(db) + eps);
                s->sape += 2.0 * ad / (fabs(da) + fabs(db) + eps);
            }
        }
        for (uint32_t c = 0; c < channel_count; c++)
            sums_add(&total[c], &row[c]);
    }

    static const char *const default_names[4] = {"R", "G", "B", "A"};
    diff_sums pooled;
    memset(&pooled, 0, sizeof pooled);
    r.width = width;
    r.height = height;
    r.channel_count = channel_count;
    r.colour_channels = colour;
    r.epsilon = eps;
    r.peak = 1.0;
    for (uint32_t c = 0; c < channel_count; c++) {
        char fallback[16];
        const char *name = names && names[c] ? names[c] : NULL;
        if (!name && c < 4)
            name = default_names[c];
        if (!name) {
            snprintf(fallback, sizeof fallback, "C%u", c);
            name = fallback;
        }
        sums_finish(&total[c], name, r.peak, &r.channels[c]);
        if (c < colour)
            sums_add(&pooled, &total[c]);
    }
    sums_finish(&pooled, "overall", r.peak, &r.overall);
    r.compared = 1;
    result_store(out, &r);

    if (o.error_image && o.error_image[0]) {
        const char *exr_names[RTK_DIFF_MAX_CHANNELS];
        for (uint32_t c = 0; c < channel_count; c++)
            exr_names[c] = r.channels[c].name;
        return write_error_image(o.error_image, a, b, (size_t)pixels, width, height, channel_count, colour,
                                 exr_names, eps);
    }
    return RTK_OK;
}

rtk_status rtk_diff_files(const char *test, const char *reference, const rtk_diff_options *options,
                                  rtk_diff_result *out)
{
    if (!out)
        return rtk_error(RTK_ERR_INVALID, "rtk_diff_files: no result given");
    rtk_diff_result r;
    memset(&r, 0, sizeof r);
    r.size = sizeof r;
    result_store(out, &r);
    if (!test || !reference)
        return rtk_error(RTK_ERR_INVALID, "rtk_diff_files: two file names are needed");

    rtk_image ia, ib;
    memset(&ib, 0, sizeof ib);
    rtk_status st = rtk_image_read(test, NULL, 0, 1, &ia);
    if (st != RTK_OK)
        return st;
    st = rtk_image_read(reference, NULL, 0, 1, &ib);
    if (st == RTK_OK && (ia.width != ib.width || ia.height != ib.height))
        st = rtk_error(RTK_ERR_INVALID, "cannot compare '%s' (%dx%d) with reference '%s' (%dx%d): the sizes differ",
                       test, ia.width, ia.height, reference, ib.width, ib.height);
    /* Grey against colour would compare a grey channel three times with
     * three different ones: refused. Extra layers (AOVs) and a missing
     * alpha are said, not silently skipped or invented. */
    if (st == RTK_OK && ((ia.channels >= 3) != (ib.channels >= 3)))
        st = rtk_error(RTK_ERR_INVALID,
                       "cannot compare '%s' (%d channel%s, %s) with reference '%s' (%d channel%s, %s): one is grey and "
                       "the other colour; convert one of them",
                       test, ia.channels, ia.channels == 1 ? "" : "s", ia.channels >= 3 ? "RGB" : "grey", reference,
                       ib.channels, ib.channels == 1 ? "" : "s", ib.channels >= 3 ? "RGB" : "grey");
    if (st == RTK_OK) {
        const rtk_image *im[2] = {&ia, &ib};
        const char *names[2] = {test, reference};
        for (int k = 0; k < 2; k++) {
            int used = im[k]->channels >= 3 ? 3 + im[k]->has_alpha : 1 + im[k]->has_alpha;
            if (im[k]->channels > used)
                rtk_log(RTK_LOG_WARN, "'%s' has %d channels; rtk diff compares its %s and leaves %d more (layers such "
                        "as AOVs) out", names[k], im[k]->channels, used >= 3 ? "RGB(A)" : "grey(A)",
                        im[k]->channels - used);
        }
        if (ia.has_alpha != ib.has_alpha)
            rtk_log(RTK_LOG_WARN, "'%s' has no alpha channel: its A is compared as 1",
                    ia.has_alpha ? reference : test);
    }
    if (st == RTK_OK) {
        static const char *const rgba[4] = {"R", "G", "B", "A"};
        rtk_diff_options o;
        memset(&o, 0, sizeof o);
        if (options) {
            size_t size = options->size ? options->size : sizeof o;
            memcpy(&o, options, size < sizeof o ? size : sizeof o);
        }
        o.size = sizeof o;
        o.colour_channels = 3;
        st = rtk_diff_buffers(ia.rgba, ib.rgba, (uint32_t)ia.width, (uint32_t)ia.height, 4, rgba, &o, out);
    }
    free(ia.rgba);
    free(ib.rgba);
    return st;
}

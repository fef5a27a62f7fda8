/* PNG written by the kernel through libpng, without the image module
 * (whose OpenImageIO start cost a small render 0.3 s and 120 MiB): the
 * first three channels (or the one, as grey in R, G and B) clamped to
 * [0, 1], sRGB-encoded to 8 bits, with an sRGB chunk, as the module wrote
 * them. */
#include "image.h"

#include <math.h>
#include <png.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The sRGB OETF for l in [0, 1], to the nearest of 256 codes. */
static unsigned char srgb_code(float v)
{
    double l = v > 0.0f ? (v < 1.0f ? (double)v : 1.0) : 0.0; /* NaN -> 0 */
    double c = l <= 0.0031308 ? 12.92 * l : 1.055 * pow(l, 1.0 / 2.4) - 0.055;
    return (unsigned char)lround(255.0 * c);
}

typedef struct png_sink {
    const rtk_image_write_job *job;
    uint64_t offset;
    char why[256]; /* libpng's error message */
    jmp_buf jump;
} png_sink;

/* A failed write is reported to libpng as done; the file keeps the failure
 * (file->err) for rtk_image_write to report. */
static void sink_write(png_structp png, png_bytep data, size_t size)
{
    png_sink *sink = png_get_io_ptr(png);
    sink->job->write_at(sink->job->file, data, size, sink->offset);
    sink->offset += size;
}

static void sink_flush(png_structp png)
{
    (void)png;
}

static void sink_error(png_structp png, png_const_charp message)
{
    png_sink *sink = png_get_error_ptr(png);
    snprintf(sink->why, sizeof sink->why, "%s", message ? message : "unknown libpng error");
    longjmp(sink->jump, 1);
}

static void sink_warning(png_structp png, png_const_charp message)
{
    (void)png;
    (void)message;
}

rtk_status rtk_png_encode(const rtk_image_write_job *job)
{
    const size_t w = (size_t)job->width, n = (size_t)job->nchannels;
    unsigned char *row = malloc(w * 3);
    if (!row)
        return rtk_error(RTK_ERR_NOMEM, "cannot write image '%s': out of memory for a row", job->path);
    png_sink sink = {.job = job};
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &sink, sink_error, sink_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!png || !info) {
        png_destroy_write_struct(&png, NULL);
        free(row);
        return rtk_error(RTK_ERR_NOMEM, "cannot write image '%s': out of memory for libpng", job->path);
    }
    if (setjmp(sink.jump)) {
        png_destroy_write_struct(&png, &info);
        free(row);
        return rtk_error(RTK_ERR_IO, "cannot write image '%s': %s", job->path, sink.why);
    }
    png_set_write_fn(png, &sink, sink_write, sink_flush);
    png_set_IHDR(png, info, (png_uint_32)job->width, (png_uint_32)job->height, 8, PNG_COLOR_TYPE_RGB,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_sRGB(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    png_text software = {.compression = PNG_TEXT_COMPRESSION_NONE, .key = "Software", .text = "rtk"};
    png_set_text(png, info, &software, 1);
    png_write_info(png, info);
    for (int y = 0; y < job->height; y++) {
        const float *src = job->pixels + (size_t)y * w * n;
        for (size_t x = 0; x < w; x++)
            for (size_t c = 0; c < 3; c++)
                row[3 * x + c] = srgb_code(src[x * n + (n >= 3 ? c : 0)]);
        png_write_row(png, row);
    }
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    free(row);
    return RTK_OK;
}

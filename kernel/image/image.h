/* Images in and out: the magic-byte format check (image_format.c),
 * decoding and encoding through OpenImageIO in the image module
 * (image_module.cpp, rtk_image.so), loaded on first use (image.c), and
 * the formats renders write most, written by the kernel itself (PFM,
 * OpenEXR, PNG: image_pfm.c, image_exr.cpp, image_png.c). */
#ifndef RTK_KERNEL_IMAGE_H
#define RTK_KERNEL_IMAGE_H

#include "../core/core.h"

RTK_EXTERN_C_BEGIN

/* Decoded image (io/image.cpp). */
typedef struct rtk_image {
    int width, height;
    float *rgba; /* linear RGBA floats, row-major from the top; [caller frees with free()] */
    int channels;  /* in the file: 1 grey, 2 grey + alpha, 3 RGB, 4 RGBA, more with extra layers */
    int has_alpha; /* the file has an alpha channel (else A reads as 1) */
} rtk_image;

/* An encoded image, recognised by its first bytes as one of the formats
 * rtk decodes (image_format.c) and its header checked. */
typedef struct rtk_image_source {
    const char *name;           /* the file, or the embedded image's name, for messages */
    const unsigned char *bytes; /* the encoded image */
    size_t count;
    unsigned char *owned;       /* bytes when they were read from the file */
    const char *format;         /* OpenImageIO's name of the format ("png") */
    const char *format_label;   /* its name in messages ("PNG") */
    int width, height;          /* from the header */
} rtk_image_source;

/* Reads the regular file path (bytes == NULL) or takes the bytes (not
 * copied), and checks them (rtk_image_source_check). [close after] */
rtk_status rtk_image_source_open(const char *path, const void *bytes, size_t byte_count, rtk_image_source *src);
/* Sets format and size from bytes: one of PNG, JPEG, OpenEXR, Radiance
 * HDR, TIFF, BMP, TGA (a .tga name), PNM, with its header walked (a
 * truncated PNG or PNM is refused here); anything else is an error naming
 * the formats. */
rtk_status rtk_image_source_check(rtk_image_source *src);
/* Decodes src through OpenImageIO's reader of src->format alone. */
rtk_status rtk_image_source_decode(const rtk_image_source *src, int srgb, rtk_image *out);
void rtk_image_source_close(rtk_image_source *src);

/* Decodes a file (bytes == NULL) or an in-memory encoded image through
 * OpenImageIO into linear RGBA; srgb: the 8-bit data is sRGB-encoded.
 * This and rtk_image_write load the image module on first use
 * (kernel/image/image.c); a module that cannot load is an RTK_ERR_IO naming it. */
RTK_KERNEL_API rtk_status rtk_image_read(const char *path, const void *bytes, size_t byte_count, int srgb,
                                         rtk_image *out);

/* Writes pixels (nchannels floats per pixel, linear) to path, format from
 * the extension (through OpenImageIO for all but PFM, OpenEXR and PNG).
 * EXR keeps linear floats (half when half != 0) with the given channel
 * names; PNG/JPEG get the first 3 channels sRGB-encoded to 8 bits. Writes path's ".tmp" sibling with the
 * same extension and renames it, so a failure never leaves a partial file. */
RTK_KERNEL_API rtk_status rtk_image_write(const char *path, int width, int height, int nchannels,
                                          const char *const *channel_names, const float *pixels, int half);

/* ---- image outputs (image.c, image_module.cpp) ---- */

/* One call of the image module's writer: encodes pixels in the format of
 * path's extension and hands every byte to write_at (into file), or with
 * pixels NULL only checks that this image can be written. */
typedef struct rtk_image_write_job {
    const char *path;                   /* the target; its extension picks the format */
    int width, height, nchannels;       /* 0 when not known yet (check only) */
    const char *const *channel_names;   /* EXR channel names, NULL: OpenImageIO's */
    const float *pixels;                /* NULL: check only */
    int half;                           /* EXR half floats */
    rtk_temp_file *file;                /* the open temporary */
    int (*write_at)(rtk_temp_file *file, const void *data, size_t size, uint64_t offset);
} rtk_image_write_job;

/* Checks, before anything is rendered, that an image of width x height
 * (0: unknown) with nchannels can be written to path: the directory (as
 * rtk_output_check), an extension OpenImageIO writes through rtk's checked
 * writes, and the format's size limits. */
rtk_status rtk_image_check_output(const char *path, int width, int height, int nchannels);

/* The formats the kernel writes itself, chosen by image.c from the
 * extension (.pfm, .exr, .png, any case): PFM (image_pfm.c, with whether
 * an image of nchannels, 0: unknown, fits one), OpenEXR (image_exr.cpp,
 * OpenEXR's library) and PNG (image_png.c, libpng). The encoders are
 * called as the module's is, with a size already checked. */
rtk_status rtk_pfm_check(const char *path, int nchannels);
rtk_status rtk_pfm_encode(const rtk_image_write_job *job);
rtk_status rtk_exr_encode(const rtk_image_write_job *job);
rtk_status rtk_png_encode(const rtk_image_write_job *job);

RTK_EXTERN_C_END

#endif

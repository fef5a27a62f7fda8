/* Test helpers that use OpenImageIO directly (oiio_check.cpp). */
#ifndef RTK_TEST_OIIO_CHECK_H
#define RTK_TEST_OIIO_CHECK_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Writes raw 8- or 16-bit pixels (no conversion), tagging the file with
 * colour_space when not NULL; 1 on success. */
int check_write_raw(const char *path, int width, int height, int nchannels, int bits,
                    const char *colour_space, const void *data);

/* check_write_raw for 8-bit pixels without a colour space tag. */
#define check_write_u8(path, width, height, nchannels, data) \
    check_write_raw(path, width, height, nchannels, 8, NULL, data)

/* Opens path with OIIO: names gets the channel names joined by ',', format
 * the pixel type; when channel != NULL, value gets that channel at (x, y).
 * Returns the channel count, -1 on failure. */
int check_exr_channels(const char *path, char *names, size_t names_size, const char *channel, int x,
                       int y, float *value, char *format, size_t format_size);

#ifdef __cplusplus
}
#endif

#endif

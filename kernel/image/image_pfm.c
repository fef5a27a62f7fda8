/* PFM (portable float map) written by the kernel itself, without the
 * image module: linear floats with no library behind them, so a machine
 * that carries rtk without OpenImageIO (tools/gpu-check) still writes its
 * renders. RGB ("PF") or grey ("Pf"), little-endian (scale -1), rows from
 * the bottom up, as the format has them. */
#include "image.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

rtk_status rtk_pfm_check(const char *path, int nchannels)
{
    if (nchannels != 0 && nchannels != 1 && nchannels != 3)
        return rtk_error(RTK_ERR_INVALID, "cannot write image '%s': a PFM holds 1 or 3 channels, this image has %d "
                         "(AOV layers need an .exr output)", path, nchannels);
    return RTK_OK;
}

rtk_status rtk_pfm_encode(const rtk_image_write_job *job)
{
    char header[64];
    int len = snprintf(header, sizeof header, "P%c\n%d %d\n-1.0\n", job->nchannels == 3 ? 'F' : 'f', job->width,
                       job->height);
    const size_t row = (size_t)job->width * (size_t)job->nchannels;
    unsigned char *bytes = malloc(row * 4);
    if (!bytes)
        return rtk_error(RTK_ERR_NOMEM, "cannot write image '%s': out of memory for a row", job->path);
    int failed = !job->write_at(job->file, header, (size_t)len, 0);
    for (int y = 0; y < job->height && !failed; y++) {
        const float *src = job->pixels + (size_t)(job->height - 1 - y) * row;
        for (size_t i = 0; i < row; i++) {
            uint32_t bits;
            memcpy(&bits, &src[i], 4);
            for (int k = 0; k < 4; k++)
                bytes[4 * i + (size_t)k] = (unsigned char)(bits >> (8 * k));
        }
        failed = !job->write_at(job->file, bytes, row * 4, (uint64_t)len + (uint64_t)y * row * 4);
    }
    free(bytes);
    return failed ? rtk_error(RTK_ERR_IO, "cannot write image '%s'", job->path) : RTK_OK;
}

/* Fuzz target: a texture file, through the format check of its first
 * bytes and header (image_format.c) and OpenImageIO's reader of the format
 * it names (the image module), as a scene's textures are read. The file is
 * named .tga, so bytes with no other format's magic are read as TGA.
 * Seeds: tests/fuzz/seeds/images, one 4x3 image per format (oiiotool
 * --pattern fill, written in each format; rgb.pfm by hand). */
#include "fuzz_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static int ready;
    if (!ready) {
        fuzz_quiet();
        ready = 1;
    }
    const char *path = fuzz_write("fuzz.tga", data, size);
    rtk_image image;
    if (rtk_image_read(path, NULL, 0, 1, &image) == RTK_OK)
        free(image.rgba);
    return 0;
}

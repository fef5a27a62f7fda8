/* Independent OpenImageIO access for test_image.c: writes raw 8-bit images
 * and reads back what rtk wrote, so the tests do not check rtk with rtk. */
#include <OpenImageIO/imageio.h>

#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "oiio_check.h"

using OIIO::ImageInput;
using OIIO::ImageOutput;
using OIIO::ImageSpec;
using OIIO::TypeDesc;

extern "C" int check_write_raw(const char *path, int width, int height, int nchannels, int bits,
                               const char *colour_space, const void *data)
{
    try {
        auto out = ImageOutput::create(path);
        if (!out)
            return 0;
        TypeDesc type = bits == 16 ? TypeDesc::UINT16 : TypeDesc::UINT8;
        ImageSpec spec(width, height, nchannels, type);
        if (nchannels == 2)
            spec.alpha_channel = 1;
        spec.attribute("oiio:UnassociatedAlpha", 1); /* store the values as given */
        if (colour_space)
            spec.attribute("oiio:ColorSpace", colour_space);
        bool ok = out->open(path, spec) && out->write_image(type, data) && out->close();
        if (!ok)
            std::fprintf(stderr, "check_write_raw: %s\n", out->geterror().c_str());
        return ok ? 1 : 0;
    } catch (...) {
        return 0;
    }
}

extern "C" int check_exr_channels(const char *path, char *names, size_t names_size,
                                  const char *channel, int x, int y, float *value, char *format,
                                  size_t format_size)
{
    try {
        auto in = ImageInput::open(path);
        if (!in)
            return -1;
        ImageSpec spec = in->spec();
        std::string joined;
        int index = -1;
        for (int c = 0; c < spec.nchannels; c++) {
            if (c)
                joined += ',';
            joined += spec.channelnames[size_t(c)];
            if (channel && spec.channelnames[size_t(c)] == channel)
                index = c;
        }
        std::snprintf(names, names_size, "%s", joined.c_str());
        std::snprintf(format, format_size, "%s", spec.format.c_str());
        if (channel) {
            if (index < 0)
                return -1;
            std::vector<float> px(size_t(spec.width) * size_t(spec.height) * size_t(spec.nchannels));
            if (!in->read_image(0, 0, 0, spec.nchannels, TypeDesc::FLOAT, px.data()))
                return -1;
            *value = px[(size_t(y) * size_t(spec.width) + size_t(x)) * size_t(spec.nchannels) + size_t(index)];
        }
        return spec.nchannels;
    } catch (...) {
        return -1;
    }
}

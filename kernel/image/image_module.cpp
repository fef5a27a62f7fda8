/* Image decode and encode through OpenImageIO, behind the C interface of
 * image.h. This file is its own module (rtk_image.so), which librtk
 * loads the first time an image is read or written (kernel/image/image.c):
 * OpenImageIO brings some 250 libraries whose symbol binding took most
 * of every rtk process's start (0.4 s). Rules for this file: no exception
 * leaves it (every entry point catches everything and turns it into an
 * rtk_status), and every error names the file (or the embedded image's
 * name) and the reason. */
#include "image.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <OpenImageIO/strutil.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <new>
#include <string>
#include <vector>

#include <sys/stat.h>
#include <unistd.h>

namespace {

using OIIO::ImageInput;
using OIIO::ImageOutput;
using OIIO::ImageSpec;
using OIIO::TypeDesc;

/* 16k x 16k: a bigger texture or output is a hostile or broken file. */
const uint64_t max_pixels = uint64_t(1) << 28;

/* The sRGB EOTF (IEC 61966-2-1): encoded value to linear. */
double srgb_to_linear(double c)
{
    return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

/* The sRGB OETF: linear to encoded, for values in [0, 1]. */
double linear_to_srgb(double l)
{
    return l <= 0.0031308 ? 12.92 * l : 1.055 * std::pow(l, 1.0 / 2.4) - 0.055;
}

/* OIIO's messages may span lines; one line reads better inside ours. */
std::string one_line(std::string text)
{
    while (!text.empty() && (text.back() == '\n' || text.back() == ' '))
        text.pop_back();
    for (char &c : text)
        if (c == '\n')
            c = ' ';
    return text.empty() ? std::string("unknown OpenImageIO error") : text;
}

/* How stored integer colour values become linear. */
enum class Transfer { none, srgb, gamma };

/* Chooses the transfer for the colour channels of an integer image whose
 * caller says it holds sRGB colour, honouring what the file declares. */
Transfer pick_transfer(const ImageSpec &spec, double *gamma)
{
    std::string cs = spec.get_string_attribute("oiio:ColorSpace");
    static const char *const linear_names[] = {"linear", "scene_linear", "lin_srgb",
                                               "lin_rec709", "acescg", "raw"};
    for (const char *name : linear_names)
        if (OIIO::Strutil::iequals(cs, name))
            return Transfer::none;
    if (OIIO::Strutil::istarts_with(cs, "GammaCorrected")) {
        double g = std::atof(cs.c_str() + std::strlen("GammaCorrected"));
        if (!(g > 0.0))
            g = spec.get_float_attribute("oiio:Gamma", 0.0f);
        if (g > 0.0 && g < 10.0) {
            *gamma = g;
            return g == 1.0 ? Transfer::none : Transfer::gamma;
        }
    }
    return Transfer::srgb;
}

/* Table mapping every code of an n-bit channel to linear. */
std::vector<float> make_table(size_t codes, Transfer transfer, double gamma)
{
    std::vector<float> table(codes);
    double top = double(codes - 1);
    for (size_t i = 0; i < codes; i++) {
        double c = double(i) / top;
        if (transfer == Transfer::srgb)
            c = srgb_to_linear(c);
        else if (transfer == Transfer::gamma)
            c = std::pow(c, gamma);
        table[i] = float(c);
    }
    return table;
}

/* Which source channel feeds each of R, G, B, A (-1: constant 1 for A). */
struct ChannelMap {
    int src[4];
    int read_count; /* channels [0, read_count) are read from the file */
};

ChannelMap map_channels(const ImageSpec &spec)
{
    int n = spec.nchannels;
    if (n == 1)
        return {{0, 0, 0, -1}, 1};
    if (n == 2)
        return {{0, 0, 0, 1}, 2};
    if (n == 3)
        return {{0, 1, 2, -1}, 3};
    /* Channel 3 is alpha when the file says so, or when there are exactly
     * four channels and it says nothing; OIIO puts A right after RGB. */
    bool alpha = spec.alpha_channel == 3 || (spec.alpha_channel < 0 && n == 4);
    return {{0, 1, 2, alpha ? 3 : -1}, alpha ? 4 : 3};
}

/* Reads one channel value of pixel i stored as T, without aliasing games. */
template <typename T> T load(const unsigned char *base, size_t index)
{
    T v;
    std::memcpy(&v, base + index * sizeof(T), sizeof(T));
    return v;
}

/* Expands pixels stored as read_count channels of T at the front of rgba
 * into 4 floats each, in place. Going from the last pixel to the first is
 * safe because a stored pixel is never larger than the 16 bytes it becomes,
 * so a pixel's output never overlaps a stored pixel not yet expanded. */
template <typename T, typename Colour, typename Alpha>
void expand(float *rgba, size_t pixels, const ChannelMap &map, Colour colour, Alpha alpha)
{
    const unsigned char *base = reinterpret_cast<const unsigned char *>(rgba);
    size_t n = size_t(map.read_count);
    for (size_t i = pixels; i-- > 0;) {
        T v[4];
        for (size_t c = 0; c < n; c++)
            v[c] = load<T>(base, i * n + c);
        float out[4];
        for (int c = 0; c < 3; c++)
            out[c] = colour(v[map.src[c]]);
        out[3] = map.src[3] < 0 ? 1.0f : alpha(v[map.src[3]]);
        std::memcpy(rgba + 4 * i, out, sizeof out);
    }
}

rtk_status read_image(const char *name, const void *bytes, size_t byte_count, const char *format, int srgb,
                      rtk_image *out)
{
    if (!bytes || byte_count == 0)
        return rtk_error(RTK_ERR_PARSE, "cannot read image '%s': the data is empty", name);

    /* Straight (unassociated) alpha as stored: OIIO would otherwise
     * premultiply PNG/TGA/TIFF colour, and do it on encoded values. */
    ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    /* OIIO 2.4's open() with a config drops its ioproxy argument; the
     * proxy must also travel in the config to reach the reader. */
    OIIO::Filesystem::IOMemReader memory(bytes, byte_count);
    void *proxy = &memory;
    config.attribute("oiio:ioproxy", TypeDesc::PTR, &proxy);
    /* The reader of the format the kernel recognised, and no other: OIIO's
     * open() by name would probe the bytes with every reader it has. */
    auto in = ImageInput::create(format, false, &config, &memory);
    ImageSpec opened;
    if (!in || !in->open(name, opened, config)) {
        std::string why = one_line(in ? in->geterror() : OIIO::geterror());
        OIIO::geterror();
        return rtk_error(RTK_ERR_PARSE, "cannot read image '%s' as %s: %s", name, format, why.c_str());
    }

    const ImageSpec spec = in->spec(); /* a copy: close() may reset the reader's */
    if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0)
        return rtk_error(RTK_ERR_PARSE,
                         "cannot read image '%s': it has no pixels (%dx%d, %d channels)", name,
                         spec.width, spec.height, spec.nchannels);
    if (spec.depth > 1)
        return rtk_error(RTK_ERR_UNSUPPORTED,
                         "cannot read image '%s': volume images (depth %d) are not supported", name,
                         spec.depth);
    uint64_t pixels = uint64_t(spec.width) * uint64_t(spec.height);
    if (pixels > max_pixels)
        return rtk_error(RTK_ERR_NOMEM,
                         "cannot read image '%s': %dx%d pixels is over the limit of %llu (16k x 16k)",
                         name, spec.width, spec.height, (unsigned long long)max_pixels);

    ChannelMap map = map_channels(spec);
    TypeDesc::BASETYPE base = TypeDesc::BASETYPE(spec.format.basetype);
    bool integer = !spec.format.is_floating_point();
    Transfer transfer = Transfer::none;
    double gamma = 1.0;
    if (srgb && integer)
        transfer = pick_transfer(spec, &gamma);

    TypeDesc read_type = TypeDesc::FLOAT;
    if (spec.channelformats.empty() && base == TypeDesc::UINT8)
        read_type = TypeDesc::UINT8;
    else if (spec.channelformats.empty() && base == TypeDesc::UINT16)
        read_type = TypeDesc::UINT16;

    size_t count = size_t(pixels) * 4;
    std::unique_ptr<float, void (*)(void *)> buffer(static_cast<float *>(std::malloc(count * sizeof(float))),
                                                    std::free);
    float *rgba = buffer.get();
    if (!rgba)
        return rtk_error(RTK_ERR_NOMEM, "cannot read image '%s': out of memory for %dx%d pixels", name,
                         spec.width, spec.height);
    if (!in->read_image(0, 0, 0, map.read_count, read_type, rgba)) {
        std::string why = one_line(in->geterror());
        OIIO::geterror();
        return rtk_error(RTK_ERR_PARSE, "cannot read image '%s': %s", name, why.c_str());
    }
    in->close();
    in->geterror();

    if (read_type == TypeDesc::UINT8) {
        std::vector<float> colour = make_table(256, transfer, gamma);
        std::vector<float> linear = make_table(256, Transfer::none, 1.0);
        auto c = [&](unsigned v) { return colour[v]; };
        auto a = [&](unsigned v) { return linear[v]; };
        expand<uint8_t>(rgba, size_t(pixels), map, c, a);
    } else if (read_type == TypeDesc::UINT16) {
        std::vector<float> colour = make_table(65536, transfer, gamma);
        std::vector<float> linear = make_table(65536, Transfer::none, 1.0);
        auto c = [&](unsigned v) { return colour[v]; };
        auto a = [&](unsigned v) { return linear[v]; };
        expand<uint16_t>(rgba, size_t(pixels), map, c, a);
    } else {
        auto c = [&](float v) {
            if (transfer == Transfer::srgb)
                return float(srgb_to_linear(v));
            if (transfer == Transfer::gamma)
                return v > 0.0f ? float(std::pow(double(v), gamma)) : v;
            return v;
        };
        auto a = [](float v) { return v; };
        expand<float>(rgba, size_t(pixels), map, c, a);
    }

    out->width = spec.width;
    out->height = spec.height;
    out->channels = spec.nchannels;
    out->has_alpha = map.src[3] >= 0;
    out->rgba = buffer.release();
    return RTK_OK;
}

/* Index of the channel named name, or -1. */
int find_channel(const std::vector<std::string> &names, const char *name)
{
    for (size_t i = 0; i < names.size(); i++)
        if (names[i] == name)
            return int(i);
    return -1;
}

/* The bytes OpenImageIO encodes go through rtk's checked writes into the
 * temporary file. A failed write is reported to the encoder as done: the
 * failure is kept in the file (file->err) and reported after close, so no
 * encoder reaches an error path of its library that ends the process
 * (libjpeg's default error_exit calls exit(1)). */
class TempFileProxy : public OIIO::Filesystem::IOProxy {
public:
    explicit TempFileProxy(const rtk_image_write_job &job) : IOProxy(job.file->tmp, Write), job_(job) {}
    const char *proxytype() const override { return "rtk-temp"; }
    size_t write(const void *buf, size_t size) override
    {
        size_t n = pwrite(buf, size, m_pos);
        m_pos += int64_t(n);
        return n;
    }
    size_t pwrite(const void *buf, size_t size, int64_t offset) override
    {
        if (offset < 0)
            return 0;
        job_.write_at(job_.file, buf, size, uint64_t(offset));
        if (uint64_t(offset) + size > end_)
            end_ = uint64_t(offset) + size;
        return size;
    }
    size_t read(void *buf, size_t size) override
    {
        size_t n = pread(buf, size, m_pos);
        m_pos += int64_t(n);
        return n;
    }
    size_t pread(void *buf, size_t size, int64_t offset) override
    {
        size_t done = 0;
        while (offset >= 0 && done < size) {
            ssize_t n = ::pread(job_.file->fd, static_cast<char *>(buf) + done, size - done, off_t(offset) + off_t(done));
            if (n < 0 && errno == EINTR)
                continue;
            if (n <= 0)
                break;
            done += size_t(n);
        }
        return done;
    }
    size_t size() const override { return size_t(end_); }
    uint64_t bytes() const { return end_; }

private:
    const rtk_image_write_job &job_;
    uint64_t end_ = 0;
};

/* Largest width or height libjpeg encodes (JPEG_MAX_DIMENSION); above it
 * libjpeg's error path would call exit(). */
const int jpeg_max_dimension = 65500;

/* The formats rtk writes (OpenImageIO's names), and their extensions for
 * messages: those rtk also reads back, each written through checked writes
 * (TIFF by name, then read back, see write_image). */
const char *const writable_formats[] = {"openexr", "png", "jpeg", "hdr", "tiff", "targa", "bmp", "pnm"};
const char *const writable_list = ".exr, .pfm, .png, .jpg, .hdr, .tif, .tga, .bmp or .ppm"; /* .pfm: image_pfm.c */

/* Reads the TIFF at file back and compares its pixels with expected (8-bit
 * RGB): proof that a write the library reported done is whole. */
bool read_back_matches(const std::string &file, int width, int height, const std::vector<unsigned char> &expected,
                       std::string *why)
{
    auto in = ImageInput::open(file);
    if (!in) {
        *why = one_line(OIIO::geterror());
        return false;
    }
    const ImageSpec spec = in->spec();
    std::vector<unsigned char> got(expected.size());
    bool ok = spec.width == width && spec.height == height && spec.nchannels >= 3 &&
              in->read_image(0, 0, 0, 3, TypeDesc::UINT8, got.data());
    if (!ok)
        *why = one_line(in->geterror());
    in->close();
    in->geterror();
    if (ok && got != expected) {
        *why = "the file read back differs from the image written";
        ok = false;
    }
    return ok;
}

/* Checks that job's image can be written, then (pixels given) encodes it
 * through a TempFileProxy. */
rtk_status write_image(const rtk_image_write_job &job)
{
    const char *path = job.path;
    int width = job.width, height = job.height, nchannels = job.nchannels;
    if (width < 0 || height < 0 || nchannels < 0 || (job.pixels && (width == 0 || height == 0 || nchannels == 0)))
        return rtk_error(RTK_ERR_INVALID, "cannot write image '%s': bad size %dx%d with %d channels",
                         path, width, height, nchannels);
    uint64_t pixel_count = uint64_t(width) * uint64_t(height);
    if (pixel_count > max_pixels || nchannels > 1024)
        return rtk_error(RTK_ERR_NOMEM, "cannot write image '%s': %dx%d with %d channels is too large",
                         path, width, height, nchannels);

    std::string target(path);
    size_t slash = target.rfind('/');
    size_t start = slash == std::string::npos ? 0 : slash + 1;
    size_t dot = target.rfind('.');
    if (dot == std::string::npos || dot <= start || dot + 1 == target.size())
        return rtk_error(RTK_ERR_UNSUPPORTED,
                         "cannot write image '%s': the file name has no extension to pick a format (use %s)", path,
                         writable_list);
    std::string ext = target.substr(dot);

    auto output = ImageOutput::create(target);
    if (!output) {
        OIIO::geterror();
        return rtk_error(RTK_ERR_UNSUPPORTED, "cannot write image '%s': OpenImageIO has no writer for '%s' (use %s)",
                         path, ext.c_str(), writable_list);
    }
    std::string format = output->format_name();
    bool known = false;
    for (const char *name : writable_formats)
        known = known || format == name;
    if (!known)
        return rtk_error(RTK_ERR_UNSUPPORTED,
                         "cannot write image '%s': rtk does not write %s files (it writes and reads back %s)", path,
                         format.c_str(), writable_list);
    /* OIIO 2.4's TIFF writer cannot rewrite its directory through a proxy
     * (it reads nothing back), so TIFF goes by name and is read back. */
    bool by_name = format == "tiff";
    if (!by_name && !output->supports("ioproxy"))
        return rtk_error(RTK_ERR_UNSUPPORTED,
                         "cannot write image '%s': OpenImageIO's %s writer cannot write through rtk's checked writes, "
                         "so a full disk could go unnoticed (use %s)",
                         path, format.c_str(), writable_list);
    if (format == "jpeg" && (width > jpeg_max_dimension || height > jpeg_max_dimension))
        return rtk_error(RTK_ERR_UNSUPPORTED,
                         "cannot write image '%s': %dx%d is larger than JPEG allows (%d pixels a side); use .exr or .png",
                         path, width, height, jpeg_max_dimension);
    if (!job.pixels)
        return RTK_OK;
    if (!job.file || job.file->fd < 0 || !job.write_at)
        return rtk_error(RTK_ERR_INVALID, "cannot write image '%s': no temporary file to write to", path);

    size_t count = size_t(pixel_count);
    const float *pixels = job.pixels;
    ImageSpec spec;
    const void *data = pixels;
    TypeDesc data_type = TypeDesc::FLOAT;
    std::vector<float> rgb;
    std::vector<unsigned char> bytes8;
    if (format == "openexr") {
        spec = ImageSpec(width, height, nchannels, job.half ? TypeDesc::HALF : TypeDesc::FLOAT);
        if (job.channel_names) {
            spec.channelnames.clear();
            for (int c = 0; c < nchannels; c++) {
                const char *name = job.channel_names[c];
                if (!name || !name[0])
                    return rtk_error(RTK_ERR_INVALID, "cannot write image '%s': channel %d has no name",
                                     path, c);
                if (find_channel(spec.channelnames, name) >= 0)
                    return rtk_error(RTK_ERR_INVALID,
                                     "cannot write image '%s': channel name '%s' is used twice", path, name);
                spec.channelnames.push_back(name);
            }
            spec.alpha_channel = find_channel(spec.channelnames, "A");
            spec.z_channel = find_channel(spec.channelnames, "Z");
        }
        spec.attribute("oiio:ColorSpace", "Linear");
    } else if (format == "hdr") {
        /* RGBE holds exactly three linear float channels. */
        spec = ImageSpec(width, height, 3, TypeDesc::FLOAT);
        rgb.resize(count * 3);
        for (size_t i = 0; i < count; i++)
            for (size_t c = 0; c < 3; c++)
                rgb[3 * i + c] = pixels[i * size_t(nchannels) + (nchannels >= 3 ? c : 0)];
        data = rgb.data();
        spec.attribute("oiio:ColorSpace", "Linear");
    } else {
        spec = ImageSpec(width, height, 3, TypeDesc::UINT8);
        bytes8.resize(count * 3);
        for (size_t i = 0; i < count; i++) {
            for (size_t c = 0; c < 3; c++) {
                float v = pixels[i * size_t(nchannels) + (nchannels >= 3 ? c : 0)];
                double l = v > 0.0f ? (v < 1.0f ? double(v) : 1.0) : 0.0; /* NaN -> 0 */
                bytes8[3 * i + c] = (unsigned char)std::lround(255.0 * linear_to_srgb(l));
            }
        }
        data = bytes8.data();
        data_type = TypeDesc::UINT8;
        spec.attribute("oiio:ColorSpace", "sRGB");
    }
    spec.attribute("Software", "rtk");

    TempFileProxy proxy(job);
    std::string why;
    int err = 0;
    bool ok = (by_name || output->set_ioproxy(&proxy)) && output->open(job.file->tmp, spec);
    if (ok) {
        ok = output->write_image(data_type, data);
        if (!ok) {
            err = errno;
            why = one_line(output->geterror());
            output->close();
        } else {
            ok = output->close();
            err = errno;
        }
    } else {
        err = errno;
    }
    if (!ok && why.empty())
        why = one_line(output->geterror());
    output->geterror();
    output.reset();
    if (!ok && by_name && (err == ENOSPC || err == EFBIG || err == EDQUOT || err == EIO)) {
        /* The library's message may not say why; its last failed write does. */
        job.file->err = err;
        return rtk_error(RTK_ERR_IO, "cannot write image '%s': %s (%s)", path, std::strerror(err), why.c_str());
    }
    if (!ok)
        return rtk_error(RTK_ERR_IO, "cannot write image '%s': %s", path, why.c_str());
    if (by_name && !read_back_matches(job.file->tmp, width, height, bytes8, &why))
        return rtk_error(RTK_ERR_IO, "cannot write image '%s': reading its temporary file back failed: %s", path,
                         why.c_str());
    if (!by_name && proxy.bytes() == 0)
        return rtk_error(RTK_ERR_IO, "cannot write image '%s': OpenImageIO's %s writer passed no bytes through rtk's "
                         "checked writes", path, format.c_str());
    return RTK_OK;
}

} // namespace

extern "C" RTK_EXPORT rtk_status rtk_image_module_read(const char *path, const void *bytes, size_t byte_count,
                                                      const char *format, int srgb, rtk_image *out)
{
    if (!out)
        return rtk_error(RTK_ERR_INVALID, "rtk_image_read: no output image given");
    out->width = out->height = 0;
    out->channels = out->has_alpha = 0;
    out->rgba = nullptr;
    if (!bytes || !format)
        return rtk_error(RTK_ERR_INVALID, "rtk_image_read: no image data or format given");
    const char *name = path ? path : "embedded image";
    try {
        return read_image(name, bytes, byte_count, format, srgb, out);
    } catch (const std::bad_alloc &) {
        return rtk_error(RTK_ERR_NOMEM, "cannot read image '%s': out of memory", name);
    } catch (const std::exception &e) {
        return rtk_error(RTK_ERR_PARSE, "cannot read image '%s': %s", name, e.what());
    } catch (...) {
        return rtk_error(RTK_ERR_PARSE, "cannot read image '%s': unknown failure in OpenImageIO", name);
    }
}

extern "C" RTK_EXPORT rtk_status rtk_image_module_encode(const rtk_image_write_job *job)
{
    if (!job || !job->path || !job->path[0])
        return rtk_error(RTK_ERR_INVALID, "rtk_image_write: no output file name given");
    const char *path = job->path;
    try {
        return write_image(*job);
    } catch (const std::bad_alloc &) {
        return rtk_error(RTK_ERR_NOMEM, "cannot write image '%s': out of memory", path);
    } catch (const std::exception &e) {
        return rtk_error(RTK_ERR_IO, "cannot write image '%s': %s", path, e.what());
    } catch (...) {
        return rtk_error(RTK_ERR_IO, "cannot write image '%s': unknown failure in OpenImageIO", path);
    }
}

/* OpenEXR written by the kernel through OpenEXR's own library, without the
 * image module: renders and AOVs are mostly EXR, and OpenImageIO's start
 * (some 250 libraries, 0.3 s and 120 MiB) was most of a small render's
 * time and memory. Scanline, ZIP, FLOAT or HALF channels named as given
 * (OpenImageIO's default names otherwise), as OpenImageIO wrote them, less
 * its capture date: the same render gives the same file. Rules as for
 * image_module.cpp: no exception leaves this file, every error names the
 * file. */
#include "image.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <Imath/half.h>

#include <new>
#include <set>
#include <string>
#include <vector>

namespace {

/* OpenEXR's bytes go through rtk's checked writes into the temporary
 * file. A failed write is reported to the library as done: the failure
 * is kept in the file (file->err) and reported after, as for the image
 * module's writers. */
class TempFileStream : public Imf::OStream {
public:
    explicit TempFileStream(const rtk_image_write_job &job) : OStream(job.file->tmp), job_(job) {}
    void write(const char c[], int n) override
    {
        if (n <= 0)
            return;
        job_.write_at(job_.file, c, size_t(n), pos_);
        pos_ += uint64_t(n);
        if (pos_ > end_)
            end_ = pos_;
    }
    uint64_t tellp() override { return pos_; }
    void seekp(uint64_t pos) override { pos_ = pos; }
    uint64_t bytes() const { return end_; }

private:
    const rtk_image_write_job &job_;
    uint64_t pos_ = 0, end_ = 0;
};

/* OpenImageIO's names for channels given none: Y alone, else R, G, B, A,
 * then channel4, channel5, ... */
std::string default_name(int c, int nchannels)
{
    static const char *const rgba[] = {"R", "G", "B", "A"};
    if (nchannels == 1)
        return "Y";
    if (c < 4)
        return rgba[c];
    return "channel" + std::to_string(c);
}

rtk_status encode(const rtk_image_write_job &job)
{
    const char *path = job.path;
    const int w = job.width, h = job.height, n = job.nchannels;
    std::vector<std::string> names;
    std::set<std::string> seen;
    for (int c = 0; c < n; c++) {
        const char *given = job.channel_names ? job.channel_names[c] : nullptr;
        if (job.channel_names && (!given || !given[0]))
            return rtk_error(RTK_ERR_INVALID, "cannot write image '%s': channel %d has no name", path, c);
        std::string name = given ? std::string(given) : default_name(c, n);
        if (!seen.insert(name).second)
            return rtk_error(RTK_ERR_INVALID, "cannot write image '%s': channel name '%s' is used twice", path,
                             name.c_str());
        names.push_back(name);
    }

    Imf::Header header(w, h);
    header.compression() = Imf::ZIP_COMPRESSION;
    header.insert("software", Imf::StringAttribute("rtk"));
    /* Each slice reads its channel from the interleaved pixels: the
     * floats, or their halves (rounded to nearest, ties to even). */
    Imf::FrameBuffer frame;
    std::vector<half> halves;
    const Imf::PixelType type = job.half ? Imf::HALF : Imf::FLOAT;
    const size_t size = job.half ? sizeof(half) : sizeof(float);
    const char *pixels = reinterpret_cast<const char *>(job.pixels);
    if (job.half) {
        const size_t count = size_t(w) * size_t(h) * size_t(n);
        halves.resize(count);
        for (size_t i = 0; i < count; i++)
            halves[i] = half(job.pixels[i]);
        pixels = reinterpret_cast<const char *>(halves.data());
    }
    const size_t x_stride = size * size_t(n), y_stride = x_stride * size_t(w);
    for (int c = 0; c < n; c++) {
        header.channels().insert(names[size_t(c)], Imf::Channel(type));
        char *base = const_cast<char *>(pixels) + size * size_t(c);
        frame.insert(names[size_t(c)], Imf::Slice(type, base, x_stride, y_stride));
    }

    TempFileStream stream(job);
    {
        Imf::OutputFile file(stream, header);
        file.setFrameBuffer(frame);
        file.writePixels(h);
    } /* the destructor writes the line offset table */
    if (stream.bytes() == 0)
        return rtk_error(RTK_ERR_IO, "cannot write image '%s': OpenEXR wrote no bytes", path);
    return RTK_OK;
}

} // namespace

rtk_status rtk_exr_encode(const rtk_image_write_job *job)
{
    const char *path = job->path;
    try {
        return encode(*job);
    } catch (const std::bad_alloc &) {
        return rtk_error(RTK_ERR_NOMEM, "cannot write image '%s': out of memory", path);
    } catch (const std::exception &e) {
        return rtk_error(RTK_ERR_IO, "cannot write image '%s': %s", path, e.what());
    } catch (...) {
        return rtk_error(RTK_ERR_IO, "cannot write image '%s': unknown failure in OpenEXR", path);
    }
}

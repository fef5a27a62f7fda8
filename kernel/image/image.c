/* rtk_image_read / rtk_image_write: the image adapter (image_module.cpp,
 * built as the module rtk_image.so with OpenImageIO) is loaded on first
 * use, and PFM, OpenEXR and PNG outputs are written without it. Linking
 * OpenImageIO into librtk put some 250 libraries into every rtk process,
 * and binding their symbols took 0.4 s of each start, also for commands
 * that never touch an image (`rtk plugins`, `rtk bench`, most of the test
 * suite). */
#include "image.h"

#include <dlfcn.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>
#include <string.h>
#include <strings.h>

typedef rtk_status (*image_read_fn)(const char *name, const void *bytes, size_t byte_count, const char *format,
                                    int srgb, rtk_image *out);
typedef rtk_status (*image_write_fn)(const rtk_image_write_job *job);

static pthread_once_t module_once = PTHREAD_ONCE_INIT;
static image_read_fn module_read;
static image_write_fn module_write;
static char module_problem[1024];

/* The build tree's module, or the one installed beside librtk (found from
 * librtk's own file, so any prefix, DESTDIR or moved tree works). [caller frees] */
static char *module_path(void)
{
    return rtk_running_from_build_tree() ? rtk_strdup(RTK_BUILD_IMAGE_MODULE)
                                         : rtk_installed_path(RTK_INSTALL_IMAGE_MODULE_SUBPATH);
}

static void load_module(void)
{
    char *path = module_path();
    if (!path) {
        snprintf(module_problem, sizeof module_problem, "the image adapter cannot be located (the file librtk was "
                 "loaded from is unknown): reinstall rtk");
        return;
    }
    /* Kept for the life of the process; RTLD_LOCAL: OpenImageIO's symbols
     * stay out of the plugins' way. */
    void *handle = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
        const char *why = dlerror();
        snprintf(module_problem, sizeof module_problem, "the image adapter %s cannot be loaded (%s); it is part "
                 "of rtk: rebuild or reinstall rtk", path, why ? why : "unknown reason");
    } else {
        image_read_fn r = (image_read_fn)dlsym(handle, "rtk_image_module_read");
        image_write_fn w = (image_write_fn)dlsym(handle, "rtk_image_module_encode");
        if (r && w) {
            module_read = r;
            module_write = w;
        } else {
            snprintf(module_problem, sizeof module_problem, "the image adapter %s lacks its entry points (a module "
                     "from another rtk version?): rebuild or reinstall rtk", path);
        }
    }
    free(path);
}

rtk_status rtk_image_source_open(const char *path, const void *bytes, size_t byte_count, rtk_image_source *src)
{
    memset(src, 0, sizeof *src);
    src->name = path ? path : "embedded image";
    if (!bytes) {
        size_t count;
        rtk_status st = rtk_file_read(path, "image", RTK_MAX_IMAGE_FILE, &src->owned, &count);
        if (st != RTK_OK)
            return st;
        src->bytes = src->owned;
        src->count = count;
    } else {
        src->bytes = bytes;
        src->count = byte_count;
    }
    if (!src->count)
        return rtk_error(RTK_ERR_PARSE, "cannot read image '%s': it is empty", src->name);
    return rtk_image_source_check(src);
}

void rtk_image_source_close(rtk_image_source *src)
{
    free(src->owned);
    src->owned = NULL;
    src->bytes = NULL;
}

rtk_status rtk_image_source_decode(const rtk_image_source *src, int srgb, rtk_image *out)
{
    pthread_once(&module_once, load_module);
    if (!module_read) {
        if (out)
            out->width = out->height = out->channels = out->has_alpha = 0, out->rgba = NULL;
        return rtk_error(RTK_ERR_IO, "cannot read image '%s': %s", src->name, module_problem);
    }
    return module_read(src->name, src->bytes, src->count, src->format, srgb, out);
}

rtk_status rtk_image_read(const char *path, const void *bytes, size_t byte_count, int srgb, rtk_image *out)
{
    if (out)
        out->width = out->height = out->channels = out->has_alpha = 0, out->rgba = NULL;
    rtk_image_source src;
    rtk_status st = rtk_image_source_open(path, bytes, byte_count, &src);
    if (st == RTK_OK)
        st = rtk_image_source_decode(&src, srgb, out);
    rtk_image_source_close(&src);
    return st;
}

/* 16k x 16k, as the image module's limit: a bigger output is a mistake. */
#define MAX_OUTPUT_PIXELS ((uint64_t)1 << 28)

typedef rtk_status (*own_encoder)(const rtk_image_write_job *job);

/* The encoder of a format librtk writes itself (PFM, OpenEXR, PNG: by
 * extension, any case), or NULL for the image module's formats. */
static own_encoder own_writer(const char *path)
{
    static const struct {
        const char *ext;
        own_encoder encode;
    } own[] = {{".pfm", rtk_pfm_encode}, {".exr", rtk_exr_encode}, {".png", rtk_png_encode}};
    const char *slash = strrchr(path, '/');
    const char *dot = strrchr(slash ? slash + 1 : path, '.');
    for (size_t i = 0; dot && i < sizeof own / sizeof own[0]; i++)
        if (strcasecmp(dot, own[i].ext) == 0)
            return own[i].encode;
    return NULL;
}

/* The image module's size checks, for the formats librtk writes. */
static rtk_status check_size(const char *path, int width, int height, int nchannels)
{
    if (width < 0 || height < 0 || nchannels < 0)
        return rtk_error(RTK_ERR_INVALID, "cannot write image '%s': bad size %dx%d with %d channels", path, width,
                         height, nchannels);
    if ((uint64_t)width * (uint64_t)height > MAX_OUTPUT_PIXELS || nchannels > 1024)
        return rtk_error(RTK_ERR_NOMEM, "cannot write image '%s': %dx%d with %d channels is too large", path, width,
                         height, nchannels);
    return RTK_OK;
}

rtk_status rtk_image_check_output(const char *path, int width, int height, int nchannels)
{
    if (!path || !path[0])
        return rtk_error(RTK_ERR_INVALID, "no output file name given");
    own_encoder own = own_writer(path);
    if (own) {
        rtk_status st = check_size(path, width, height, nchannels);
        if (st == RTK_OK && own == rtk_pfm_encode)
            st = rtk_pfm_check(path, nchannels);
        return st == RTK_OK ? rtk_output_check(path) : st;
    }
    pthread_once(&module_once, load_module);
    if (!module_write)
        return rtk_error(RTK_ERR_IO, "cannot write image '%s': %s", path, module_problem);
    rtk_image_write_job job = {.path = path, .width = width, .height = height, .nchannels = nchannels};
    rtk_status st = module_write(&job);
    return st == RTK_OK ? rtk_output_check(path) : st;
}

/* Where ".tmp<pid>-<n>" goes: before the extension, which picks the format. */
static size_t image_stem(const char *path)
{
    const char *slash = strrchr(path, '/');
    const char *dot = strrchr(slash ? slash + 1 : path, '.');
    return dot ? (size_t)(dot - path) : strlen(path);
}

rtk_status rtk_image_write(const char *path, int width, int height, int nchannels,
                           const char *const *channel_names, const float *pixels, int half)
{
    rtk_status st = rtk_image_check_output(path, width, height, nchannels);
    if (st != RTK_OK)
        return st;
    if (!pixels)
        return rtk_error(RTK_ERR_INVALID, "cannot write image '%s': no pixels given", path);
    own_encoder own = own_writer(path);
    if (own && (width == 0 || height == 0 || nchannels == 0))
        return rtk_error(RTK_ERR_INVALID, "cannot write image '%s': %dx%d with %d channels has no pixels", path,
                         width, height, nchannels);
    rtk_temp_file file;
    if ((st = rtk_temp_open(&file, path, image_stem(path))) != RTK_OK)
        return st;
    rtk_image_write_job job = {.path = path, .width = width, .height = height, .nchannels = nchannels,
                               .channel_names = channel_names, .pixels = pixels, .half = half,
                               .file = &file, .write_at = rtk_temp_write_at};
    st = own ? own(&job) : module_write(&job);
    if (st != RTK_OK && file.err)
        return rtk_temp_commit(&file, 1); /* a failed write is the cause: say which and why */
    if (st != RTK_OK) {
        char msg[2048];
        snprintf(msg, sizeof msg, "%s", rtk_error_message());
        int existed = access(path, F_OK) == 0;
        rtk_temp_commit(&file, 0);
        return rtk_error(st, "%s; its temporary file was removed and %s", msg,
                         existed ? "the previous file is unchanged" : "no file was written");
    }
    return rtk_temp_commit(&file, 1);
}

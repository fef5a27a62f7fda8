/* Hostile and broken files (kernel/core/files.c, kernel/scene/files.c,
 * kernel/image/image_format.c, kernel/scene/io/obj.cpp, kernel/scene/io/gltf.cpp,
 * kernel/scene/texture.c, kernel/core/log.c):
 * each input is made here, small, in a temporary folder. A watchdog
 * (alarm) turns a hang into a failure instead of a stuck test. */
#include "config/config.h"
#include "render/render.h"
#include "image/image.h"
#include "check.h"
#include "scratch.h"
#include "capture.h"

#include <errno.h>
#include <fcntl.h>
#include <ftw.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include <zlib.h>

static int has(const char *text, const char *part) { return text && part && strstr(text, part) != NULL; }

static void on_alarm(int sig)
{
    (void)sig;
    static const char msg[] = "FAIL  watchdog: a check took over its limit (a hang)\n";
    ssize_t n = write(1, msg, sizeof msg - 1);
    (void)n;
    _exit(1);
}

/* Runs under a watchdog of seconds (generous: each case takes well under
 * a second when it works; the defects hung or took minutes). */
static void watchdog(unsigned seconds) { alarm(seconds); }

static void test_obj_indices(void)
{
    const char *path = write_text("wrap.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4294967299\n");
    rtk_scene *s = NULL;
    rtk_status st = rtk_scene_load(path, 0, &s);
    check(st == RTK_ERR_PARSE && has(rtk_error_message(), "wrap.obj:4:") &&
              has(rtk_error_message(), "4294967299"),
          "face index 4294967299 is an error naming file, line and index (%s)", rtk_error_message());
    rtk_scene_free(s);
    path = write_text("neg.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n# comment\nf 1 2 2147483648\n");
    st = rtk_scene_load(path, 0, &s);
    check(st == RTK_ERR_PARSE && has(rtk_error_message(), "neg.obj:5:") && has(rtk_error_message(), "2147483648") &&
              !has(rtk_error_message(), "-2147483648"),
          "face index 2147483648 is reported as itself (%s)", rtk_error_message());
    rtk_scene_free(s);
    path = write_text("ok.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf -3 -2 -1\nf 1/0/0 2 3\n");
    st = rtk_scene_load(path, 0, &s);
    check(st == RTK_OK && s && s->triangle_count == 3, "indices that fit still load (%s)",
          st == RTK_OK ? "loaded" : rtk_error_message());
    rtk_scene_free(s);
}

/* Polygon of n corners on a circle (convex) or with every other corner
 * pulled in (a star: not convex). */
static const char *polygon_obj(const char *name, size_t n, int star)
{
    const char *path = in_tmp(name);
    FILE *f = fopen(path, "w");
    for (size_t i = 0; i < n; i++) {
        double a = 2.0 * 3.14159265358979 * (double)i / (double)n, r = star && (i & 1) ? 0.5 : 1.0;
        fprintf(f, "v %.9f %.9f 0\n", r * cos(a), r * sin(a));
    }
    fputs("f", f);
    for (size_t i = 1; i <= n; i++)
        fprintf(f, " %zu", i);
    fputs("\n", f);
    fclose(f);
    return path;
}

/* One face of n corners going round the unit cube's corners cycle[0..k)
 * again and again, with corner at (if below n) moved off their plane to
 * cube corner 2 (OBJ numbering). */
static const char *cycle_obj(const char *name, const int *cycle, size_t k, size_t n, size_t at)
{
    const char *path = in_tmp(name);
    FILE *f = fopen(path, "w");
    for (int v = 0; v < 8; v++)
        fprintf(f, "v %d %d %d\n", v & 1, (v >> 1) & 1, (v >> 2) & 1);
    fputs("f", f);
    for (size_t i = 0; i < n; i++)
        fprintf(f, " %d", i == at ? 2 : cycle[i % k]);
    fputs("\n", f);
    fclose(f);
    return path;
}

static void test_polygons(void)
{
    /* A convex hexagon: ear clipping's fan around the last corner. */
    rtk_scene *s = NULL;
    rtk_status st = rtk_scene_load(polygon_obj("hexagon.obj", 6, 0), 0, &s);
    static const uint32_t hexagon[12] = {5, 0, 1, 5, 1, 2, 5, 2, 3, 3, 4, 5};
    check(st == RTK_OK && s->triangle_count == 4 && memcmp(s->indices, hexagon, sizeof hexagon) == 0,
          "a convex hexagon gives ear clipping's triangles (5 0 1, 5 1 2, 5 2 3, 3 4 5)");
    rtk_scene_free(s);

    /* 300,000 corners: ear clipping took minutes (54 s at 1e5); linear now. */
    watchdog(120);
    const size_t big = 300000;
    st = rtk_scene_load(polygon_obj("convex.obj", big, 0), 0, &s);
    watchdog(0);
    /* Corners round to float: some are collinear, and their zero-area
     * triangles are dropped as any scene's are. */
    int fan = st == RTK_OK && s->triangle_count > big - 1000 && s->triangle_count <= big - 2;
    for (uint32_t t = 0; fan && t < s->triangle_count; t++)
        fan = s->indices[3 * t] == big - 1 || s->indices[3 * t + 1] == big - 1 || s->indices[3 * t + 2] == big - 1;
    check(fan, "a convex polygon of %zu corners gives a fan around its last corner in bounded time (%u triangles, %s)",
          big, st == RTK_OK ? s->triangle_count : 0, st == RTK_OK ? "loaded" : rtk_error_message());
    rtk_scene_free(s);

    watchdog(120);
    st = rtk_scene_load(polygon_obj("star.obj", 1000, 1), 0, &s);
    watchdog(0);
    check(st == RTK_OK && s->triangle_count == 998, "a star of 1000 corners is ear-clipped (%s)",
          st == RTK_OK ? "ok" : rtk_error_message());
    rtk_scene_free(s);
    /* Faces that go round a few points again and again have no proper
     * ear at most clips; one such face needs ear tests in the cube of its
     * corner count, and past the loader's limit (16 per squared count) its
     * other corners are clipped without them, with a warning. */
    static const int square[4] = {1, 3, 7, 5}, skew[4] = {4, 8, 2, 1};
    int saved;
    watchdog(120);
    capture_begin(&saved);
    st = rtk_scene_load(cycle_obj("square.obj", square, 4, 1024, 500), 0, &s);
    capture_end(saved);
    watchdog(0);
    check(st == RTK_OK && s->triangle_count > 0 && s->triangle_count <= 1022 && !has(captured, "ear clipping"),
          "a face going 256 times round a square is ear-clipped whole (%s; %s)",
          st == RTK_OK ? "ok" : rtk_error_message(), captured);
    rtk_scene_free(s);
    watchdog(120);
    capture_begin(&saved);
    st = rtk_scene_load(cycle_obj("skew.obj", skew, 4, 1024, 1024), 0, &s);
    capture_end(saved);
    watchdog(0);
    check(st == RTK_OK && s->triangle_count > 0 && s->triangle_count <= 1022 &&
              has(captured, "skew.obj: ear clipping reached its limit") && has(captured, "on 1 face"),
          "a face going 256 times round four corners of a cube is clipped past the limit, with a warning "
          "(%s; %s)", st == RTK_OK ? "ok" : rtk_error_message(), captured);
    rtk_scene_free(s);

    st = rtk_scene_load(polygon_obj("bigstar.obj", 1026, 1), 0, &s);
    check(st == RTK_ERR_UNSUPPORTED && has(rtk_error_message(), "1026 corners") &&
              has(rtk_error_message(), "neither convex") && has(rtk_error_message(), "1024"),
          "a star of 1026 corners is refused, naming the limit (%s)", rtk_error_message());
    rtk_scene_free(s);
}

/* A Maya IFF header (FOR4 ... CIMG TBHD) of the 52-byte kind that made
 * OpenImageIO's probe assert, and a longer one. */
static size_t iff_bytes(unsigned char *b, size_t cap)
{
    static const unsigned char head[] = {'F', 'O', 'R', '4', 0, 0, 0, 0x2c, 'C', 'I', 'M', 'G', 'T', 'B', 'H',
                                         'D', 0, 0, 0, 0x20, 0, 0, 0, 0x40, 0, 0, 0, 0x40, 0, 1, 0, 1, 0, 0,
                                         0, 3, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
    memset(b, 0, cap);
    memcpy(b, head, sizeof head);
    return cap;
}

static void test_image_formats(void)
{
    unsigned char iff[172];
    iff_bytes(iff, sizeof iff);
    rtk_image img;
    rtk_status st = rtk_image_read(write_file("iff.png", iff, sizeof iff), NULL, 0, 1, &img);
    check(st == RTK_ERR_PARSE && has(rtk_error_message(), "not in a format rtk decodes") &&
              has(rtk_error_message(), "46 4f 52 34"),
          "a Maya IFF file named .png is refused by its first bytes (%s)", rtk_error_message());
    st = rtk_image_read("iff bytes", iff, 52, 1, &img);
    check(st == RTK_ERR_PARSE && has(rtk_error_message(), "not in a format"), "52 bytes of IFF in memory too");

    /* Truncated PPM and PNG: named as truncated before OpenImageIO sees them. */
    const char ppm[] = "P6\n4 4\n255\n0123456789";
    st = rtk_image_read(write_file("cut.ppm", ppm, sizeof ppm - 1), NULL, 0, 1, &img);
    check(st == RTK_ERR_PARSE && has(rtk_error_message(), "PNM file is truncated") &&
              has(rtk_error_message(), "48 bytes of pixels, 10 present"),
          "a truncated PPM says so (%s)", rtk_error_message());
    float px[4 * 4 * 3];
    for (size_t i = 0; i < sizeof px / sizeof px[0]; i++)
        px[i] = (float)i / 48.0f;
    const char *whole = in_tmp("whole.png");
    if (rtk_image_write(whole, 4, 4, 3, NULL, px, 0) != RTK_OK) {
        check(0, "writing a PNG: %s", rtk_error_message());
        return;
    }
    unsigned char *bytes;
    size_t count;
    rtk_file_read(whole, "image", 1 << 20, &bytes, &count);
    st = rtk_image_read("cut.png", bytes, count - 20, 1, &img);
    check(st == RTK_ERR_PARSE && has(rtk_error_message(), "PNG file is truncated"),
          "a truncated PNG says so (%s)", rtk_error_message());
    st = rtk_image_read("whole.png", bytes, count, 1, &img);
    check(st == RTK_OK && img.width == 4 && img.height == 4, "the whole PNG decodes");
    free(img.rgba);
    free(bytes);
}

/* Every format on the allow-list is read back through its own reader
 * (OpenImageIO from memory, by name); a TGA only from a .tga file. */
static void test_allowed_formats(void)
{
    static const char *const exts[] = {"png", "jpg", "exr", "hdr", "tif", "tga", "bmp", "ppm"};
    float px[5 * 3 * 3];
    for (size_t i = 0; i < sizeof px / sizeof px[0]; i++)
        px[i] = (float)(i % 7) / 7.0f;
    for (size_t k = 0; k < sizeof exts / sizeof exts[0]; k++) {
        char name[32];
        snprintf(name, sizeof name, "fmt.%s", exts[k]);
        const char *path = in_tmp(name);
        rtk_status st = rtk_image_write(path, 5, 3, 3, NULL, px, 0);
        rtk_image img = {0};
        if (st == RTK_OK)
            st = rtk_image_read(path, NULL, 0, 1, &img);
        check(st == RTK_OK && img.width == 5 && img.height == 3, ".%s is written and read back (%s)", exts[k],
              st == RTK_OK ? "5x3" : rtk_error_message());
        free(img.rgba);
    }
    unsigned char *bytes;
    size_t count;
    if (rtk_file_read(in_tmp("fmt.tga"), "image", 1 << 20, &bytes, &count) == RTK_OK) {
        rtk_image img;
        rtk_status st = rtk_image_read("embedded", bytes, count, 1, &img);
        check(st == RTK_ERR_PARSE && has(rtk_error_message(), "not in a format"),
              "TGA bytes without a .tga name are not guessed at");
        free(bytes);
    }
}

static void test_special_files(void)
{
    rtk_image img;
    watchdog(30);
    rtk_status st = rtk_image_read("/dev/zero", NULL, 0, 1, &img);
    check(st == RTK_ERR_IO && has(rtk_error_message(), "a device"), "/dev/zero as an image: %s",
          rtk_error_message());
    st = rtk_image_read("/dev/urandom", NULL, 0, 1, &img);
    check(st == RTK_ERR_IO && has(rtk_error_message(), "a device"), "/dev/urandom as an image");
    const char *fifo = in_tmp("pipe.png");
    mkfifo(fifo, 0600);
    st = rtk_image_read(fifo, NULL, 0, 1, &img);
    check(st == RTK_ERR_IO && has(rtk_error_message(), "FIFO"), "a FIFO as an image: %s", rtk_error_message());
    st = rtk_image_read(tmpdir, NULL, 0, 1, &img);
    check(st == RTK_ERR_IO && has(rtk_error_message(), "a directory"), "a directory as an image");

    /* A FIFO as the scene, with a writer: refused, not read as empty. */
    const char *pipe_obj = in_tmp("pipe.obj");
    mkfifo(pipe_obj, 0600);
    pid_t writer = fork();
    if (writer == 0) {
        int fd = open(pipe_obj, O_WRONLY);
        const char text[] = "v 0 0 0\n";
        ssize_t n = fd >= 0 ? write(fd, text, sizeof text - 1) : 0;
        (void)n;
        _exit(0);
    }
    rtk_scene *s = NULL;
    st = rtk_scene_load(pipe_obj, 0, &s);
    check(st == RTK_ERR_IO && has(rtk_error_message(), "FIFO") && has(rtk_error_message(), "regular files"),
          "a FIFO .obj (with a writer) is refused: %s", rtk_error_message());
    rtk_scene_free(s);
    /* The writer is waiting for a reader: give it one, then reap it. */
    int fd = open(pipe_obj, O_RDONLY | O_NONBLOCK);
    waitpid(writer, NULL, 0);
    if (fd >= 0)
        close(fd);
    st = rtk_scene_load(in_tmp("pipe.gltf"), 0, &s);
    check(st == RTK_ERR_IO, "a missing scene is an error");
    mkfifo(in_tmp("pipe.gltf"), 0600);
    st = rtk_scene_load(in_tmp("pipe.gltf"), 0, &s);
    check(st == RTK_ERR_IO && has(rtk_error_message(), "FIFO"), "a FIFO .gltf is refused");

    /* /dev/zero named .obj grew memory without bound. */
    symlink("/dev/zero", in_tmp("zero.obj"));
    st = rtk_scene_load(in_tmp("zero.obj"), 0, &s);
    check(st == RTK_ERR_IO && has(rtk_error_message(), "a device"), "/dev/zero named .obj is refused: %s",
          rtk_error_message());
    watchdog(0);
}

/* A glTF with one triangle whose buffer is uri (a file name as JSON text). */
static const char *gltf_with_buffer(const char *name, const char *uri)
{
    char text[2048];
    snprintf(text, sizeof text,
             "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"uri\":\"%s\",\"byteLength\":36}],"
             "\"bufferViews\":[{\"buffer\":0,\"byteLength\":36}],"
             "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\","
             "\"min\":[0,0,0],\"max\":[1,1,0]}],"
             "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0}}]}],"
             "\"nodes\":[{\"mesh\":0}],\"scenes\":[{\"nodes\":[0]}],\"scene\":0}",
             uri);
    return write_text(name, text);
}

static void test_gltf_files(void)
{
    const float tri[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    write_file("tri.bin", tri, sizeof tri);
    rtk_scene *s = NULL;
    rtk_status st = rtk_scene_load(gltf_with_buffer("good.gltf", "tri.bin"), 0, &s);
    check(st == RTK_OK && s->triangle_count == 1, "a buffer beside the glTF loads (%s)",
          st == RTK_OK ? "ok" : rtk_error_message());
    rtk_scene_free(s);

    struct stat passwd;
    char size_text[32] = "none";
    if (stat("/etc/passwd", &passwd) == 0)
        snprintf(size_text, sizeof size_text, "%lld", (long long)passwd.st_size);
    /* tinygltf joins a buffer's uri to the folder: "/etc/passwd" is looked
     * for under it, and only ".." leads out. */
    st = rtk_scene_load(gltf_with_buffer("steal.gltf", "/etc/passwd"), 0, &s);
    check(st != RTK_OK && !has(rtk_error_message(), size_text), "buffer uri /etc/passwd is not read (%s)",
          rtk_error_message());
    rtk_scene_free(s);
    const char *uris[1] = {"../../../../../../../../etc/passwd"};
    for (int i = 0; i < 1; i++) {
        st = rtk_scene_load(gltf_with_buffer("steal.gltf", uris[i]), 0, &s);
        check(st != RTK_OK && has(rtk_error_message(), "outside the folders") &&
                  has(rtk_error_message(), "--allow-outside-files") && !has(rtk_error_message(), size_text),
              "buffer uri %s is refused, naming the flag, not its size (%s)", uris[i], rtk_error_message());
        rtk_scene_free(s);
    }
    /* A missing file outside reads as an existing one does. */
    st = rtk_scene_load(gltf_with_buffer("steal.gltf", "../../../../../../../../etc/no-such-file-here"), 0, &s);
    check(st != RTK_OK && has(rtk_error_message(), "outside the folders"), "a missing file outside: the same refusal");
    rtk_scene_free(s);

    /* With the boundary lifted, the file is read (and fails on its size). */
    rtk_scene_files *open_files = rtk_scene_files_new(NULL, 1, 0);
    st = rtk_scene_load_with(gltf_with_buffer("steal.gltf", "../../../../../../../../etc/passwd"), 0, open_files, &s);
    check(st != RTK_OK && !has(rtk_error_message(), "outside the folders"),
          "--allow-outside-files lets the buffer be read (%s)", rtk_error_message());
    rtk_scene_free(s);

    mkdir(in_tmp("dir.bin"), 0700);
    st = rtk_scene_load(gltf_with_buffer("dir.gltf", "dir.bin"), 0, &s);
    check(st != RTK_OK && has(rtk_error_message(), "a directory") && !has(rtk_error_message(), "out of memory"),
          "a buffer uri naming a directory says so (%s)", rtk_error_message());
    rtk_scene_free(s);
    mkfifo(in_tmp("fifo.bin"), 0600);
    watchdog(30);
    st = rtk_scene_load(gltf_with_buffer("fifo.gltf", "fifo.bin"), 0, &s);
    watchdog(0);
    check(st != RTK_OK && has(rtk_error_message(), "FIFO"), "a FIFO buffer is refused (%s)", rtk_error_message());
    rtk_scene_free(s);
    st = rtk_scene_load_with(gltf_with_buffer("dev.gltf", "../../../../../../../../dev/zero"), 0, open_files, &s);
    check(st != RTK_OK && has(rtk_error_message(), "a device"), "/dev/zero as a buffer, boundary lifted: %s",
          rtk_error_message());
    rtk_scene_free(s);
    rtk_scene_files_unref(open_files);
}

/* A glTF whose material's base colour is image uri (or data URI). */
static const char *gltf_with_image(const char *name, const char *uri)
{
    static char text[4096];
    snprintf(text, sizeof text,
             "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"uri\":\"tri.bin\",\"byteLength\":36}],"
             "\"bufferViews\":[{\"buffer\":0,\"byteLength\":36}],"
             "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\","
             "\"min\":[0,0,0],\"max\":[1,1,0]}],"
             "\"images\":[{\"uri\":\"%s\"}],\"textures\":[{\"source\":0}],"
             "\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0}}}],"
             "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"material\":0}]}],"
             "\"nodes\":[{\"mesh\":0}],\"scenes\":[{\"nodes\":[0]}],\"scene\":0}",
             uri);
    return write_text(name, text);
}

/* Loads path for textures and returns the warnings printed. */
static rtk_status load_textured(const char *path, rtk_scene_files *files, rtk_scene **s)
{
    int saved;
    capture_begin(&saved);
    rtk_status st = rtk_scene_load_with(path, RTK_NEED_TEXTURES, files, s);
    capture_end(saved);
    return st;
}

static void test_gltf_images(void)
{
    rtk_scene *s = NULL;
    watchdog(30);
    rtk_status st = load_textured(gltf_with_image("urandom.gltf", "/dev/urandom"), NULL, &s);
    check(st == RTK_OK && s->texture_count == 1 && s->textures[0].missing && has(captured, "outside the folders"),
          "image uri /dev/urandom: outside, the texture reads white (%s)", captured);
    rtk_scene_free(s);
    rtk_scene_files *open_files = rtk_scene_files_new(NULL, 1, 0);
    st = load_textured(gltf_with_image("urandom.gltf", "/dev/urandom"), open_files, &s);
    check(st == RTK_OK && s->textures[0].missing && has(captured, "a device"),
          "image uri /dev/urandom, boundary lifted: a device (%s)", captured);
    rtk_scene_free(s);
    rtk_scene_files_unref(open_files);
    watchdog(0);

    st = load_textured(gltf_with_image("passwd.gltf", "/etc/passwd"), NULL, &s);
    check(st == RTK_OK && s->textures[0].missing && has(captured, "'/etc/passwd' lies outside"),
          "image uri /etc/passwd is outside (%s)", captured);
    rtk_scene_free(s);

    /* The IFF file as a data URI (base64 of 172 bytes). */
    unsigned char iff[172];
    iff_bytes(iff, sizeof iff);
    static const char b64[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    char uri[512] = "data:image/png;base64,";
    size_t o = strlen(uri);
    for (size_t i = 0; i < sizeof iff; i += 3) {
        uint32_t v = (uint32_t)iff[i] << 16 | (uint32_t)(i + 1 < sizeof iff ? iff[i + 1] : 0) << 8 |
                     (i + 2 < sizeof iff ? iff[i + 2] : 0);
        uri[o++] = b64[v >> 18 & 63];
        uri[o++] = b64[v >> 12 & 63];
        uri[o++] = i + 1 < sizeof iff ? b64[v >> 6 & 63] : '=';
        uri[o++] = i + 2 < sizeof iff ? b64[v & 63] : '=';
    }
    uri[o] = '\0';
    st = load_textured(gltf_with_image("iff.gltf", uri), NULL, &s);
    check(st == RTK_OK && s->textures[0].missing && has(captured, "not in a format rtk decodes"),
          "an IFF data URI is refused by its first bytes (%s)", captured);
    rtk_scene_free(s);
}

/* A folder tree: root/assets/models/scene.obj with textures in
 * root/assets/models/textures and root/assets/textures (allowed), and
 * root/secret.png (outside). */
static void test_boundary(void)
{
    mkdir(in_tmp("root"), 0700);
    mkdir(in_tmp("root/assets"), 0700);
    mkdir(in_tmp("root/assets/models"), 0700);
    mkdir(in_tmp("root/assets/models/textures"), 0700);
    mkdir(in_tmp("root/assets/textures"), 0700);
    mkdir(in_tmp("root/configs"), 0700);
    mkdir(in_tmp("root/configs/cfg"), 0700);
    float px[2 * 2 * 3] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1};
    const char *names[4] = {"root/assets/models/textures/a.png", "root/assets/textures/b.png", "root/secret.png",
                            "root/configs/cfg/c.png"};
    for (int i = 0; i < 4; i++)
        rtk_image_write(in_tmp(names[i]), 2, 2, 3, NULL, px, 0);
    write_text("root/assets/models/scene.mtl", "newmtl a\nmap_Kd textures/a.png\nnewmtl b\nmap_Kd ../textures/b.png\n"
                                               "newmtl s\nmap_Kd ../../secret.png\n"
                                               "newmtl c\nmap_Kd ../../configs/cfg/c.png\n");
    const char *obj = write_text("root/assets/models/scene.obj",
                                 "mtllib scene.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\n"
                                 "usemtl a\nf 1/1 2/1 3/1\nusemtl b\nf 1/1 3/1 2/1\nusemtl s\nf 2/1 1/1 3/1\n"
                                 "usemtl c\nf 3/1 2/1 1/1\n");
    rtk_scene *s = NULL;
    rtk_status st = load_textured(obj, NULL, &s);
    int ok = st == RTK_OK && s->texture_count == 4;
    check(ok && !s->textures[0].missing && !s->textures[1].missing,
          "textures/ and ../textures/ beside the scene are read");
    check(ok && s->textures[2].missing && has(captured, "secret.png' lies outside") &&
              has(captured, "--allow-outside-files"),
          "../../secret.png is refused with the flag named (%s)", captured);
    check(ok && s->textures[3].missing, "a texture in another folder is refused without the config's folder");
    rtk_scene_free(s);

    rtk_scene_files *with_config = rtk_scene_files_new(in_tmp("root/configs/cfg"), 0, 0);
    st = load_textured(obj, with_config, &s);
    check(st == RTK_OK && s->texture_count == 4 && !s->textures[3].missing && s->textures[2].missing,
          "the config's folder is readable too; the rest stays outside");
    rtk_scene_free(s);
    rtk_scene_files_unref(with_config);

    /* A symbolic link inside pointing outside is outside. */
    symlink(in_tmp("root/secret.png"), in_tmp("root/assets/models/textures/link.png"));
    write_text("root/assets/models/link.mtl", "newmtl l\nmap_Kd textures/link.png\n");
    obj = write_text("root/assets/models/link.obj", "mtllib link.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\n"
                                                    "usemtl l\nf 1/1 2/1 3/1\n");
    st = load_textured(obj, NULL, &s);
    check(st == RTK_OK && s->textures[0].missing && has(captured, "lies outside"),
          "a link to a file outside is outside (%s)", captured);
    rtk_scene_free(s);

    /* An mtllib outside: its materials are left out, the flag named. */
    write_text("root/outside.mtl", "newmtl x\nKd 1 0 0\n");
    obj = write_text("root/assets/models/mtl.obj", "mtllib ../../outside.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    st = load_textured(obj, NULL, &s);
    check(st == RTK_OK && s->material_count == 0 && has(captured, "material library") &&
              has(captured, "--allow-outside-files"),
          "an mtllib outside is left out, naming the flag (%s)", captured);
    rtk_scene_free(s);
}

static void put_be32(unsigned char *b, uint32_t v)
{
    b[0] = (unsigned char)(v >> 24), b[1] = (unsigned char)(v >> 16), b[2] = (unsigned char)(v >> 8);
    b[3] = (unsigned char)v;
}

/* One PNG chunk: length, type, data, CRC. */
static void write_chunk(FILE *f, const char *type, const unsigned char *data, uint32_t len)
{
    unsigned char head[8], crc[4];
    put_be32(head, len);
    memcpy(head + 4, type, 4);
    put_be32(crc, (uint32_t)crc32(crc32(0, (const Bytef *)type, 4), data, len));
    fwrite(head, 1, 8, f);
    fwrite(data, 1, len, f);
    fwrite(crc, 1, 4, f);
}

/* Deflates n bytes (flush: Z_NO_FLUSH or Z_FINISH) into IDAT chunks. */
static void deflate_into(FILE *f, z_stream *z, unsigned char *in, size_t n, int flush, unsigned char *out, size_t cap)
{
    z->next_in = in;
    z->avail_in = (uInt)n;
    int st;
    do {
        z->next_out = out;
        z->avail_out = (uInt)cap;
        st = deflate(z, flush);
        if (cap - z->avail_out)
            write_chunk(f, "IDAT", out, (uint32_t)(cap - z->avail_out));
    } while (z->avail_in || (flush == Z_FINISH && st != Z_STREAM_END));
}

/* A greyscale PNG of w x h pixels, all zero, compressed row by row as it
 * is written (16384 x 16384 takes some 260 KB). */
static const char *zero_png(const char *name, uint32_t w, uint32_t h)
{
    const char *path = in_tmp(name);
    FILE *f = fopen(path, "wb");
    fwrite("\x89PNG\r\n\x1a\n", 1, 8, f);
    unsigned char ihdr[13] = {0, 0, 0, 0, 0, 0, 0, 0, 8, 0, 0, 0, 0};
    put_be32(ihdr, w);
    put_be32(ihdr + 4, h);
    write_chunk(f, "IHDR", ihdr, 13);
    unsigned char *row = calloc(1, (size_t)w + 1), out[65536];
    z_stream z;
    memset(&z, 0, sizeof z);
    deflateInit(&z, 1);
    for (uint32_t y = 0; y < h; y++)
        deflate_into(f, &z, row, (size_t)w + 1, Z_NO_FLUSH, out, sizeof out);
    deflate_into(f, &z, row, 0, Z_FINISH, out, sizeof out);
    deflateEnd(&z);
    static const unsigned char none[1];
    write_chunk(f, "IEND", none, 0);
    free(row);
    fclose(f);
    return path;
}

static void test_budget(void)
{
    zero_png("huge.png", 16384, 16384);
    zero_png("small.png", 128, 128);   /* 256 KiB decoded */
    zero_png("medium.png", 512, 512);  /* 4 MiB decoded */
    write_text("huge.mtl", "newmtl h\nmap_Kd huge.png\n");
    const char *obj = write_text("huge.obj", "mtllib huge.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\n"
                                             "usemtl h\nf 1/1 2/1 3/1\n");
    struct rusage before, after;
    getrusage(RUSAGE_SELF, &before);
    rtk_scene *s = NULL;
    watchdog(60);
    rtk_status st = load_textured(obj, NULL, &s);
    watchdog(0);
    getrusage(RUSAGE_SELF, &after);
    check(st == RTK_OK && s->textures[0].missing && has(captured, "huge.png") && has(captured, "16384x16384") &&
              has(captured, "4096.0 MiB") && has(captured, "textures.memory"),
          "a 16384x16384 PNG over the default 2048 MiB budget is not decoded, with its size named (%s)", captured);
    check(after.ru_maxrss - before.ru_maxrss < 512 * 1024, "peak memory grew by %ld KiB (< 512 MiB)",
          after.ru_maxrss - before.ru_maxrss);
    rtk_scene_free(s);

    write_text("two.mtl", "newmtl a\nmap_Kd small.png\nnewmtl b\nmap_Kd medium.png\n");
    obj = write_text("two.obj", "mtllib two.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\n"
                                "usemtl a\nf 1/1 2/1 3/1\nusemtl b\nf 1/1 3/1 2/1\n");
    rtk_scene_files *one_mb = rtk_scene_files_new(NULL, 0, (uint64_t)1 << 20);
    st = load_textured(obj, one_mb, &s);
    check(st == RTK_OK && !s->textures[0].missing && s->textures[1].missing && has(captured, "512x512") &&
              has(captured, "0.8 of 1 MiB left"),
          "a 1 MB budget: 128x128 decoded, 512x512 refused (%s)", captured);
    check(one_mb->texture_bytes == 128u * 128u * 16u, "the budget counts 16 bytes a texel (%llu)",
          (unsigned long long)one_mb->texture_bytes);
    rtk_scene_free(s);
    rtk_scene_files_unref(one_mb);
}

static void test_names(void)
{
    rtk_error(RTK_ERR_PARSE, "object '%s'", "evil\x1b]0;pwned\x07\x1b[2J\xc2\x9b" "31m");
    const char *m = rtk_error_message();
    check(!strchr(m, 0x1b) && !strchr(m, 0x07) && !strstr(m, "\xc2\x9b") && has(m, "\\x1b]0;pwned\\x07\\x1b[2J\\x9b31m"),
          "escape sequences in errors are shown as \\xNN (%s)", m);
    /* An undefined material with an escape sequence in its name, warned. */
    const char *obj = write_text("esc.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl \x1b[31mred\nf 1 2 3\n");
    rtk_scene *s = NULL;
    int saved;
    capture_begin(&saved);
    rtk_status st = rtk_scene_load(obj, RTK_NEED_MATERIALS, &s);
    capture_end(saved);
    check(st == RTK_OK && !strchr(captured, 0x1b) && has(captured, "\\x1b[31mred"),
          "a material name's escape sequence is not printed raw (%s)", captured);
    rtk_scene_free(s);
}

int main(void)
{
    signal(SIGALRM, on_alarm);
    scratch_begin("rtk-hostile");
    test_obj_indices();
    test_polygons();
    test_image_formats();
    test_allowed_formats();
    test_special_files();
    test_gltf_files();
    test_gltf_images();
    test_boundary();
    test_budget();
    test_names();
    scratch_end();
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}

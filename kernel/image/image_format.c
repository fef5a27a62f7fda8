/* Which encoded images rtk hands to its image library: the allow-list.
 *
 * An image is recognised by its first bytes (never by its name, except a
 * TGA, which has no signature and is taken only from a .tga file), and its
 * header is walked far enough to know its size and to catch truncation:
 * OpenImageIO is then told the format, so it never probes the bytes with
 * every reader it has (a Maya IFF file named .png crashed its IFF reader;
 * /dev/zero hung its probe). Formats: PNG, JPEG, OpenEXR, Radiance HDR,
 * TIFF, BMP, TGA, PNM (PBM/PGM/PPM), PFM. */
#include "image.h"

#include <ctype.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

/* The formats rtk decodes, for messages. */
#define ALLOWED "PNG, JPEG, OpenEXR, Radiance HDR, TIFF, BMP, TGA, PNM and PFM"

/* Sizes above this are a broken or hostile header (OpenImageIO's own
 * limit on a side is far larger; rtk's pixel limit is 2^28). */
#define MAX_SIDE 1000000u

static uint32_t be32(const unsigned char *p)
{
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}
static uint32_t be16(const unsigned char *p) { return (uint32_t)p[0] << 8 | p[1]; }
static uint32_t le32(const unsigned char *p)
{
    return (uint32_t)p[3] << 24 | (uint32_t)p[2] << 16 | (uint32_t)p[1] << 8 | p[0];
}
static uint32_t le16(const unsigned char *p) { return (uint32_t)p[1] << 8 | p[0]; }

/* An image header's fault: the message, and RTK_ERR_PARSE. */
static rtk_status bad(const rtk_image_source *src, const char *fmt, const char *detail)
{
    return rtk_error(RTK_ERR_PARSE, "cannot read image '%s': the %s file %s%s", src->name, src->format_label, fmt,
                     detail ? detail : "");
}

static rtk_status set_size(rtk_image_source *src, uint64_t w, uint64_t h)
{
    if (w == 0 || h == 0 || w > MAX_SIDE || h > MAX_SIDE) {
        char text[96];
        snprintf(text, sizeof text, " (%llux%llu)", (unsigned long long)w, (unsigned long long)h);
        return bad(src, "declares an impossible size", text);
    }
    src->width = (int)w;
    src->height = (int)h;
    return RTK_OK;
}

/* Deflate packs at most 1032 bytes into one: a 258-byte match in two
 * bits. Image data shorter than its pixels over this is truncated, and
 * would only make the decoder allocate for pixels that are not there. */
#define DEFLATE_MAX_RATIO 1032u

/* PNG: IHDR first, then every chunk inside the file, up to IEND, with
 * image data in between (a truncated PNG sent OpenImageIO down a path
 * that leaks) enough for its pixels. */
static rtk_status check_png(rtk_image_source *src)
{
    const unsigned char *b = src->bytes;
    size_t n = src->count, at = 8;
    uint64_t data = 0, pixel_bytes = 0;
    int seen_data = 0;
    for (uint32_t chunk = 0;; chunk++) {
        if (n - at < 12)
            return bad(src, "is truncated: it ends before its IEND chunk", NULL);
        uint32_t len = be32(b + at);
        const unsigned char *type = b + at + 4;
        if (len > 0x7fffffffu || len > n - at - 12)
            return bad(src, "is truncated: a chunk runs past the end of the file", NULL);
        if (chunk == 0) {
            if (memcmp(type, "IHDR", 4) != 0 || len != 13)
                return bad(src, "does not start with its IHDR header", NULL);
            rtk_status st = set_size(src, be32(b + at + 8), be32(b + at + 12));
            if (st != RTK_OK)
                return st;
            static const unsigned channels[7] = {1, 0, 3, 1, 2, 0, 4};
            const unsigned depth = b[at + 16], colour = b[at + 17];
            const unsigned bits = colour < 7 ? channels[colour] * depth : 0;
            pixel_bytes = (uint64_t)src->height * (((uint64_t)src->width * bits + 7) / 8);
        }
        if (memcmp(type, "IDAT", 4) == 0) {
            seen_data = 1;
            data += len;
        }
        at += 12 + (size_t)len;
        if (memcmp(type, "IEND", 4) == 0) {
            if (!seen_data)
                return bad(src, "holds no image data (IDAT)", NULL);
            if (data < pixel_bytes / DEFLATE_MAX_RATIO) {
                char text[96];
                snprintf(text, sizeof text, " (%llu bytes of it for %dx%d pixels)", (unsigned long long)data,
                         src->width, src->height);
                return bad(src, "is truncated: its image data (IDAT) is too short for its size", text);
            }
            return RTK_OK;
        }
    }
}

/* JPEG: the segments up to the frame header (SOFn), which gives the
 * size, then a scan (SOS) must follow. */
static rtk_status check_jpeg(rtk_image_source *src)
{
    const unsigned char *b = src->bytes;
    size_t n = src->count, at = 2;
    int framed = 0;
    while (at + 2 <= n) {
        if (b[at] != 0xFF)
            return bad(src, "is damaged: a segment does not start with a marker", NULL);
        unsigned char m = b[at + 1];
        if (m == 0xFF) {
            at++;
            continue;
        }
        at += 2;
        if (m == 0x01 || (m >= 0xD0 && m <= 0xD7))
            continue;
        if (m == 0xD9)
            break;
        if (at + 2 > n)
            break;
        uint32_t len = be16(b + at);
        if (len < 2 || len > n - at)
            return bad(src, "is truncated: a segment runs past the end of the file", NULL);
        if (m >= 0xC0 && m <= 0xCF && m != 0xC4 && m != 0xC8 && m != 0xCC) {
            if (len < 8)
                return bad(src, "has a damaged frame header", NULL);
            rtk_status st = set_size(src, be16(b + at + 5), be16(b + at + 3));
            if (st != RTK_OK)
                return st;
            framed = 1;
        }
        if (m == 0xDA)
            return framed ? RTK_OK : bad(src, "has image data before its frame header", NULL);
        at += len;
    }
    return bad(src, "is truncated: it ends before its image data", NULL);
}

/* OpenEXR: the first header's attributes, for dataWindow. */
static rtk_status check_exr(rtk_image_source *src)
{
    const unsigned char *b = src->bytes;
    size_t n = src->count, at = 8;
    while (at < n) {
        const unsigned char *name = b + at;
        const unsigned char *end = memchr(name, 0, n - at);
        if (!end)
            break;
        if (end == name)
            return bad(src, "has no dataWindow in its header", NULL);
        const unsigned char *type = end + 1;
        const unsigned char *tend = (size_t)(type - b) < n ? memchr(type, 0, n - (size_t)(type - b)) : NULL;
        if (!tend || (size_t)(tend - b) + 5 > n)
            break;
        uint32_t size = le32(tend + 1);
        size_t value = (size_t)(tend - b) + 5;
        if (size > n - value)
            break;
        if (strcmp((const char *)name, "dataWindow") == 0 && size == 16) {
            int32_t x0 = (int32_t)le32(b + value), y0 = (int32_t)le32(b + value + 4);
            int32_t x1 = (int32_t)le32(b + value + 8), y1 = (int32_t)le32(b + value + 12);
            return set_size(src, x1 >= x0 ? (uint64_t)((int64_t)x1 - x0 + 1) : 0,
                            y1 >= y0 ? (uint64_t)((int64_t)y1 - y0 + 1) : 0);
        }
        at = value + size;
    }
    return bad(src, "is truncated: it ends inside its header", NULL);
}

/* Radiance HDR: header lines, a blank line, then "-Y h +X w" (any of the
 * eight orientations). */
static rtk_status check_hdr(rtk_image_source *src)
{
    const char *b = (const char *)src->bytes;
    size_t n = src->count, at = 0;
    int blank = 0;
    while (at < n && at < 65536) {
        const char *nl = memchr(b + at, '\n', n - at);
        if (!nl)
            break;
        size_t len = (size_t)(nl - (b + at));
        if (blank) {
            char line[128];
            if (len >= sizeof line)
                break;
            memcpy(line, b + at, len);
            line[len] = '\0';
            char s1, a1, s2, a2;
            unsigned long v1, v2;
            if (sscanf(line, "%c%c %lu %c%c %lu", &s1, &a1, &v1, &s2, &a2, &v2) != 6 || a1 == a2 ||
                (a1 != 'X' && a1 != 'Y') || (a2 != 'X' && a2 != 'Y') || (s1 != '+' && s1 != '-') ||
                (s2 != '+' && s2 != '-'))
                return bad(src, "has no valid resolution line after its header", NULL);
            return a1 == 'Y' ? set_size(src, v2, v1) : set_size(src, v1, v2);
        }
        blank = len == 0;
        at += len + 1;
    }
    return bad(src, "is truncated: it ends inside its header", NULL);
}

/* TIFF (classic): ImageWidth and ImageLength of the first directory. */
static rtk_status check_tiff(rtk_image_source *src)
{
    const unsigned char *b = src->bytes;
    size_t n = src->count;
    int le = b[0] == 'I';
    uint32_t (*u32)(const unsigned char *) = le ? le32 : be32;
    uint32_t (*u16)(const unsigned char *) = le ? le16 : be16;
    if (n < 8)
        return bad(src, "is truncated: it ends inside its header", NULL);
    uint32_t ifd = u32(b + 4);
    if (ifd < 8 || ifd > n || n - ifd < 2)
        return bad(src, "is truncated: its first directory lies past the end of the file", NULL);
    uint32_t entries = u16(b + ifd);
    if ((uint64_t)entries * 12 > n - ifd - 2)
        return bad(src, "is truncated: its first directory runs past the end of the file", NULL);
    uint64_t w = 0, h = 0;
    for (uint32_t i = 0; i < entries; i++) {
        const unsigned char *e = b + ifd + 2 + 12 * (size_t)i;
        uint32_t tag = u16(e), type = u16(e + 2);
        uint32_t v = type == 3 ? u16(e + 8) : type == 4 ? u32(e + 8) : 0;
        if (tag == 256)
            w = v;
        else if (tag == 257)
            h = v;
    }
    return set_size(src, w, h);
}

/* BMP: the file and info headers, the pixel data's offset inside the file. */
static rtk_status check_bmp(rtk_image_source *src)
{
    const unsigned char *b = src->bytes;
    size_t n = src->count;
    if (n < 26)
        return bad(src, "is truncated: it ends inside its header", NULL);
    uint32_t offset = le32(b + 10), info = le32(b + 14);
    if (offset >= n)
        return bad(src, "is truncated: its pixel data lies past the end of the file", NULL);
    if (info == 12)
        return set_size(src, le16(b + 18), le16(b + 20));
    if (info < 40)
        return bad(src, "has an info header rtk does not know", NULL);
    int32_t w = (int32_t)le32(b + 18), h = (int32_t)le32(b + 22);
    return set_size(src, w > 0 ? (uint64_t)w : 0, h < 0 ? (uint64_t)(-(int64_t)h) : (uint64_t)h);
}

/* TGA (no signature): a plausible header and, uncompressed, all pixels;
 * run-length encoded, as many packets as its pixels need at the least. */
static rtk_status check_tga(rtk_image_source *src)
{
    const unsigned char *b = src->bytes;
    size_t n = src->count;
    if (n < 18)
        return bad(src, "is truncated: it ends inside its header", NULL);
    unsigned type = b[2], bpp = b[16], cmap = b[1];
    if (cmap > 1 || !(type == 1 || type == 2 || type == 3 || type == 9 || type == 10 || type == 11) ||
        !(bpp == 8 || bpp == 15 || bpp == 16 || bpp == 24 || bpp == 32))
        return bad(src, "has a header that is not a TGA header", NULL);
    rtk_status st = set_size(src, le16(b + 12), le16(b + 14));
    if (st != RTK_OK)
        return st;
    uint64_t cmap_bytes = cmap ? (uint64_t)le16(b + 5) * ((b[7] + 7u) / 8u) : 0;
    uint64_t need = 18 + (uint64_t)b[0] + cmap_bytes;
    const uint64_t pixels = (uint64_t)src->width * (uint64_t)src->height, bytes = (bpp + 7u) / 8u;
    if (type <= 3)
        need += pixels * bytes;
    else /* run-length packets: a count byte and a pixel, for at most 128 pixels */
        need += (pixels + 127) / 128 * (1 + bytes);
    if (need > n)
        return bad(src, "is truncated: it ends before its last pixel", NULL);
    return RTK_OK;
}

/* Skips whitespace and # comments of a PNM header from *at; 1 when a
 * token starts there. */
static int pnm_token(const char *b, size_t n, size_t *at)
{
    for (;;) {
        while (*at < n && isspace((unsigned char)b[*at]))
            (*at)++;
        if (*at < n && b[*at] == '#') {
            while (*at < n && b[*at] != '\n')
                (*at)++;
            continue;
        }
        return *at < n;
    }
}

/* The header number at *at (capped past 10^8), or 0 when there is none. */
static int pnm_number(const char *b, size_t n, size_t *at, unsigned long *v)
{
    *v = 0;
    if (!pnm_token(b, n, at) || !isdigit((unsigned char)b[*at]))
        return 0;
    while (*at < n && isdigit((unsigned char)b[*at]) && *v <= 100000000ul)
        *v = *v * 10 + (unsigned long)(b[(*at)++] - '0');
    return 1;
}

/* PFM (PF: RGB, Pf: grey): width, height, a non-zero scale (its sign the
 * byte order), then every float. */
static rtk_status check_pfm(rtk_image_source *src)
{
    const char *b = (const char *)src->bytes;
    size_t n = src->count, at = 2;
    unsigned long w, h;
    if (!pnm_number(b, n, &at, &w) || !pnm_number(b, n, &at, &h))
        return bad(src, "is truncated or damaged: its header lacks a number", NULL);
    rtk_status st = set_size(src, w, h);
    if (st != RTK_OK)
        return st;
    char scale[32];
    size_t len = 0;
    if (pnm_token(b, n, &at))
        while (at < n && len + 1 < sizeof scale &&
               (isdigit((unsigned char)b[at]) || (b[at] && strchr("+-.eE", b[at]))))
            scale[len++] = b[at++];
    scale[len] = '\0';
    char *end = NULL;
    double s = len ? strtod(scale, &end) : 0.0;
    if (!len || *end || !(s != 0.0) || !isfinite(s))
        return bad(src, "is damaged: its scale (the third header field) is not a non-zero number", NULL);
    at++; /* the single whitespace before the floats */
    uint64_t need = (uint64_t)src->width * (uint64_t)src->height * (b[1] == 'F' ? 3u : 1u) * 4u;
    char text[96];
    snprintf(text, sizeof text, " (%llu bytes of pixels, %llu present)", (unsigned long long)need,
             (unsigned long long)(at <= n ? n - at : 0));
    if (at > n || need > n - at)
        return bad(src, "is truncated: it ends before its last pixel", text);
    return RTK_OK;
}

/* PNM: the header's numbers and, for the binary kinds, all pixels. */
static rtk_status check_pnm(rtk_image_source *src)
{
    const char *b = (const char *)src->bytes;
    size_t n = src->count, at = 2;
    int kind = b[1] - '0';
    int fields = kind == 1 || kind == 4 ? 2 : 3;
    unsigned long v[3] = {0, 0, 0};
    for (int f = 0; f < fields; f++)
        if (!pnm_number(b, n, &at, &v[f]))
            return bad(src, "is truncated or damaged: its header lacks a number", NULL);
    if (fields == 3 && (v[2] == 0 || v[2] > 65535))
        return bad(src, "declares an impossible maximum value", NULL);
    rtk_status st = set_size(src, v[0], v[1]);
    if (st != RTK_OK || kind < 4)
        return st;
    at++; /* the single whitespace before binary data */
    uint64_t bytes_per = fields == 3 && v[2] > 255 ? 2 : 1;
    uint64_t row = kind == 4 ? ((uint64_t)src->width + 7) / 8 : (uint64_t)src->width * bytes_per * (kind == 6 ? 3 : 1);
    char text[96];
    snprintf(text, sizeof text, " (%llu bytes of pixels, %llu present)",
             (unsigned long long)(row * (uint64_t)src->height), (unsigned long long)(at <= n ? n - at : 0));
    if (at > n || row * (uint64_t)src->height > n - at)
        return bad(src, "is truncated: it ends before its last pixel", text);
    return RTK_OK;
}

static int ends_with_tga(const char *name)
{
    size_t len = name ? strlen(name) : 0;
    return len >= 4 && strcasecmp(name + len - 4, ".tga") == 0;
}

rtk_status rtk_image_source_check(rtk_image_source *src)
{
    static const struct {
        const char *magic;
        size_t len;
        const char *format, *label;
        rtk_status (*check)(rtk_image_source *);
    } kinds[] = {
        {"\x89PNG\r\n\x1a\n", 8, "png", "PNG", check_png},
        {"\xFF\xD8\xFF", 3, "jpeg", "JPEG", check_jpeg},
        {"\x76\x2F\x31\x01", 4, "openexr", "OpenEXR", check_exr},
        {"#?", 2, "hdr", "Radiance HDR", check_hdr},
        {"II*\0", 4, "tiff", "TIFF", check_tiff},
        {"MM\0*", 4, "tiff", "TIFF", check_tiff},
        {"BM", 2, "bmp", "BMP", check_bmp},
    };
    const unsigned char *b = src->bytes;
    size_t n = src->count;
    src->format = NULL;
    src->width = src->height = 0;
    for (size_t k = 0; k < sizeof kinds / sizeof kinds[0]; k++) {
        if (n >= kinds[k].len && memcmp(b, kinds[k].magic, kinds[k].len) == 0) {
            src->format = kinds[k].format;
            src->format_label = kinds[k].label;
            return kinds[k].check(src);
        }
    }
    if (n >= 3 && b[0] == 'P' && b[1] >= '1' && b[1] <= '6' && isspace(b[2])) {
        src->format = "pnm";
        src->format_label = "PNM";
        return check_pnm(src);
    }
    if (n >= 3 && b[0] == 'P' && (b[1] == 'F' || b[1] == 'f') && isspace(b[2])) {
        src->format = "pnm";
        src->format_label = "PFM";
        return check_pfm(src);
    }
    if (ends_with_tga(src->name)) {
        src->format = "targa";
        src->format_label = "TGA";
        return check_tga(src);
    }
    char shown[40] = "";
    for (size_t i = 0, used = 0; i < n && i < 8; i++)
        used += (size_t)snprintf(shown + used, sizeof shown - used, "%s%02x", i ? " " : "", b[i]);
    return rtk_error(RTK_ERR_PARSE,
                     "cannot read image '%s': it is not in a format rtk decodes (" ALLOWED ", recognised by their "
                     "first bytes; it starts with %s%s): convert it to PNG or JPEG",
                     src->name, n ? shown : "nothing, it is empty", n > 8 ? " ..." : "");
}

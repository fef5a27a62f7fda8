/* Wavefront OBJ + MTL through tinyobjloader's streaming parser
 * (LoadObjWithCallback), converted to the scene builder calls as the file
 * is read. Polygons are triangulated here rather than by tinyobjloader:
 * its ear clipping (2.0.0rc10) drops triangles of many n-gons (8,295 in
 * the showroom mesh), and without triangulation it stores vertex
 * counts in 8 bits, so faces of more than 255 corners come out corrupt.
 * Every function called from C catches all exceptions. */
#include "../scene.h"

#include <tiny_obj_loader.h>

#include <cerrno>
#include <cfloat>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <algorithm>
#include <map>
#include <new>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <string.h>
#include <unistd.h>

namespace {

/* At most this many distinct parser messages are printed per file. */
const size_t max_messages = 20;
/* Most corners of a face ear clipping takes (its time grows with the
 * square of the count); a larger face must be convex, or seen whole from
 * its last corner, to be triangulated as a fan. */
const size_t max_concave_corners = 1024;
/* Corner tests ear clipping may spend on a face of n corners, per n^2.
 * Faces with a proper ear at most clips need about 3; a face going round
 * a few points again and again can need n^3 / 18. Past the limit the
 * face's other corners are clipped without the test, with a warning. */
const uint64_t ear_tests_per_square = 16;

std::string trimmed(const std::string &s)
{
    size_t b = s.find_first_not_of(" \t\r\n");
    if (b == std::string::npos)
        return std::string();
    return s.substr(b, s.find_last_not_of(" \t\r\n") - b + 1);
}

/* Passes tinyobjloader's messages on: one warning per distinct line with
 * its repeat count, prefixed with the file name. */
void log_messages(const char *path, const std::string &text)
{
    std::vector<std::pair<std::string, size_t> > lines;
    std::map<std::string, size_t> seen;
    std::istringstream in(text);
    std::string line;
    while (std::getline(in, line)) {
        line = trimmed(line);
        if (line.empty())
            continue;
        std::map<std::string, size_t>::iterator it = seen.find(line);
        if (it != seen.end()) {
            lines[it->second].second++;
            continue;
        }
        seen[line] = lines.size();
        lines.push_back(std::make_pair(line, size_t(1)));
    }
    for (size_t i = 0; i < lines.size() && i < max_messages; i++) {
        if (lines[i].second > 1)
            rtk_log(RTK_LOG_WARN, "%s: %s (%zu times)", path, lines[i].first.c_str(), lines[i].second);
        else
            rtk_log(RTK_LOG_WARN, "%s: %s", path, lines[i].first.c_str());
    }
    if (lines.size() > max_messages)
        rtk_log(RTK_LOG_WARN, "%s: %zu more distinct warnings", path, lines.size() - max_messages);
}

std::string take(char *s)
{
    if (!s)
        throw std::bad_alloc();
    std::string out(s);
    std::free(s);
    return out;
}

std::string dir_of(const std::string &path) { return take(rtk_path_dirname(path.c_str())); }
std::string join(const std::string &dir, const std::string &path) { return take(rtk_path_join(dir.c_str(), path.c_str())); }

/* What tinyobjloader does not tell about a material: its MTL file (for
 * messages), that file's directory (texture paths are relative to it) and
 * which values the MTL set explicitly (tinyobjloader fills the rest with
 * its own defaults). */
struct MtlInfo {
    std::string file, dir;
    bool has_ni = false, has_pr = false, has_pm = false, has_illum = false, has_tf = false;
};

bool is_space(char c) { return c == ' ' || c == '\t'; }

/* Lists the explicit keys of each material in the order tinyobj::LoadMtl
 * appends them: at each `newmtl` after a named one, and once at the end. */
std::vector<MtlInfo> scan_mtl(const std::string &text, const std::string &file)
{
    std::vector<MtlInfo> out;
    MtlInfo current;
    current.file = file;
    current.dir = dir_of(file);
    bool named = false;
    size_t pos = 0;
    while (pos < text.size()) {
        size_t end = text.find_first_of("\r\n", pos);
        if (end == std::string::npos)
            end = text.size();
        const char *t = text.c_str() + pos;
        size_t len = end - pos;
        pos = end + 1;
        while (len && is_space(*t)) {
            t++;
            len--;
        }
        while (len && is_space(t[len - 1]))
            len--;
        if (len >= 7 && std::strncmp(t, "newmtl", 6) == 0 && is_space(t[6])) {
            if (named)
                out.push_back(current);
            current = MtlInfo();
            current.file = file;
            current.dir = dir_of(file);
            named = len > 7;
        } else if (len >= 6 && std::strncmp(t, "illum", 5) == 0 && is_space(t[5])) {
            current.has_illum = true;
        } else if (len >= 3 && is_space(t[2])) {
            if (t[0] == 'N' && t[1] == 'i')
                current.has_ni = true;
            else if (t[0] == 'P' && t[1] == 'r')
                current.has_pr = true;
            else if (t[0] == 'P' && t[1] == 'm')
                current.has_pm = true;
            else if ((t[0] == 'T' && t[1] == 'f') || (t[0] == 'K' && t[1] == 't'))
                current.has_tf = true;
        }
    }
    out.push_back(current);
    return out;
}

/* Reads each `mtllib` relative to the OBJ's directory (not split at ':'
 * as tinyobj::MaterialFileReader does) and records an MtlInfo per material. */
class MtlReader : public tinyobj::MaterialReader {
  public:
    MtlReader(const rtk_scene *scene, const std::string &obj_dir, std::vector<MtlInfo> *info)
        : scene_(scene), obj_dir_(obj_dir), info_(info)
    {
    }

    bool operator()(const std::string &name, std::vector<tinyobj::material_t> *materials,
                    std::map<std::string, int> *names, std::string *warn, std::string *err) override
    {
        std::string file = join(obj_dir_, name);
        unsigned char *bytes = NULL;
        size_t count = 0;
        if (rtk_scene_file_read(scene_, file.c_str(), "material library", RTK_MAX_TEXT_FILE, &bytes, &count) !=
            RTK_OK) {
            if (warn)
                *warn += std::string(rtk_error_message()) + "; its materials are left out\n";
            return false;
        }
        const std::string text(reinterpret_cast<const char *>(bytes), count);
        std::free(bytes);
        std::istringstream stream(text);
        size_t first = materials->size();
        std::string mtl_warn;
        tinyobj::LoadMtl(names, materials, &stream, &mtl_warn, err);
        if (warn && !mtl_warn.empty())
            *warn += mtl_warn;
        std::vector<MtlInfo> found = scan_mtl(text, file);
        info_->resize(first, MtlInfo());
        for (size_t i = first; i < materials->size(); i++)
            info_->push_back(i - first < found.size() ? found[i - first] : found.back());
        return true;
    }

  private:
    const rtk_scene *scene_;
    std::string obj_dir_;
    std::vector<MtlInfo> *info_;
};

/* The OBJ file as tinyobjloader reads it, in whole lines, checked on the
 * way: a face index that does not fit in 32 bits (tinyobjloader's atoi
 * would wrap 4294967299 to 3) and a line longer than max_line stop the
 * stream before that line, with the line number kept for the message. */
class CheckedObj : public std::streambuf {
  public:
    static const size_t max_line = size_t(64) << 20;
    explicit CheckedObj(int fd) : fd_(fd), buf_(size_t(1) << 20) {}
    ~CheckedObj() override { close(fd_); }
    uint64_t bad_line = 0;   /* line of the problem, 0 when none */
    std::string problem;     /* what is wrong there */
    bool read_error = false;

  protected:
    int_type underflow() override
    {
        if (gptr() < egptr())
            return traits_type::to_int_type(*gptr());
        if (stopped_)
            return traits_type::eof();
        /* The partial line after what was delivered moves to the front. */
        size_t tail = filled_ - delivered_;
        std::memmove(buf_.data(), buf_.data() + delivered_, tail);
        filled_ = tail;
        delivered_ = 0;
        size_t end = 0;
        for (;;) {
            if (filled_ == buf_.size()) {
                if (buf_.size() >= max_line) {
                    stop(line_, "a line is longer than 64 MiB (no line break)");
                    return traits_type::eof();
                }
                buf_.resize(buf_.size() * 2);
            }
            ssize_t n = eof_ ? 0 : read(fd_, buf_.data() + filled_, buf_.size() - filled_);
            if (n < 0 && errno == EINTR)
                continue;
            if (n < 0) {
                read_error = true;
                n = 0;
            }
            if (n == 0)
                eof_ = true;
            filled_ += size_t(n);
            const char *last = static_cast<const char *>(memrchr(buf_.data(), '\n', filled_));
            if (last) {
                end = size_t(last - buf_.data()) + 1;
                break;
            }
            if (eof_) {
                end = filled_;
                break;
            }
        }
        end = scan(end);
        delivered_ = end;
        setg(buf_.data(), buf_.data(), buf_.data() + end);
        if (end == 0)
            return traits_type::eof();
        return traits_type::to_int_type(*gptr());
    }

  private:
    void stop(uint64_t line, const std::string &what)
    {
        stopped_ = true;
        bad_line = line;
        problem = what;
    }
    /* Checks the whole lines in [0, end); returns where delivery stops. */
    size_t scan(size_t end)
    {
        const char *b = buf_.data();
        size_t at = 0;
        while (at < end) {
            const char *nl = static_cast<const char *>(std::memchr(b + at, '\n', end - at));
            size_t stop_at = nl ? size_t(nl - b) : end;
            size_t p = at;
            while (p < stop_at && (b[p] == ' ' || b[p] == '\t'))
                p++;
            if (p + 1 < stop_at && b[p] == 'f' && (b[p + 1] == ' ' || b[p + 1] == '\t')) {
                for (size_t q = p + 2; q < stop_at; q++) {
                    if (b[q] < '0' || b[q] > '9')
                        continue;
                    size_t start = q;
                    uint64_t v = 0;
                    while (q < stop_at && b[q] >= '0' && b[q] <= '9') {
                        if (v <= 2147483647u)
                            v = v * 10 + uint64_t(b[q] - '0');
                        q++;
                    }
                    if (v > 2147483647u) {
                        std::string digits(b + start, std::min<size_t>(q - start, 40));
                        stop(line_, "face index " + digits + " is too large (the largest is 2147483647)");
                        return at;
                    }
                }
            }
            line_++;
            at = stop_at + 1;
        }
        return end;
    }

    int fd_;
    std::vector<char> buf_;
    size_t filled_ = 0, delivered_ = 0;
    uint64_t line_ = 1;
    bool eof_ = false, stopped_ = false;
};

/* Thrown from a parser callback to stop reading; the status is recorded. */
struct Stop {
    rtk_status status;
};

/* One polygon corner, indices resolved to 0-based (-1: absent). */
struct Corner {
    uint32_t v;
    int64_t vt, vn;
};

/* Orientation of the polygon's corners projected on the plane of its
 * dominant axis: axes a, b and the sign that makes it counter-clockwise. */
struct Plane {
    int a, b;
    double sign;
};

/* State of one file being streamed into the scene. */
struct Reader {
    const char *path;
    rtk_scene *scene;
    bool want_normals;
    uint32_t base;               /* scene vertex index of this file's vertex 1 */
    uint32_t vertex_count = 0;   /* `v` lines so far */
    size_t normal_count = 0, uv_count = 0;
    std::vector<float> normals, uvs; /* kept only when the scene needs them */
    std::vector<MtlInfo> info;
    std::vector<uint32_t> materials; /* tinyobjloader material -> scene material */
    std::map<std::string, int> material_names;
    std::map<std::string, size_t> unknown_materials;
    uint32_t material = RTK_INVALID_ID;
    std::string object;
    size_t face = 0, short_faces = 0, capped_faces = 0;
    std::vector<Corner> corners;
    std::vector<uint32_t> triangles, remaining;
    /* Ear clipping's memory per corner: its turn and whether it is an ear
     * (known while its neighbours stay), or the corner that blocks it
     * (known while that corner remains). */
    enum EarState : uint8_t { unknown, ear, blocked };
    std::vector<double> corner_turn;
    std::vector<EarState> ear_state;
    std::vector<uint32_t> blocker;

    /* Stops the parse with an error naming the file. */
    [[noreturn]] void fail(rtk_status code, const char *fmt, ...) RTK_PRINTF(3, 4);
    void check(rtk_status status)
    {
        if (status != RTK_OK)
            throw Stop{status};
    }
    const float *position(size_t corner) const
    {
        return scene->positions + size_t(corners[corner].v) * 3;
    }
    int64_t resolve(int raw, size_t count, bool optional, const char *what, const char *plural);
    void add_face(const tinyobj::index_t *indices, int count);
    void triangulate();
    bool fan(const Plane &pl, bool star);
    void add_materials(const tinyobj::material_t *list, int count);
};

void Reader::fail(rtk_status code, const char *fmt, ...)
{
    char text[1024];
    va_list ap;
    va_start(ap, fmt);
    std::vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    throw Stop{rtk_error(code, "%s: %s", path, text)};
}

/* 0-based index of an OBJ reference (1-based, or negative = relative to
 * the end so far); -1 when an optional one (normal, uv) is absent (0). */
int64_t Reader::resolve(int raw, size_t count, bool optional, const char *what, const char *plural)
{
    if (raw == 0 && optional)
        return -1;
    int64_t i = raw > 0 ? int64_t(raw) - 1 : int64_t(count) + raw;
    if (raw == 0 || i < 0 || uint64_t(i) >= count)
        fail(RTK_ERR_PARSE,
             "face %zu (object '%s') refers to %s %d, but the file defines %zu %s before that face; "
             "fix the face's indices",
             face, object.empty() ? "(unnamed)" : object.c_str(), what, raw, count, plural);
    return i;
}

/* Adds map `name` of a material; its -clamp option sets the slot's wrap
 * (on: clamp to the edge on both axes, off: repeat). */
rtk_status add_texture(rtk_scene *scene, const std::string &name, const tinyobj::texture_option_t &option,
                       const std::string &dir, int srgb, int *index, rtk_tex_wrap *wrap)
{
    *index = -1;
    if (name.empty())
        return RTK_OK;
    wrap->s = wrap->t = option.clamp ? RTK_WRAP_CLAMP : RTK_WRAP_REPEAT;
    std::string file = name;
    for (char &c : file) {
        if (c == '\\')
            c = '/'; /* paths written on Windows */
    }
    std::string path = join(dir, file);
    return rtk_scene_add_texture(scene, NULL, path.c_str(), NULL, 0, srgb, index);
}

/* A scalar map (map_Ns, map_Pr, map_Pm) into slot: its -imfchan r, g or
 * b picks that channel, anything else the first (a grey image's value). */
rtk_status add_map(rtk_scene *scene, const std::string &name, const tinyobj::texture_option_t &option,
                   const std::string &dir, int srgb, rtk_tex_slot *slot)
{
    slot->channel = option.imfchan == 'g' ? 1 : option.imfchan == 'b' ? 2 : 0;
    return add_texture(scene, name, option, dir, srgb, &slot->tex, &slot->wrap);
}

rtk_status add_material(rtk_scene *scene, const tinyobj::material_t &src, const MtlInfo &info, uint32_t *index)
{
    rtk_material m = rtk_material_default();
    const std::string label = "material '" + src.name + "'";
    const char *file = info.file.c_str(), *name = label.c_str();
    const rtk_rgb black = rtk_rgb_make(0.0f, 0.0f, 0.0f), white = rtk_rgb_make(1.0f, 1.0f, 1.0f);
    m.name = const_cast<char *>(src.name.c_str());
    m.base_color = rtk_material_rgb(file, name, "Kd", src.diffuse[0], src.diffuse[1], src.diffuse[2], white, 0, 1);
    m.specular = rtk_material_rgb(file, name, "Ks", src.specular[0], src.specular[1], src.specular[2], black, 0, 1);
    m.emission =
        rtk_material_rgb(file, name, "Ke", src.emission[0], src.emission[1], src.emission[2], black, 0, FLT_MAX);
    m.shininess = rtk_material_value(file, name, "Ns", src.shininess, m.shininess, 0, FLT_MAX);
    if (info.has_ni && std::isfinite(src.ior) && src.ior > 0)
        m.ior = float(src.ior);
    else if (info.has_ni) /* exporters write Ni 0 for "no refraction" */
        rtk_log(RTK_LOG_WARN, "%s: %s: Ni is %g, not a positive number; using %g", file, name, double(src.ior),
                double(m.ior));
    if (info.has_pr)
        m.roughness = rtk_material_value(file, name, "Pr", src.roughness, m.roughness, 0, 1);
    if (info.has_pm)
        m.metallic = rtk_material_value(file, name, "Pm", src.metallic, m.metallic, 0, 1);
    else if (!src.metallic_texname.empty())
        m.metallic = 1.0f; /* map_Pm alone gives the metallic value */
    if (info.has_tf) {
        m.filter = rtk_material_rgb(file, name, "Tf", src.transmittance[0], src.transmittance[1],
                                    src.transmittance[2], white, 0, 1);
        m.has_filter = 1;
    }
    /* tinyobjloader folds `Tr` into dissolve as 1 - Tr when `d` is absent. */
    m.alpha = rtk_material_value(file, name, "d (or 1 - Tr)", src.dissolve, 1.0f, 0, 1);
    m.illum = src.illum;
    m.has_illum = info.has_illum;
    const bool pbr = info.has_pr || info.has_pm || !src.roughness_texname.empty() || !src.metallic_texname.empty();
    m.model = pbr ? RTK_MODEL_METALLIC_ROUGHNESS : RTK_MODEL_MTL;
    rtk_status status;
    const bool normal = !src.normal_texname.empty();
    if ((status = add_texture(scene, src.diffuse_texname, src.diffuse_texopt, info.dir, 1, &m.base_tex,
                              &m.base_wrap)) != RTK_OK ||
        (status = add_texture(scene, src.alpha_texname, src.alpha_texopt, info.dir, 0, &m.alpha_tex, &m.alpha_wrap)) !=
            RTK_OK ||
        (status = add_texture(scene, src.emissive_texname, src.emissive_texopt, info.dir, 1, &m.emission_tex,
                              &m.emission_wrap)) != RTK_OK ||
        (status = add_texture(scene, normal ? src.normal_texname : src.bump_texname,
                              normal ? src.normal_texopt : src.bump_texopt, info.dir, 0, &m.normal_tex,
                              &m.normal_wrap)) != RTK_OK ||
        /* Ks and map_Ks are not inputs of the metallic-roughness mapping. */
        (status = add_texture(scene, pbr ? std::string() : src.specular_texname, src.specular_texopt, info.dir, 1,
                              &m.maps[RTK_MAP_SPECULAR_COLOR].tex, &m.maps[RTK_MAP_SPECULAR_COLOR].wrap)) != RTK_OK ||
        (status = add_map(scene, src.specular_highlight_texname, src.specular_highlight_texopt, info.dir, 0,
                          &m.maps[RTK_MAP_SHININESS])) != RTK_OK ||
        (status = add_map(scene, src.roughness_texname, src.roughness_texopt, info.dir, 0,
                          &m.maps[RTK_MAP_ROUGHNESS])) != RTK_OK ||
        (status = add_map(scene, src.metallic_texname, src.metallic_texopt, info.dir, 0, &m.maps[RTK_MAP_METALLIC])) !=
            RTK_OK)
        return status;
    /* A map_d cuts out (foliage, fences); a constant d < 1 is translucency. */
    if (m.alpha < 1.0f)
        m.alpha_mode = RTK_ALPHA_BLEND;
    else if (m.alpha_tex >= 0)
        m.alpha_mode = RTK_ALPHA_MASK;
    return rtk_scene_add_material(scene, &m, index);
}

/* tinyobjloader passes its whole material list after each `mtllib`;
 * converts the ones not seen yet. */
void Reader::add_materials(const tinyobj::material_t *list, int count)
{
    MtlInfo fallback;
    fallback.file = path;
    fallback.dir = dir_of(path);
    for (size_t i = materials.size(); i < size_t(count); i++) {
        uint32_t index;
        check(add_material(scene, list[i], i < info.size() ? info[i] : fallback, &index));
        materials.push_back(index);
        material_names[list[i].name] = int(i);
    }
}


Plane polygon_plane(const Reader &r, const std::vector<uint32_t> &poly)
{
    double n[3] = {0, 0, 0}; /* Newell's normal */
    for (size_t i = 0; i < poly.size(); i++) {
        const float *p = r.position(poly[i]), *q = r.position(poly[(i + 1) % poly.size()]);
        n[0] += (double(p[1]) - q[1]) * (double(p[2]) + q[2]);
        n[1] += (double(p[2]) - q[2]) * (double(p[0]) + q[0]);
        n[2] += (double(p[0]) - q[0]) * (double(p[1]) + q[1]);
    }
    int axis = 2;
    if (std::fabs(n[0]) > std::fabs(n[1]) && std::fabs(n[0]) > std::fabs(n[2]))
        axis = 0;
    else if (std::fabs(n[1]) > std::fabs(n[2]))
        axis = 1;
    Plane pl;
    pl.a = (axis + 1) % 3;
    pl.b = (axis + 2) % 3;
    pl.sign = n[axis] < 0 ? -1.0 : 1.0;
    return pl;
}

/* Twice the signed area of (p, q, s) in the plane, positive when the
 * turn follows the polygon's orientation. */
double turn(const Plane &pl, const float *p, const float *q, const float *s)
{
    return pl.sign * ((double(q[pl.a]) - p[pl.a]) * (double(s[pl.b]) - p[pl.b]) -
                      (double(q[pl.b]) - p[pl.b]) * (double(s[pl.a]) - p[pl.a]));
}

bool same(const float *p, const float *q) { return p[0] == q[0] && p[1] == q[1] && p[2] == q[2]; }

/* Fan triangulation around the last corner, in linear time: ears (n-1,
 * k, k+1), then (n-3, n-2, n-1), which is what ear clipping makes of a
 * strictly convex polygon (every turn positive, its edges going round
 * once). With star set, any polygon whose fan triangles all turn the
 * polygon's way and together sweep less than a full turn around the last
 * corner (a polygon every point of which the last corner sees) qualifies,
 * up to float rounding (a circle of 1e5 corners in float coordinates has
 * corners that are flat or slightly reflex): a fan triangle may turn back
 * by what rounding moves its corners, a sliver. False, writing nothing,
 * otherwise. */
bool Reader::fan(const Plane &pl, bool star)
{
    const size_t n = corners.size();
    const uint32_t last = uint32_t(n - 1);
    if (!star) {
        int flips = 0;
        double prev_da = 0.0, first_da = 0.0;
        for (size_t i = 0; i < n; i++) {
            const float *p = position((i + n - 1) % n), *q = position(i), *r = position((i + 1) % n);
            if (!(turn(pl, p, q, r) > 0))
                return false;
            /* Sign changes of the edges' extent along axis a: two for a
             * polygon that goes round once, more for a star. */
            double da = double(r[pl.a]) - q[pl.a];
            if (da != 0.0) {
                if (prev_da != 0.0 && (da > 0) != (prev_da > 0))
                    flips++;
                if (first_da == 0.0)
                    first_da = da;
                prev_da = da;
            }
        }
        if (prev_da != 0.0 && first_da != 0.0 && (first_da > 0) != (prev_da > 0))
            flips++;
        if (flips > 2)
            return false;
    }
    double swept = 0.0;
    const float *o = position(last);
    for (uint32_t k = 0; k + 2 < n; k++) {
        const float *p = position(k), *q = position(k + 1);
        double t = turn(pl, o, p, q);
        double ua = double(p[pl.a]) - o[pl.a], ub = double(p[pl.b]) - o[pl.b];
        double va = double(q[pl.a]) - o[pl.a], vb = double(q[pl.b]) - o[pl.b];
        /* A star may turn back by what rounding its corners to float
         * moves them (a few ulps of the largest coordinate): slivers. */
        double m = std::max({std::fabs(double(o[pl.a])), std::fabs(double(o[pl.b])), std::fabs(double(p[pl.a])),
                             std::fabs(double(p[pl.b])), std::fabs(double(q[pl.a])), std::fabs(double(q[pl.b]))});
        double slack = star ? 4.0 * FLT_EPSILON * m * (std::hypot(ua, ub) + std::hypot(va, vb)) : 0.0;
        if (star ? !(t >= -slack) : !(t > 0))
            return false;
        swept += std::atan2(t, ua * va + ub * vb);
    }
    if (star && !(swept < 2.0 * 3.14159265358979323846))
        return false;
    for (uint32_t k = 0; k + 3 < n; k++)
        triangles.insert(triangles.end(), {last, k, k + 1});
    triangles.insert(triangles.end(), {uint32_t(n - 3), uint32_t(n - 2), last});
    return true;
}

/* Ear clipping in the polygon's plane. Every polygon of n corners gives
 * n - 2 triangles: when no proper ear exists (self-intersecting or
 * degenerate input) the first corner is clipped anyway, and zero-area
 * results are dropped later by rtk_scene_finish. */
void Reader::triangulate()
{
    triangles.clear();
    const size_t n = corners.size();
    if (n == 3) {
        triangles.insert(triangles.end(), {0, 1, 2});
        return;
    }
    remaining.resize(n);
    for (size_t i = 0; i < n; i++)
        remaining[i] = uint32_t(i);
    const Plane pl = polygon_plane(*this, remaining);
    if (n == 4) {
        /* Split along the diagonal that keeps both halves turning the
         * polygon's way (the only one for a concave quad); the shorter one
         * when both do. */
        const float *p[4] = {position(0), position(1), position(2), position(3)};
        bool ok02 = turn(pl, p[0], p[1], p[2]) > 0 && turn(pl, p[0], p[2], p[3]) > 0;
        bool ok13 = turn(pl, p[1], p[2], p[3]) > 0 && turn(pl, p[1], p[3], p[0]) > 0;
        double d02 = 0, d13 = 0;
        for (int k = 0; k < 3; k++) {
            d02 += (double(p[2][k]) - p[0][k]) * (double(p[2][k]) - p[0][k]);
            d13 += (double(p[3][k]) - p[1][k]) * (double(p[3][k]) - p[1][k]);
        }
        if (ok13 && (!ok02 || d13 < d02))
            triangles.insert(triangles.end(), {1, 2, 3, 1, 3, 0});
        else
            triangles.insert(triangles.end(), {0, 1, 2, 0, 2, 3});
        return;
    }
    if (fan(pl, false))
        return;
    if (n > max_concave_corners) {
        if (fan(pl, true))
            return;
        fail(RTK_ERR_UNSUPPORTED,
             "face %zu (object '%s') has %zu corners and is neither convex nor seen whole from its last corner; "
             "rtk ear-clips such faces up to %zu corners (its time grows with the square of the count): split it "
             "in the modelling tool",
             face, object.empty() ? "(unnamed)" : object.c_str(), n, max_concave_corners);
    }
    /* A corner's turn and ear test depend only on its neighbours and on
     * which corners remain; clipping a corner changes the neighbours of two
     * and can unblock only the corners it blocked. So each is computed
     * once and again only then: the same ears as testing every corner
     * anew, in far fewer tests on faces with no proper ear. */
    ear_state.assign(n, unknown);
    corner_turn.resize(n);
    blocker.resize(n);
    uint64_t tests_left = ear_tests_per_square * uint64_t(n) * uint64_t(n);
    bool capped = false;
    size_t start = 0;
    while (remaining.size() > 3) {
        const size_t m = remaining.size();
        size_t ear_at = m, flat = m, convex = m;
        for (size_t k = 0; k < m && ear_at == m; k++) {
            size_t i = (start + k) % m;
            uint32_t a = remaining[(i + m - 1) % m], b = remaining[i], c = remaining[(i + 1) % m];
            const float *pa = position(a), *pb = position(b), *pc = position(c);
            if (ear_state[b] == unknown)
                corner_turn[b] = turn(pl, pa, pb, pc);
            double t = corner_turn[b];
            if (t <= 0) {
                if (t == 0 && flat == m)
                    flat = i;
                ear_state[b] = blocked;
                blocker[b] = b; /* not an ear until a neighbour changes */
                continue;
            }
            if (convex == m)
                convex = i;
            if (capped)
                break; /* past the limit: the first convex corner */
            /* A corner inside the ear or on its border (the new diagonal
             * included) blocks it; one sitting on the ear's own corners
             * (a repeated position) does not. */
            if (ear_state[b] == unknown) {
                if (tests_left < m) {
                    capped = true;
                    capped_faces++;
                    break;
                }
                tests_left -= m;
                ear_state[b] = ear;
                for (size_t j = 0; j < m; j++) {
                    const float *po = position(remaining[j]);
                    if (same(po, pa) || same(po, pb) || same(po, pc))
                        continue;
                    if (turn(pl, pa, pb, po) >= 0 && turn(pl, pb, pc, po) >= 0 && turn(pl, pc, pa, po) >= 0) {
                        ear_state[b] = blocked;
                        blocker[b] = remaining[j];
                        break;
                    }
                }
            }
            if (ear_state[b] == ear)
                ear_at = i;
        }
        /* No proper ear: the projected polygon is not simple. Clipping a
         * collinear corner adds nothing; a convex one adds the least overlap. */
        if (ear_at == m)
            ear_at = flat != m ? flat : convex != m ? convex : start % m;
        const uint32_t a = remaining[(ear_at + m - 1) % m], b = remaining[ear_at], c = remaining[(ear_at + 1) % m];
        triangles.insert(triangles.end(), {a, b, c});
        remaining.erase(remaining.begin() + std::ptrdiff_t(ear_at));
        ear_state[a] = ear_state[c] = unknown;
        for (uint32_t r : remaining)
            if (ear_state[r] == blocked && blocker[r] == b)
                ear_state[r] = unknown;
        start = ear_at;
    }
    triangles.insert(triangles.end(), {remaining[0], remaining[1], remaining[2]});
}

void Reader::add_face(const tinyobj::index_t *indices, int count)
{
    face++;
    if (count < 3) {
        short_faces++;
        return;
    }
    corners.resize(size_t(count));
    for (int k = 0; k < count; k++) {
        Corner &c = corners[size_t(k)];
        c.v = base + uint32_t(resolve(indices[k].vertex_index, vertex_count, false, "vertex", "vertices"));
        c.vt = resolve(indices[k].texcoord_index, uv_count, true, "texture coordinate", "texture coordinates");
        c.vn = resolve(indices[k].normal_index, normal_count, true, "normal", "normals");
    }
    triangulate();
    for (size_t t = 0; t < triangles.size(); t += 3) {
        const Corner *c[3] = {&corners[triangles[t]], &corners[triangles[t + 1]], &corners[triangles[t + 2]]};
        float n[9], uv[6];
        /* Texture coordinates go to the scene when it keeps them: for
         * the integrator, or for the alpha of cutout materials. */
        bool has_n = want_normals, has_uv = true;
        for (int k = 0; k < 3; k++) {
            if (has_n && c[k]->vn >= 0)
                std::memcpy(n + k * 3, &normals[size_t(c[k]->vn) * 3], 3 * sizeof(float));
            else
                has_n = false;
            if (has_uv && c[k]->vt >= 0)
                std::memcpy(uv + k * 2, &uvs[size_t(c[k]->vt) * 2], 2 * sizeof(float));
            else
                has_uv = false;
        }
        check(rtk_scene_add_triangle(scene, c[0]->v, c[1]->v, c[2]->v, has_n ? n : NULL, has_uv ? uv : NULL,
                                     material));
    }
}

void on_vertex(void *user, tinyobj::real_t x, tinyobj::real_t y, tinyobj::real_t z, tinyobj::real_t)
{
    Reader &r = *static_cast<Reader *>(user);
    r.check(rtk_scene_add_vertex(r.scene, x, y, z, NULL));
    r.vertex_count++;
}

void on_normal(void *user, tinyobj::real_t x, tinyobj::real_t y, tinyobj::real_t z)
{
    Reader &r = *static_cast<Reader *>(user);
    if (r.want_normals)
        r.normals.insert(r.normals.end(), {float(x), float(y), float(z)});
    r.normal_count++;
}

void on_texcoord(void *user, tinyobj::real_t u, tinyobj::real_t v, tinyobj::real_t)
{
    Reader &r = *static_cast<Reader *>(user);
    /* Kept whatever the integrator needs: a cutout material (map_d) may
     * come later in the file and needs them for its alpha. */
    r.uvs.insert(r.uvs.end(), {float(u), 1.0f - float(v)}); /* OBJ's v points up; the texture service's down */
    r.uv_count++;
}

void on_face(void *user, tinyobj::index_t *indices, int count)
{
    static_cast<Reader *>(user)->add_face(indices, count);
}

void on_usemtl(void *user, const char *name, int id)
{
    Reader &r = *static_cast<Reader *>(user);
    if (id < 0) {
        /* tinyobjloader's streaming parser keeps trailing blanks in the name. */
        std::map<std::string, int>::const_iterator it = r.material_names.find(trimmed(name));
        if (it != r.material_names.end())
            id = it->second;
    }
    if (id >= 0 && size_t(id) < r.materials.size()) {
        r.material = r.materials[size_t(id)];
    } else {
        r.material = RTK_INVALID_ID;
        r.unknown_materials[trimmed(name)]++;
    }
}

void on_mtllib(void *user, const tinyobj::material_t *list, int count)
{
    static_cast<Reader *>(user)->add_materials(list, count);
}

void on_object(void *user, const char *name) { static_cast<Reader *>(user)->object = trimmed(name); }

rtk_status load(const char *path, rtk_scene *scene)
{
    int fd;
    rtk_status opened = rtk_file_open(path, "OBJ file", &fd, NULL);
    if (opened != RTK_OK)
        return opened;
    CheckedObj file(fd);
    unsigned char bom[3] = {0, 0, 0};
    ssize_t got = pread(fd, bom, 3, 0);
    if (got >= 2 && ((bom[0] == 0xFE && bom[1] == 0xFF) || (bom[0] == 0xFF && bom[1] == 0xFE)))
        return rtk_error(RTK_ERR_UNSUPPORTED, "%s: the file is UTF-16 encoded; save it as UTF-8 or ASCII", path);
    if (got == 3 && bom[0] == 0xEF && bom[1] == 0xBB && bom[2] == 0xBF) /* skip a UTF-8 byte order mark */
        lseek(fd, 3, SEEK_SET);
    std::istream in(&file);

    Reader r;
    r.path = path;
    r.scene = scene;
    r.want_normals = (scene->needs & RTK_NEED_NORMALS) != 0;
    r.base = scene->vertex_count;
    MtlReader mtl(scene, dir_of(path), &r.info);
    tinyobj::callback_t cb;
    cb.vertex_cb = on_vertex;
    cb.normal_cb = on_normal;
    cb.texcoord_cb = on_texcoord;
    cb.index_cb = on_face;
    cb.usemtl_cb = on_usemtl;
    cb.mtllib_cb = on_mtllib;
    cb.object_cb = on_object;
    std::string warn, err;
    bool ok;
    try {
        ok = tinyobj::LoadObjWithCallback(in, cb, &r, &mtl, &warn, &err);
    } catch (const Stop &stop) {
        log_messages(path, warn);
        return stop.status;
    }
    log_messages(path, warn);
    if (file.bad_line)
        return rtk_error(RTK_ERR_PARSE, "%s:%llu: %s; fix the line", path, (unsigned long long)file.bad_line,
                         file.problem.c_str());
    if (!ok)
        return rtk_error(RTK_ERR_PARSE, "%s: %s", path, trimmed(err).c_str());
    log_messages(path, err);
    if (in.bad() || file.read_error)
        return rtk_error(RTK_ERR_IO, "%s: read error", path);
    size_t shown = 0;
    for (const std::pair<const std::string, size_t> &u : r.unknown_materials) {
        if (shown++ < max_messages)
            rtk_log(RTK_LOG_WARN, "%s: material '%s' is not defined in any mtllib; its faces get the default material",
                    path, u.first.c_str());
    }
    if (shown > max_messages)
        rtk_log(RTK_LOG_WARN, "%s: %zu more undefined materials", path, shown - max_messages);
    if (r.capped_faces)
        rtk_log(RTK_LOG_WARN,
                "%s: ear clipping reached its limit of %llu corner tests per squared corner count on %zu face%s "
                "(corners going round the same points again and again?), whose other corners were clipped "
                "without the test, so their triangles may overlap: split such faces in the modelling tool",
                path, (unsigned long long)ear_tests_per_square, r.capped_faces, r.capped_faces == 1 ? "" : "s");
    if (r.short_faces)
        rtk_log(RTK_LOG_WARN, "%s: ignored %zu face%s with fewer than 3 corners", path, r.short_faces,
                r.short_faces == 1 ? "" : "s");
    return RTK_OK;
}

} // namespace

extern "C" rtk_status rtk_load_obj(const char *path, rtk_scene *scene)
{
    try {
        return load(path, scene);
    } catch (const std::bad_alloc &) {
        return rtk_error(RTK_ERR_NOMEM, "%s: out of memory while reading the OBJ file", path);
    } catch (const std::exception &e) {
        return rtk_error(RTK_ERR_PARSE, "%s: %s", path, e.what());
    } catch (...) {
        return rtk_error(RTK_ERR_PARSE, "%s: unexpected failure while reading the OBJ file", path);
    }
}

/* Wavefront OBJ + MTL through tinyobjloader's streaming parser
 * (LoadObjWithCallback), converted to the scene builder calls as the file
 * is read. Polygons are triangulated here rather than by tinyobjloader:
 * its ear clipping (2.0.0rc10) drops triangles of many n-gons (8,295 in
 * ../shared/data/showroom), and without triangulation it stores vertex
 * counts in 8 bits, so faces of more than 255 corners come out corrupt.
 * Every function called from C catches all exceptions. */
#include "../internal.h"

#include <tiny_obj_loader.h>

#include <cerrno>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <new>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace {

/* At most this many distinct parser messages are printed per file. */
const size_t max_messages = 20;

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

/* What tinyobjloader does not tell about a material: the directory of its
 * MTL file (texture paths are relative to it) and which values the MTL
 * set explicitly (tinyobjloader fills the rest with its own defaults). */
struct MtlInfo {
    std::string dir;
    bool has_ni = false, has_pr = false, has_pm = false;
};

bool is_space(char c) { return c == ' ' || c == '\t'; }

/* Lists the explicit keys of each material in the order tinyobj::LoadMtl
 * appends them: at each `newmtl` after a named one, and once at the end. */
std::vector<MtlInfo> scan_mtl(const std::string &text, const std::string &dir)
{
    std::vector<MtlInfo> out;
    MtlInfo current;
    current.dir = dir;
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
            current.dir = dir;
            named = len > 7;
        } else if (len >= 3 && is_space(t[2])) {
            if (t[0] == 'N' && t[1] == 'i')
                current.has_ni = true;
            else if (t[0] == 'P' && t[1] == 'r')
                current.has_pr = true;
            else if (t[0] == 'P' && t[1] == 'm')
                current.has_pm = true;
        }
    }
    out.push_back(current);
    return out;
}

/* Reads each `mtllib` relative to the OBJ's directory (not split at ':'
 * as tinyobj::MaterialFileReader does) and records an MtlInfo per material. */
class MtlReader : public tinyobj::MaterialReader {
  public:
    MtlReader(const std::string &obj_dir, std::vector<MtlInfo> *info) : obj_dir_(obj_dir), info_(info) {}

    bool operator()(const std::string &name, std::vector<tinyobj::material_t> *materials,
                    std::map<std::string, int> *names, std::string *warn, std::string *err) override
    {
        std::string file = join(obj_dir_, name);
        std::ifstream in(file.c_str(), std::ios::binary);
        if (!in) {
            if (warn)
                *warn += "material library '" + name + "' not found (looked for " + file + ")\n";
            return false;
        }
        std::ostringstream buffer;
        buffer << in.rdbuf();
        const std::string text = buffer.str();
        std::istringstream stream(text);
        size_t first = materials->size();
        std::string mtl_warn;
        tinyobj::LoadMtl(names, materials, &stream, &mtl_warn, err);
        if (warn && !mtl_warn.empty())
            *warn += mtl_warn;
        std::vector<MtlInfo> found = scan_mtl(text, dir_of(file));
        info_->resize(first, MtlInfo());
        for (size_t i = first; i < materials->size(); i++)
            info_->push_back(i - first < found.size() ? found[i - first] : found.back());
        return true;
    }

  private:
    std::string obj_dir_;
    std::vector<MtlInfo> *info_;
};

float clean(tinyobj::real_t v, float fallback) { return std::isfinite(v) ? float(v) : fallback; }

rtk_rgb clean_rgb(const tinyobj::real_t *c, rtk_rgb fallback)
{
    return rtk_rgb_make(clean(c[0], fallback.r), clean(c[1], fallback.g), clean(c[2], fallback.b));
}

/* Thrown from a parser callback to stop reading; the status is recorded. */
struct Stop {
    rtk_status status;
};

/* One polygon corner, indices resolved to 0-based (-1: absent). */
struct Corner {
    uint32_t v;
    int64_t vt, vn;
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
    size_t face = 0, short_faces = 0;
    std::vector<Corner> corners;
    std::vector<uint32_t> triangles, remaining;

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

rtk_status add_material(rtk_scene *scene, const tinyobj::material_t &src, const MtlInfo &info, uint32_t *index)
{
    rtk_material m = rtk_material_default();
    m.name = const_cast<char *>(src.name.c_str());
    m.base_color = clean_rgb(src.diffuse, m.base_color);
    m.specular = clean_rgb(src.specular, m.specular);
    m.emission = clean_rgb(src.emission, m.emission);
    m.shininess = clean(src.shininess, m.shininess);
    if (info.has_ni && std::isfinite(src.ior) && src.ior > 0)
        m.ior = float(src.ior);
    if (info.has_pr)
        m.roughness = clean(src.roughness, m.roughness);
    if (info.has_pm)
        m.metallic = clean(src.metallic, m.metallic);
    /* tinyobjloader folds `Tr` into dissolve as 1 - Tr when `d` is absent. */
    m.alpha = clean(src.dissolve, 1.0f);
    m.illum = src.illum;
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
                              &m.normal_wrap)) != RTK_OK)
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
    fallback.dir = dir_of(path);
    for (size_t i = materials.size(); i < size_t(count); i++) {
        uint32_t index;
        check(add_material(scene, list[i], i < info.size() ? info[i] : fallback, &index));
        materials.push_back(index);
        material_names[list[i].name] = int(i);
    }
}

/* Orientation of the polygon's corners projected on the plane of its
 * dominant axis: axes a, b and the sign that makes it counter-clockwise. */
struct Plane {
    int a, b;
    double sign;
};

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
    size_t start = 0;
    while (remaining.size() > 3) {
        const size_t m = remaining.size();
        size_t ear = m, flat = m, convex = m;
        for (size_t k = 0; k < m && ear == m; k++) {
            size_t i = (start + k) % m;
            uint32_t a = remaining[(i + m - 1) % m], b = remaining[i], c = remaining[(i + 1) % m];
            const float *pa = position(a), *pb = position(b), *pc = position(c);
            double t = turn(pl, pa, pb, pc);
            if (t <= 0) {
                if (t == 0 && flat == m)
                    flat = i;
                continue;
            }
            if (convex == m)
                convex = i;
            /* A corner inside the ear or on its border (the new diagonal
             * included) blocks it; one sitting on the ear's own corners
             * (a repeated position) does not. */
            bool empty = true;
            for (size_t j = 0; j < m && empty; j++) {
                const float *po = position(remaining[j]);
                if (same(po, pa) || same(po, pb) || same(po, pc))
                    continue;
                empty = !(turn(pl, pa, pb, po) >= 0 && turn(pl, pb, pc, po) >= 0 && turn(pl, pc, pa, po) >= 0);
            }
            if (empty)
                ear = i;
        }
        /* No proper ear: the projected polygon is not simple. Clipping a
         * collinear corner adds nothing; a convex one adds the least overlap. */
        if (ear == m)
            ear = flat != m ? flat : convex != m ? convex : start % m;
        triangles.insert(triangles.end(), {remaining[(ear + m - 1) % m], remaining[ear], remaining[(ear + 1) % m]});
        remaining.erase(remaining.begin() + std::ptrdiff_t(ear));
        start = ear;
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
    std::ifstream in(path, std::ios::binary);
    if (!in)
        return rtk_error(RTK_ERR_IO, "%s: cannot open: %s", path, std::strerror(errno));
    unsigned char bom[3] = {0, 0, 0};
    in.read(reinterpret_cast<char *>(bom), 3);
    if ((bom[0] == 0xFE && bom[1] == 0xFF) || (bom[0] == 0xFF && bom[1] == 0xFE))
        return rtk_error(RTK_ERR_UNSUPPORTED, "%s: the file is UTF-16 encoded; save it as UTF-8 or ASCII", path);
    in.clear();
    in.seekg(bom[0] == 0xEF && bom[1] == 0xBB && bom[2] == 0xBF ? 3 : 0); /* skip a UTF-8 byte order mark */

    Reader r;
    r.path = path;
    r.scene = scene;
    r.want_normals = (scene->needs & RTK_NEED_NORMALS) != 0;
    r.base = scene->vertex_count;
    MtlReader mtl(dir_of(path), &r.info);
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
    if (!ok)
        return rtk_error(RTK_ERR_PARSE, "%s: %s", path, trimmed(err).c_str());
    log_messages(path, err);
    if (in.bad())
        return rtk_error(RTK_ERR_IO, "%s: read error", path);
    size_t shown = 0;
    for (const std::pair<const std::string, size_t> &u : r.unknown_materials) {
        if (shown++ < max_messages)
            rtk_log(RTK_LOG_WARN, "%s: material '%s' is not defined in any mtllib; its faces get the default material",
                    path, u.first.c_str());
    }
    if (shown > max_messages)
        rtk_log(RTK_LOG_WARN, "%s: %zu more undefined materials", path, shown - max_messages);
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

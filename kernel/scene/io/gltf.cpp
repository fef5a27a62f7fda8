/* glTF 2.0 (.gltf, .glb) through tinygltf, converted to the scene builder
 * calls. Images are never decoded here: the image-loader callback keeps
 * only the bytes of data-URI images, and textures are recorded by path or
 * by buffer view for the kernel's texture service. Every accessor is
 * validated before it is read. Functions called from C catch all
 * exceptions. */
#include "../scene.h"
#include "../../accel/accel.h"
#include "draco.h"

#include <tiny_gltf.h>
#ifdef RTK_HAVE_MESHOPT
#include <meshoptimizer.h>
#endif

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <strings.h>
#include <map>
#include <new>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace {

/* Deepest node nesting accepted; real files stay far below. */
const int max_depth = 256;
/* Node instances accepted: shared subtrees could otherwise expand
 * exponentially. */
const size_t max_node_visits = size_t(1) << 20;
/* At most this many tinygltf warnings are printed per file. */
const size_t max_messages = 20;
/* Elements of a sparse accessor without a buffer view (all zeros but
 * for its sparse values) accepted. */
const size_t max_zero_elements = size_t(1) << 26;
/* Deepest JSON nesting accepted: tinygltf's parser recurses per level
 * (15,000 levels overflow the stack); glTF's own structure needs 7. */
const int max_json_depth = 100;

const double pi = 3.14159265358979323846;

/* Column-major 4x4 matrix, as glTF stores them. */
typedef std::array<double, 16> Mat4;

Mat4 identity()
{
    Mat4 m{};
    m[0] = m[5] = m[10] = m[15] = 1.0;
    return m;
}

Mat4 mul(const Mat4 &a, const Mat4 &b)
{
    Mat4 r{};
    for (int c = 0; c < 4; c++)
        for (int row = 0; row < 4; row++) {
            double s = 0.0;
            for (int k = 0; k < 4; k++)
                s += a[k * 4 + row] * b[c * 4 + k];
            r[c * 4 + row] = s;
        }
    return r;
}

/* m applied to (x, y, z, w). */
void transform(const Mat4 &m, double x, double y, double z, double w, double out[3])
{
    for (int row = 0; row < 3; row++)
        out[row] = m[row] * x + m[4 + row] * y + m[8 + row] * z + m[12 + row] * w;
}

/* Matrix taking normals through m: the cofactor matrix of m's upper 3x3
 * (its inverse transpose times the determinant), with the determinant's
 * sign so that it also keeps orientation. Row-major 3x3. */
std::array<double, 9> normal_matrix(const Mat4 &m, double *det)
{
    double a = m[0], b = m[4], c = m[8];
    double d = m[1], e = m[5], f = m[9];
    double g = m[2], h = m[6], i = m[10];
    std::array<double, 9> cof = {e * i - f * h, f * g - d * i, d * h - e * g,
                                 c * h - b * i, a * i - c * g, b * g - a * h,
                                 b * f - c * e, c * d - a * f, a * e - b * d};
    *det = a * cof[0] + b * cof[1] + c * cof[2];
    double s = *det < 0.0 ? -1.0 : 1.0;
    for (double &v : cof)
        v *= s;
    return cof;
}

/* T * R * S from a translation, a rotation quaternion (x, y, z, w;
 * normalized here) and a scale. */
Mat4 trs(const double t[3], const double rotation[4], const double s[3])
{
    double q[4] = {rotation[0], rotation[1], rotation[2], rotation[3]};
    double len = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (len > 0.0 && std::isfinite(len)) {
        for (double &v : q)
            v /= len;
    }
    const double x = q[0], y = q[1], z = q[2], w = q[3];
    /* Columns of R scaled by S; T in the last column. */
    const double r[9] = {1 - 2 * (y * y + z * z), 2 * (x * y + z * w), 2 * (x * z - y * w),
                         2 * (x * y - z * w), 1 - 2 * (x * x + z * z), 2 * (y * z + x * w),
                         2 * (x * z + y * w), 2 * (y * z - x * w), 1 - 2 * (x * x + y * y)};
    Mat4 m = identity();
    for (int c = 0; c < 3; c++)
        for (int row = 0; row < 3; row++)
            m[size_t(c * 4 + row)] = r[c * 3 + row] * s[c];
    m[12] = t[0];
    m[13] = t[1];
    m[14] = t[2];
    return m;
}

std::string trimmed(const std::string &s)
{
    size_t b = s.find_first_not_of(" \t\r\n");
    if (b == std::string::npos)
        return std::string();
    return s.substr(b, s.find_last_not_of(" \t\r\n") - b + 1);
}

std::vector<std::string> lines_of(const std::string &text)
{
    std::vector<std::string> out;
    std::istringstream in(text);
    std::string line;
    while (std::getline(in, line)) {
        line = trimmed(line);
        if (!line.empty())
            out.push_back(line);
    }
    return out;
}

bool starts_with(const std::string &s, const char *prefix) { return s.compare(0, std::strlen(prefix), prefix) == 0; }

/* "mesh 3 'Cube'", or "mesh 3" when the object has no name. */
std::string label(const char *kind, size_t index, const std::string &name)
{
    std::string out = std::string(kind) + " " + std::to_string(index);
    return name.empty() ? out : out + " '" + name + "'";
}

/* Passes tinygltf's warnings on, prefixed with the file name. A missing
 * external image is left out: it becomes a texture that the texture
 * service reports, once, when a plugin actually needs it. */
void log_warnings(const char *path, const std::string &text)
{
    std::vector<std::string> lines = lines_of(text);
    std::vector<bool> drop(lines.size(), false);
    for (size_t i = 0; i < lines.size(); i++) {
        if (starts_with(lines[i], "Failed to load external 'uri' for image[")) {
            drop[i] = true;
            if (i > 0 && starts_with(lines[i - 1], "File "))
                drop[i - 1] = true;
        }
    }
    size_t shown = 0, more = 0;
    for (size_t i = 0; i < lines.size(); i++) {
        if (drop[i])
            continue;
        if (shown++ < max_messages)
            rtk_log(RTK_LOG_WARN, "%s: %s", path, lines[i].c_str());
        else
            more++;
    }
    if (more)
        rtk_log(RTK_LOG_WARN, "%s: %zu more warnings", path, more);
}

std::string one_line(const std::string &text)
{
    std::string out;
    for (const std::string &line : lines_of(text))
        out += out.empty() ? line : "; " + line;
    return out.empty() ? std::string("tinygltf could not parse the file") : out;
}

std::string take(char *s)
{
    if (!s)
        throw std::bad_alloc();
    std::string out(s);
    std::free(s);
    return out;
}

int hex_digit(char c)
{
    if (c >= '0' && c <= '9')
        return c - '0';
    if (c >= 'a' && c <= 'f')
        return c - 'a' + 10;
    if (c >= 'A' && c <= 'F')
        return c - 'A' + 10;
    return -1;
}

/* URIs are percent-encoded ("my%20texture.png"). */
std::string uri_decode(const std::string &uri)
{
    std::string out;
    for (size_t i = 0; i < uri.size(); i++) {
        int hi, lo;
        if (uri[i] == '%' && i + 2 < uri.size() && (hi = hex_digit(uri[i + 1])) >= 0 &&
            (lo = hex_digit(uri[i + 2])) >= 0) {
            out += char(hi * 16 + lo);
            i += 2;
        } else {
            out += uri[i];
        }
    }
    return out;
}

/* Image-loader callback: records instead of decoding. Only data URIs need
 * their bytes kept, since tinygltf drops the decoded base64 afterwards;
 * external files are referenced by uri and glb images by buffer view. */
bool keep_image(tinygltf::Image *image, const int, std::string *, std::string *, int, int,
                const unsigned char *bytes, int size, void *)
{
    if (image->uri.empty() && image->bufferView < 0 && bytes && size > 0)
        image->image.assign(bytes, bytes + size);
    image->as_is = true;
    return true;
}

/* A validated accessor: count elements of elem_size bytes, stride apart. */
struct View {
    const unsigned char *data = nullptr;
    size_t count = 0, stride = 0;
    int component = 0;
    bool normalized = false;
};

/* Where an accessor is read from, for messages. */
struct Where {
    int mesh, primitive; /* primitive -1: mesh is a node (a node's own accessors) */
    const char *what;    /* "POSITION", "indices" ... */
};

const char *type_name(int type)
{
    switch (type) {
    case TINYGLTF_TYPE_SCALAR: return "SCALAR";
    case TINYGLTF_TYPE_VEC2: return "VEC2";
    case TINYGLTF_TYPE_VEC3: return "VEC3";
    case TINYGLTF_TYPE_VEC4: return "VEC4";
    case TINYGLTF_TYPE_MAT2: return "MAT2";
    case TINYGLTF_TYPE_MAT3: return "MAT3";
    case TINYGLTF_TYPE_MAT4: return "MAT4";
    default: return "unknown";
    }
}

const char *component_name(int component)
{
    switch (component) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: return "BYTE";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return "UNSIGNED_BYTE";
    case TINYGLTF_COMPONENT_TYPE_SHORT: return "SHORT";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return "UNSIGNED_SHORT";
    case TINYGLTF_COMPONENT_TYPE_INT: return "INT";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: return "UNSIGNED_INT";
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return "FLOAT";
    case TINYGLTF_COMPONENT_TYPE_DOUBLE: return "DOUBLE";
    default: return "unknown";
    }
}

size_t component_size(int component)
{
    switch (component) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
    case TINYGLTF_COMPONENT_TYPE_INT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
    default: return 0;
    }
}

size_t component_count(int type)
{
    switch (type) {
    case TINYGLTF_TYPE_SCALAR: return 1;
    case TINYGLTF_TYPE_VEC2: return 2;
    case TINYGLTF_TYPE_VEC3: return 3;
    case TINYGLTF_TYPE_VEC4: return 4;
    case TINYGLTF_TYPE_MAT4: return 16;
    default: return 0;
    }
}

float read_float(const unsigned char *p)
{
    float f;
    std::memcpy(&f, p, sizeof f);
    return f;
}

/* Component k of element i; normalized integers map to [0, 1] (unsigned)
 * or [-1, 1] (signed), as glTF and KHR_mesh_quantization define them. */
double read_component(const View &v, size_t i, size_t k)
{
    const unsigned char *p = v.data + i * v.stride + k * component_size(v.component);
    switch (v.component) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
        const double c = double(int8_t(p[0]));
        return v.normalized ? std::max(c / 127.0, -1.0) : c;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return v.normalized ? p[0] / 255.0 : p[0];
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
        int16_t c;
        std::memcpy(&c, p, sizeof c);
        return v.normalized ? std::max(c / 32767.0, -1.0) : c;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        uint16_t u;
        std::memcpy(&u, p, sizeof u);
        return v.normalized ? u / 65535.0 : u;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
        uint32_t u;
        std::memcpy(&u, p, sizeof u);
        return u;
    }
    default: return read_float(p);
    }
}

double number(const tinygltf::Value &v, double fallback)
{
    if (!v.IsNumber())
        return fallback;
    double d = v.GetNumberAsDouble();
    return std::isfinite(d) ? d : fallback;
}

float clean(double v, float fallback) { return std::isfinite(v) ? float(v) : fallback; }

float clamp01(float v) { return v < 0.0f ? 0.0f : v > 1.0f ? 1.0f : v; }

/* Component types of vertex attributes: float, and the integer types of
 * KHR_mesh_quantization (normalized or not). */
const std::vector<int> vertex_components = {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_BYTE,
                                            TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_SHORT,
                                            TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT};

/* Extensions whose "required" use rtk honours; any other required
 * extension changes the meaning of the data, so the file is refused. */
const char *const supported_required[] = {"KHR_materials_emissive_strength", "KHR_materials_ior",
                                          "KHR_materials_transmission", "KHR_materials_specular",
                                          "KHR_lights_punctual",
                                          "KHR_mesh_quantization", "KHR_texture_transform",
                                          "EXT_mesh_gpu_instancing"};

const char *const draco_extension = "KHR_draco_mesh_compression";
const char *const meshopt_extension = "EXT_meshopt_compression";
#ifdef RTK_HAVE_MESHOPT
const bool meshopt_available = true;
#else
const bool meshopt_available = false;
#endif

bool supported_extension(const std::string &name)
{
    for (const char *s : supported_required)
        if (name == s)
            return true;
    return (name == draco_extension && rtk_draco::available()) || (name == meshopt_extension && meshopt_available);
}

rtk_status refuse_extension(const char *path, const std::string &name)
{
    if (name == draco_extension)
        return rtk_error(RTK_ERR_UNSUPPORTED,
                         "%s: the file requires the glTF extension %s, and this rtk was built without Draco; "
                         "install libdraco-dev and rebuild rtk, or export the scene without Draco compression",
                         path, name.c_str());
    if (name == meshopt_extension)
        return rtk_error(RTK_ERR_UNSUPPORTED,
                         "%s: the file requires the glTF extension %s, and this rtk was built without "
                         "meshoptimizer; install libmeshoptimizer-dev and rebuild rtk, or export the scene without "
                         "meshopt compression",
                         path, name.c_str());
    return rtk_error(RTK_ERR_UNSUPPORTED,
                     "%s: the file requires the glTF extension %s, which rtk does not support; "
                     "export the scene without it",
                     path, name.c_str());
}

class Loader {
  public:
    Loader(const char *path, rtk_scene *scene, const tinygltf::Model &model)
        : path_(path), scene_(scene), model_(model), dir_(take(rtk_path_dirname(path))),
          want_normals_((scene->needs & RTK_NEED_NORMALS) != 0),
          want_uvs_((scene->needs & (RTK_NEED_UVS | RTK_NEED_TEXTURES)) != 0),
          want_colors_((scene->needs & (RTK_NEED_MATERIALS | RTK_NEED_TEXTURES | RTK_NEED_LIGHTS)) != 0),
          on_path_(model.nodes.size(), 0), mesh_uses_(model.meshes.size(), 0),
          mesh_index_(model.meshes.size(), RTK_INVALID_ID)
    {
        for (const tinygltf::Node &node : model.nodes)
            if (node.mesh >= 0 && size_t(node.mesh) < mesh_uses_.size() && !own_shape(node))
                mesh_uses_[size_t(node.mesh)]++;
    }

    /* A node that shapes its mesh itself (morph weights of its own, a
     * skin) gets a flattened copy; the other uses of the mesh may share one. */
    static bool own_shape(const tinygltf::Node &node) { return !node.weights.empty() || node.skin >= 0; }

    rtk_status run();

  private:
    const char *path_;
    rtk_scene *scene_;
    const tinygltf::Model &model_;
    std::string dir_;
    bool want_normals_, want_uvs_, want_colors_;
    std::vector<char> on_path_;
    /* Nodes using each mesh: a mesh used by more than one is instanced
     * (one copy in object space, its own BVH) instead of flattened. */
    std::vector<size_t> mesh_uses_;
    std::vector<uint32_t> mesh_index_; /* glTF mesh -> rtk mesh, RTK_INVALID_ID until made */
    size_t flat_instances_ = 0;         /* instances with a singular transform, not placed */
    size_t visits_ = 0;
    size_t skipped_primitives_ = 0, ragged_primitives_ = 0;
    bool ortho_warned_ = false, other_uv_sets_ = false;
    bool uses_uv1_ = false;   /* a texture reads TEXCOORD_1 */
    bool alpha_uv1_ = false;  /* a cutout's alpha does */
    std::vector<uint32_t> materials_;
    std::map<std::pair<int, int>, int> textures_; /* (image, srgb) -> scene texture */

    rtk_status check_extensions();
    rtk_status add_materials();
    rtk_status add_texture(size_t material, const char *slot, int index, int srgb, int *out, rtk_tex_wrap *wrap);
    /* The texture an extension's textureInfo object names (key in ext)
     * into map, reading channel; none when ext has no such key. */
    rtk_status add_extension_map(size_t material, const tinygltf::Value &ext, const char *key, int srgb,
                                 uint8_t channel, rtk_tex_slot *map);
    rtk_tex_wrap sampler_wrap(size_t material, const char *slot, const tinygltf::Texture &tex);
    /* A texture use's uv set (texCoord) and KHR_texture_transform. */
    rtk_tex_map tex_map(size_t material, const char *slot, int tex_coord, const tinygltf::ExtensionMap &extensions);
    rtk_status visit(int index, const Mat4 &parent, int depth);
    rtk_status local_matrix(int index, Mat4 *out);
    void take_camera(int index, const Mat4 &world);
    rtk_status take_light(int index, const Mat4 &world);
    /* Adds a primitive placed by world, its morph targets at weights;
     * with joints (a skin's joint matrices), each vertex placed by its
     * joints instead (world for a vertex without weights). */
    rtk_status add_primitive(int mesh, int primitive, const Mat4 &world, const std::vector<double> &weights,
                             rtk_scene *dst, const std::vector<Mat4> *joints = nullptr);
    /* Each vertex's matrix: its JOINTS_n matrices blended by WEIGHTS_n. */
    rtk_status skin_vertices(int mesh, int primitive, const std::vector<Mat4> &joints, const Mat4 &fallback,
                             size_t count, std::vector<Mat4> *out);
    /* A skin's joint matrices: each joint's world transform times its
     * inverse bind matrix (the file's rest pose). */
    rtk_status joint_matrices(int node, std::vector<Mat4> *out);
    /* Node index's world transform, from its parents (memoised). */
    rtk_status global(int index, int depth, Mat4 *out);
    /* Decodes the primitive's KHR_draco_mesh_compression data: its
     * attributes' accessors read from decoded_, its corners into indices. */
    rtk_status decode_draco(int mesh, int primitive, const tinygltf::Value &ext, std::vector<uint32_t> *indices);
    std::map<int, std::vector<double>> decoded_; /* accessor -> values, while a Draco primitive is added */
    std::vector<int> parent_;    /* made on first use: each node's parent, -1 for none */
    std::vector<Mat4> globals_;
    std::vector<char> global_done_;
    /* Adds weights[t] times morph target t's attribute what to values
     * (3 per vertex). */
    rtk_status morph(int mesh, int primitive, const char *what, const std::vector<double> &weights,
                     std::vector<double> *values);
    rtk_status add_instance(int node, int mesh, const Mat4 &world);
    /* Places node's mesh once per EXT_mesh_gpu_instancing element. */
    rtk_status add_gpu_instances(int node, const Mat4 &world, const tinygltf::Value &ext);
    /* Validates count elements of elem bytes from offset in buffer view
     * index (its stride unless packed) for accessor; part prefixes messages. */
    rtk_status locate(const Where &where, int accessor, const char *part, int index, size_t offset, size_t count,
                      size_t elem, bool packed, View *out);
    /* Accessor index's elements, components in a row, normalized
     * integers mapped to floats and sparse values applied. */
    rtk_status read(int accessor, const Where &where, const std::vector<int> &components, int type,
                    std::vector<double> *out);
    rtk_status fail(const Where &where, int accessor, const char *fmt, ...) RTK_PRINTF(4, 5);
    std::string node_label(int index) const { return label("node", size_t(index), model_.nodes[size_t(index)].name); }
    std::string mesh_label(int index) const { return label("mesh", size_t(index), model_.meshes[size_t(index)].name); }
};

rtk_status Loader::fail(const Where &where, int accessor, const char *fmt, ...)
{
    char problem[1024];
    va_list ap;
    va_start(ap, fmt);
    std::vsnprintf(problem, sizeof problem, fmt, ap);
    va_end(ap);
    if (where.primitive < 0)
        return rtk_error(RTK_ERR_PARSE, "%s: %s, %s accessor %d: %s", path_, node_label(where.mesh).c_str(), where.what,
                         accessor, problem);
    return rtk_error(RTK_ERR_PARSE, "%s: %s primitive %d, %s accessor %d: %s", path_, mesh_label(where.mesh).c_str(),
                     where.primitive, where.what, accessor, problem);
}

rtk_status Loader::locate(const Where &where, int accessor, const char *part, int index, size_t offset, size_t count,
                          size_t elem, bool packed, View *out)
{
    if (index < 0 || size_t(index) >= model_.bufferViews.size())
        return fail(where, accessor, "%sbuffer view %d does not exist (the file has %zu)", part, index,
                    model_.bufferViews.size());
    const tinygltf::BufferView &bv = model_.bufferViews[size_t(index)];
    if (bv.buffer < 0 || size_t(bv.buffer) >= model_.buffers.size())
        return fail(where, accessor, "%sbuffer view %d uses buffer %d, which does not exist (the file has %zu)", part,
                    index, bv.buffer, model_.buffers.size());
    const size_t buffer_size = model_.buffers[size_t(bv.buffer)].data.size();
    if (bv.byteOffset > buffer_size || bv.byteLength > buffer_size - bv.byteOffset)
        return fail(where, accessor, "%sbuffer view %d (%zu bytes from offset %zu) does not fit in buffer %d (%zu bytes)",
                    part, index, bv.byteLength, bv.byteOffset, bv.buffer, buffer_size);
    const size_t stride = bv.byteStride && !packed ? bv.byteStride : elem;
    if (stride < elem)
        return fail(where, accessor, "%sbyte stride %zu is smaller than one element (%zu bytes)", part, stride, elem);
    out->data = NULL;
    if (count) {
        const size_t last = count - 1;
        if (last > (SIZE_MAX - elem) / stride || offset > bv.byteLength || last * stride + elem > bv.byteLength - offset)
            return fail(where, accessor, "%s%zu elements of %zu bytes, %zu apart, from offset %zu do not fit in buffer "
                        "view %d (%zu bytes)", part, count, elem, stride, offset, index, bv.byteLength);
        out->data = model_.buffers[size_t(bv.buffer)].data.data() + bv.byteOffset + offset;
    }
    out->count = count;
    out->stride = stride;
    return RTK_OK;
}

rtk_status Loader::read(int index, const Where &where, const std::vector<int> &components, int type,
                        std::vector<double> *out)
{
    if (index < 0 || size_t(index) >= model_.accessors.size())
        return fail(where, index, "no such accessor (the file has %zu)", model_.accessors.size());
    const tinygltf::Accessor &acc = model_.accessors[size_t(index)];
    bool known = false;
    std::string expected;
    for (int c : components) {
        known = known || c == acc.componentType;
        expected += (expected.empty() ? "" : " or ") + std::string(component_name(c));
    }
    if (!known)
        return fail(where, index, "component type %s (%d), expected %s", component_name(acc.componentType),
                    acc.componentType, expected.c_str());
    if (acc.type != type)
        return fail(where, index, "type %s, expected %s", type_name(acc.type), type_name(type));
    std::map<int, std::vector<double>>::const_iterator decoded = decoded_.find(index);
    if (decoded != decoded_.end()) {
        *out = decoded->second;
        return RTK_OK;
    }
    const size_t n = component_count(type), elem = component_size(acc.componentType) * n;
    if (acc.count > (SIZE_MAX / sizeof(double)) / n)
        return fail(where, index, "%zu elements is more than rtk can hold", acc.count);
    View v;
    v.component = acc.componentType;
    v.normalized = acc.normalized;
    /* A sparse accessor without a buffer view starts as zeros; its count
     * is bounded since no data in the file backs it. */
    if (acc.bufferView < 0 && acc.sparse.isSparse && acc.count > max_zero_elements)
        return fail(where, index, "%zu elements without a buffer view, more than rtk's limit of %zu", acc.count,
                    max_zero_elements);
    if (acc.bufferView >= 0 || !acc.sparse.isSparse) {
        rtk_status status = locate(where, index, "", acc.bufferView, acc.byteOffset, acc.count, elem, false, &v);
        if (status != RTK_OK)
            return status;
    }
    out->assign(acc.count * n, 0.0);
    for (size_t i = 0; v.data && i < acc.count; i++)
        for (size_t k = 0; k < n; k++)
            (*out)[i * n + k] = read_component(v, i, k);
    if (!acc.sparse.isSparse)
        return RTK_OK;
    /* Sparse: count (index, value) pairs replace elements of the base. */
    const int sc = acc.sparse.count, ic = acc.sparse.indices.componentType;
    if (sc < 1 || size_t(sc) > acc.count)
        return fail(where, index, "sparse count %d, expected 1 to the accessor's %zu", sc, acc.count);
    if (ic != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE && ic != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
        ic != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
        return fail(where, index, "sparse indices of component type %s (%d), expected UNSIGNED_BYTE, UNSIGNED_SHORT or "
                    "UNSIGNED_INT", component_name(ic), ic);
    if (acc.sparse.indices.byteOffset < 0 || acc.sparse.values.byteOffset < 0)
        return fail(where, index, "negative sparse byte offset");
    View iv, vv;
    iv.component = ic;
    vv.component = acc.componentType;
    vv.normalized = acc.normalized;
    rtk_status status = locate(where, index, "sparse indices: ", acc.sparse.indices.bufferView,
                               size_t(acc.sparse.indices.byteOffset), size_t(sc), component_size(ic), true, &iv);
    if (status != RTK_OK || (status = locate(where, index, "sparse values: ", acc.sparse.values.bufferView,
                                             size_t(acc.sparse.values.byteOffset), size_t(sc), elem, true, &vv)) != RTK_OK)
        return status;
    for (size_t j = 0; j < size_t(sc); j++) {
        const double target = read_component(iv, j, 0);
        if (target >= double(acc.count))
            return fail(where, index, "sparse index %zu is %.0f, but the accessor has %zu elements", j, target,
                        acc.count);
        for (size_t k = 0; k < n; k++)
            (*out)[size_t(target) * n + k] = read_component(vv, j, k);
    }
    return RTK_OK;
}

rtk_status Loader::check_extensions()
{
    for (const std::string &ext : model_.extensionsRequired)
        if (!supported_extension(ext))
            return refuse_extension(path_, ext);
    return RTK_OK;
}

rtk_tex_map Loader::tex_map(size_t material, const char *slot, int tex_coord, const tinygltf::ExtensionMap &extensions)
{
    rtk_tex_map map = {};
    int set = tex_coord;
    tinygltf::ExtensionMap::const_iterator ext = extensions.find("KHR_texture_transform");
    if (ext != extensions.end() && ext->second.IsObject()) {
        const tinygltf::Value &t = ext->second;
        double offset[2] = {0.0, 0.0}, scale[2] = {1.0, 1.0};
        const tinygltf::Value &o = t.Get("offset"), &sc = t.Get("scale");
        for (int k = 0; k < 2; k++) {
            if (o.IsArray() && o.ArrayLen() == 2)
                offset[k] = number(o.Get(k), 0.0);
            if (sc.IsArray() && sc.ArrayLen() == 2)
                scale[k] = number(sc.Get(k), 1.0);
        }
        const double r = number(t.Get("rotation"), 0.0), c = std::cos(r), s = std::sin(r);
        if (t.Has("texCoord"))
            set = int(number(t.Get("texCoord"), double(set)));
        /* translation * rotation * scale; the rotation's rows are the
         * extension's mat3(cos, sin, 0, -sin, cos, 0, ...) read row by row,
         * as conforming viewers apply it (TextureTransformTest's marks). */
        const double m[6] = {c * scale[0], s * scale[1], offset[0], -s * scale[0], c * scale[1], offset[1]};
        for (int k = 0; k < 6; k++)
            map.m[k] = float(m[k]);
        map.transformed = 1;
    }
    if (set != 0 && set != 1) {
        if (!other_uv_sets_)
            rtk_log(RTK_LOG_WARN, "%s: %s %s reads TEXCOORD_%d; rtk reads TEXCOORD_0 and TEXCOORD_1 and uses "
                    "TEXCOORD_0 there", path_, label("material", material, model_.materials[material].name).c_str(),
                    slot, set);
        other_uv_sets_ = true;
        set = 0;
    }
    map.set = uint8_t(set);
    uses_uv1_ = uses_uv1_ || set == 1;
    return map;
}

/* One axis of a glTF sampler: 10497 REPEAT (the default), 33071
 * CLAMP_TO_EDGE, 33648 MIRRORED_REPEAT. */
static uint8_t wrap_mode(int gl)
{
    if (gl == TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE)
        return RTK_WRAP_CLAMP;
    if (gl == TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT)
        return RTK_WRAP_MIRROR;
    return RTK_WRAP_REPEAT;
}

/* The wrap modes of tex's sampler; repeat without one. */
rtk_tex_wrap Loader::sampler_wrap(size_t material, const char *slot, const tinygltf::Texture &tex)
{
    rtk_tex_wrap wrap = {RTK_WRAP_REPEAT, RTK_WRAP_REPEAT};
    if (tex.sampler < 0)
        return wrap;
    if (size_t(tex.sampler) >= model_.samplers.size()) {
        rtk_log(RTK_LOG_WARN, "%s: %s %s: sampler %d does not exist; repeat wrapping", path_,
                label("material", material, model_.materials[material].name).c_str(), slot, tex.sampler);
        return wrap;
    }
    const tinygltf::Sampler &sm = model_.samplers[size_t(tex.sampler)];
    wrap.s = wrap_mode(sm.wrapS);
    wrap.t = wrap_mode(sm.wrapT);
    return wrap;
}

rtk_status Loader::add_texture(size_t material, const char *slot, int index, int srgb, int *out, rtk_tex_wrap *wrap)
{
    *out = -1;
    if (index < 0)
        return RTK_OK;
    const std::string mat = label("material", material, model_.materials[material].name);
    if (size_t(index) >= model_.textures.size()) {
        rtk_log(RTK_LOG_WARN, "%s: %s %s refers to texture %d, which does not exist; ignored", path_, mat.c_str(),
                slot, index);
        return RTK_OK;
    }
    const tinygltf::Texture &tex = model_.textures[size_t(index)];
    /* Per use: the image is one texture whatever sampler reads it. */
    *wrap = sampler_wrap(material, slot, tex);
    int source = tex.source;
    /* Image-format extensions (EXT_texture_webp ...) name their own source. */
    for (const auto &ext : tex.extensions) {
        if (source < 0 && ext.second.Get("source").IsInt())
            source = ext.second.Get("source").GetNumberAsInt();
    }
    if (source < 0 || size_t(source) >= model_.images.size()) {
        rtk_log(RTK_LOG_WARN, "%s: %s %s: texture %d has no usable image; ignored", path_, mat.c_str(), slot,
                index);
        return RTK_OK;
    }
    std::pair<int, int> key(source, srgb);
    std::map<std::pair<int, int>, int>::const_iterator found = textures_.find(key);
    if (found != textures_.end()) {
        *out = found->second;
        return RTK_OK;
    }
    const tinygltf::Image &image = model_.images[size_t(source)];
    rtk_status status;
    int added = -1;
    const std::string image_label = label("image", size_t(source), image.name);
    if (!image.uri.empty() && !starts_with(image.uri, "data:")) {
        std::string file = take(rtk_path_join(dir_.c_str(), uri_decode(image.uri).c_str()));
        status = rtk_scene_add_texture(scene_, NULL, file.c_str(), NULL, 0, srgb, &added);
    } else if (image.bufferView >= 0) {
        const tinygltf::BufferView *bv =
            size_t(image.bufferView) < model_.bufferViews.size() ? &model_.bufferViews[size_t(image.bufferView)] : NULL;
        const tinygltf::Buffer *buf =
            bv && bv->buffer >= 0 && size_t(bv->buffer) < model_.buffers.size() ? &model_.buffers[size_t(bv->buffer)]
                                                                                 : NULL;
        if (!buf || bv->byteOffset > buf->data.size() || bv->byteLength > buf->data.size() - bv->byteOffset ||
            !bv->byteLength) {
            rtk_log(RTK_LOG_WARN, "%s: %s refers to a buffer view that does not exist or does not fit its buffer; "
                    "ignored", path_, image_label.c_str());
            return RTK_OK;
        }
        const std::string name = std::string(path_) + ": " + image_label;
        status = rtk_scene_add_texture(scene_, name.c_str(), NULL, buf->data.data() + bv->byteOffset, bv->byteLength,
                                       srgb, &added);
    } else if (!image.image.empty()) {
        const std::string name = std::string(path_) + ": " + image_label + " (data URI)";
        status = rtk_scene_add_texture(scene_, name.c_str(), NULL, image.image.data(), image.image.size(), srgb, &added);
    } else {
        rtk_log(RTK_LOG_WARN, "%s: %s has no data rtk can read (unsupported data URI?); ignored", path_,
                image_label.c_str());
        return RTK_OK;
    }
    if (status != RTK_OK)
        return status;
    textures_[key] = added;
    *out = added;
    return RTK_OK;
}

rtk_status Loader::add_extension_map(size_t material, const tinygltf::Value &ext, const char *key, int srgb,
                                     uint8_t channel, rtk_tex_slot *map)
{
    const tinygltf::Value &info = ext.Get(key);
    if (!info.IsObject() || !info.Has("index"))
        return RTK_OK;
    int index = int(number(info.Get("index"), -1.0));
    int tex_coord = int(number(info.Get("texCoord"), 0.0));
    tinygltf::ExtensionMap extensions;
    const tinygltf::Value &nested = info.Get("extensions");
    if (nested.IsObject())
        for (const std::string &name : nested.Keys())
            extensions[name] = nested.Get(name);
    map->uv = tex_map(material, key, tex_coord, extensions);
    map->channel = channel;
    return add_texture(material, key, index, srgb, &map->tex, &map->wrap);
}

rtk_status Loader::add_materials()
{
    materials_.resize(model_.materials.size());
    for (size_t i = 0; i < model_.materials.size(); i++) {
        const tinygltf::Material &src = model_.materials[i];
        const tinygltf::PbrMetallicRoughness &pbr = src.pbrMetallicRoughness;
        const std::string who = label("material", i, src.name);
        const char *mat = who.c_str();
        const rtk_rgb white = rtk_rgb_make(1.0f, 1.0f, 1.0f);
        rtk_material m = rtk_material_default();
        m.name = const_cast<char *>(src.name.c_str());
        m.model = RTK_MODEL_METALLIC_ROUGHNESS;
        if (pbr.baseColorFactor.size() == 4) {
            const std::vector<double> &c = pbr.baseColorFactor;
            m.base_color = rtk_material_rgb(path_, mat, "baseColorFactor", c[0], c[1], c[2], white, 0, 1);
            m.alpha = rtk_material_value(path_, mat, "baseColorFactor alpha", c[3], 1.0f, 0, 1);
        }
        m.metallic = rtk_material_value(path_, mat, "metallicFactor", pbr.metallicFactor, 1.0f, 0, 1);
        m.single_sided = !src.doubleSided;
        m.roughness = rtk_material_value(path_, mat, "roughnessFactor", pbr.roughnessFactor, 1.0f, 0, 1);
        double strength = 1.0;
        tinygltf::ExtensionMap::const_iterator ext = src.extensions.find("KHR_materials_emissive_strength");
        if (ext != src.extensions.end())
            strength = number(ext->second.Get("emissiveStrength"), 1.0);
        if (src.emissiveFactor.size() == 3)
            m.emission = rtk_material_rgb(path_, mat, "emissiveFactor x emissiveStrength",
                                          src.emissiveFactor[0] * strength, src.emissiveFactor[1] * strength,
                                          src.emissiveFactor[2] * strength, rtk_rgb_make(0.0f, 0.0f, 0.0f), 0, FLT_MAX);
        ext = src.extensions.find("KHR_materials_ior");
        if (ext != src.extensions.end()) {
            double ior = number(ext->second.Get("ior"), 1.5);
            if (ior >= 1.0)
                m.ior = float(ior);
            else
                rtk_log(RTK_LOG_WARN, "%s: %s: KHR_materials_ior ior is %g; rtk takes an ior of at least 1 and "
                        "uses %g", path_, mat, ior, double(m.ior));
        }
        rtk_status status;
        ext = src.extensions.find("KHR_materials_transmission");
        if (ext != src.extensions.end()) {
            m.transmission = rtk_material_value(path_, mat, "transmissionFactor",
                                                number(ext->second.Get("transmissionFactor"), 0.0), 0.0f, 0, 1);
            if ((status = add_extension_map(i, ext->second, "transmissionTexture", 0, 0,
                                            &m.maps[RTK_MAP_TRANSMISSION])) != RTK_OK)
                return status;
        }
        ext = src.extensions.find("KHR_materials_specular");
        if (ext != src.extensions.end()) {
            const tinygltf::Value &sp = ext->second, &c = sp.Get("specularColorFactor");
            m.specular_weight =
                rtk_material_value(path_, mat, "specularFactor", number(sp.Get("specularFactor"), 1.0), 1.0f, 0, 1);
            if (c.IsArray() && c.ArrayLen() == 3)
                m.specular_color = rtk_material_rgb(path_, mat, "specularColorFactor", number(c.Get(0), NAN),
                                                    number(c.Get(1), NAN), number(c.Get(2), NAN), white, 0, FLT_MAX);
            if ((status = add_extension_map(i, sp, "specularTexture", 0, 3, &m.maps[RTK_MAP_SPECULAR])) != RTK_OK ||
                (status = add_extension_map(i, sp, "specularColorTexture", 1, 0,
                                            &m.maps[RTK_MAP_SPECULAR_COLOR])) != RTK_OK)
                return status;
        }
        if (src.alphaMode == "MASK") {
            m.alpha_mode = RTK_ALPHA_MASK;
            m.alpha_cutoff = clean(src.alphaCutoff, 0.5f);
        } else if (src.alphaMode == "BLEND") {
            m.alpha_mode = RTK_ALPHA_BLEND;
            m.coverage = 1; /* alpha is the chance that a ray stops */
        } else if (src.alphaMode != "OPAQUE") {
            rtk_log(RTK_LOG_WARN, "%s: %s has alphaMode '%s'; treated as OPAQUE", path_,
                    label("material", i, src.name).c_str(), src.alphaMode.c_str());
        }
        m.base_uv = tex_map(i, "baseColorTexture", pbr.baseColorTexture.texCoord, pbr.baseColorTexture.extensions);
        m.emission_uv = tex_map(i, "emissiveTexture", src.emissiveTexture.texCoord, src.emissiveTexture.extensions);
        m.normal_uv = tex_map(i, "normalTexture", src.normalTexture.texCoord, src.normalTexture.extensions);
        rtk_tex_slot &rough = m.maps[RTK_MAP_ROUGHNESS], &metal = m.maps[RTK_MAP_METALLIC];
        rough.uv = tex_map(i, "metallicRoughnessTexture", pbr.metallicRoughnessTexture.texCoord,
                           pbr.metallicRoughnessTexture.extensions);
        rough.channel = 1; /* G: roughness, B: metallic */
        if ((status = add_texture(i, "baseColorTexture", pbr.baseColorTexture.index, 1, &m.base_tex, &m.base_wrap)) !=
                RTK_OK ||
            (status = add_texture(i, "emissiveTexture", src.emissiveTexture.index, 1, &m.emission_tex,
                                  &m.emission_wrap)) != RTK_OK ||
            (status = add_texture(i, "normalTexture", src.normalTexture.index, 0, &m.normal_tex, &m.normal_wrap)) !=
                RTK_OK ||
            (status = add_texture(i, "metallicRoughnessTexture", pbr.metallicRoughnessTexture.index, 0, &rough.tex,
                                  &rough.wrap)) != RTK_OK)
            return status;
        metal = rough;
        metal.channel = 2;
        if (m.alpha_mode != RTK_ALPHA_OPAQUE) {
            m.alpha_tex = m.base_tex;
            m.alpha_wrap = m.base_wrap;
            m.alpha_uv = m.base_uv;
            alpha_uv1_ = alpha_uv1_ || m.alpha_uv.set == 1;
        }
        if ((status = rtk_scene_add_material(scene_, &m, &materials_[i])) != RTK_OK)
            return status;
    }
    return RTK_OK;
}

rtk_status Loader::local_matrix(int index, Mat4 *out)
{
    const tinygltf::Node &node = model_.nodes[size_t(index)];
    const char *bad = NULL;
    if (!node.matrix.empty() && node.matrix.size() != 16)
        bad = "matrix needs 16 numbers";
    else if (!node.translation.empty() && node.translation.size() != 3)
        bad = "translation needs 3 numbers";
    else if (!node.rotation.empty() && node.rotation.size() != 4)
        bad = "rotation needs 4 numbers";
    else if (!node.scale.empty() && node.scale.size() != 3)
        bad = "scale needs 3 numbers";
    if (bad)
        return rtk_error(RTK_ERR_PARSE, "%s: %s: %s", path_, node_label(index).c_str(), bad);

    Mat4 m = identity();
    if (node.matrix.size() == 16) {
        for (int k = 0; k < 16; k++)
            m[size_t(k)] = node.matrix[size_t(k)];
    } else {
        double t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 1}, s[3] = {1, 1, 1};
        for (size_t k = 0; k < node.translation.size(); k++)
            t[k] = node.translation[k];
        for (size_t k = 0; k < node.rotation.size(); k++)
            q[k] = node.rotation[k];
        for (size_t k = 0; k < node.scale.size(); k++)
            s[k] = node.scale[k];
        m = trs(t, q, s);
    }
    for (double v : m) {
        if (!std::isfinite(v))
            return rtk_error(RTK_ERR_PARSE, "%s: %s has a non-finite transform", path_, node_label(index).c_str());
    }
    *out = m;
    return RTK_OK;
}

void Loader::take_camera(int index, const Mat4 &world)
{
    const tinygltf::Node &node = model_.nodes[size_t(index)];
    if (size_t(node.camera) >= model_.cameras.size()) {
        rtk_log(RTK_LOG_WARN, "%s: %s refers to camera %d, which does not exist; ignored", path_,
                node_label(index).c_str(), node.camera);
        return;
    }
    const tinygltf::Camera &cam = model_.cameras[size_t(node.camera)];
    if (cam.type != "perspective") {
        if (!ortho_warned_)
            rtk_log(RTK_LOG_WARN, "%s: %s is %s; rtk only uses perspective cameras", path_,
                    label("camera", size_t(node.camera), cam.name).c_str(), cam.type.c_str());
        ortho_warned_ = true;
        return;
    }
    double yfov = cam.perspective.yfov;
    double pos[3], fwd[3], up[3];
    transform(world, 0, 0, 0, 1, pos);
    transform(world, 0, 0, -1, 0, fwd);
    transform(world, 0, 1, 0, 0, up);
    double lf = std::sqrt(fwd[0] * fwd[0] + fwd[1] * fwd[1] + fwd[2] * fwd[2]);
    double lu = std::sqrt(up[0] * up[0] + up[1] * up[1] + up[2] * up[2]);
    if (!(yfov > 0.0 && yfov < pi) || !(lf > 0.0) || !(lu > 0.0)) {
        rtk_log(RTK_LOG_WARN, "%s: %s on %s has an unusable field of view or transform; ignored", path_,
                label("camera", size_t(node.camera), cam.name).c_str(), node_label(index).c_str());
        return;
    }
    rtk_camera_desc &desc = scene_->camera;
    desc.position = rtk_vec3_make(float(pos[0]), float(pos[1]), float(pos[2]));
    desc.look_at = rtk_vec3_make(float(pos[0] + fwd[0] / lf), float(pos[1] + fwd[1] / lf), float(pos[2] + fwd[2] / lf));
    desc.up = rtk_vec3_make(float(up[0] / lu), float(up[1] / lu), float(up[2] / lu));
    desc.fov_deg = float(yfov * 180.0 / pi);
    double aspect = cam.perspective.aspectRatio;
    scene_->camera_aspect = aspect > 0.0 && std::isfinite(aspect) ? float(aspect) : 0.0f;
    scene_->has_camera = 1;
}

/* A node's KHR_lights_punctual light, placed by the node's transform: at
 * its origin, shining along its -Z axis. glTF intensities (candela for
 * point and spot, lux for directional) are taken as rtk's W/sr and W/m^2. */
rtk_status Loader::take_light(int index, const Mat4 &world)
{
    const tinygltf::Node &node = model_.nodes[size_t(index)];
    auto ext = node.extensions.find("KHR_lights_punctual");
    if (ext == node.extensions.end() || !ext->second.IsObject() || !ext->second.Has("light"))
        return RTK_OK;
    const tinygltf::Value &v = ext->second.Get("light");
    int id = v.IsNumber() ? v.GetNumberAsInt() : -1;
    if (id < 0 || size_t(id) >= model_.lights.size()) {
        rtk_log(RTK_LOG_WARN, "%s: %s refers to light %d, which does not exist; ignored", path_,
                node_label(index).c_str(), id);
        return RTK_OK;
    }
    const tinygltf::Light &gl = model_.lights[size_t(id)];
    rtk_punctual_light l = {};
    double pos[3], dir[3];
    transform(world, 0, 0, 0, 1, pos);
    transform(world, 0, 0, -1, 0, dir);
    double ld = std::sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
    double c[3] = {1.0, 1.0, 1.0};
    if (gl.color.size() == 3)
        c[0] = gl.color[0], c[1] = gl.color[1], c[2] = gl.color[2];
    double k = gl.intensity;
    if (!(ld > 0.0) || !std::isfinite(k) || k < 0.0 || !std::isfinite(c[0] + c[1] + c[2])) {
        rtk_log(RTK_LOG_WARN, "%s: light %d on %s has an unusable transform, colour or intensity; ignored", path_, id,
                node_label(index).c_str());
        return RTK_OK;
    }
    l.position = rtk_vec3_make(float(pos[0]), float(pos[1]), float(pos[2]));
    l.direction = rtk_vec3_make(float(dir[0] / ld), float(dir[1] / ld), float(dir[2] / ld));
    l.intensity = rtk_rgb_make(float(c[0] * k), float(c[1] * k), float(c[2] * k));
    if (gl.type == "directional") {
        l.type = RTK_LIGHT_DIRECTIONAL;
    } else if (gl.type == "spot") {
        l.type = RTK_LIGHT_SPOT;
        l.cos_inner = float(std::cos(gl.spot.innerConeAngle));
        l.cos_outer = float(std::cos(gl.spot.outerConeAngle));
    } else {
        l.type = RTK_LIGHT_POINT;
    }
    return rtk_scene_add_punctual(scene_, &l);
}

rtk_status Loader::morph(int mesh, int index, const char *what, const std::vector<double> &weights,
                         std::vector<double> *values)
{
    const tinygltf::Primitive &prim = model_.meshes[size_t(mesh)].primitives[size_t(index)];
    for (size_t t = 0; t < prim.targets.size() && t < weights.size(); t++) {
        const double w = weights[t];
        std::map<std::string, int>::const_iterator attr = prim.targets[t].find(what);
        if (w == 0.0 || !std::isfinite(w) || attr == prim.targets[t].end())
            continue;
        const std::string name = "morph target " + std::to_string(t) + " " + what;
        std::vector<double> delta;
        rtk_status status = read(attr->second, {mesh, index, name.c_str()}, vertex_components, TINYGLTF_TYPE_VEC3,
                                 &delta);
        if (status != RTK_OK)
            return status;
        if (delta.size() != values->size())
            return fail({mesh, index, name.c_str()}, attr->second, "%zu elements for %zu vertices", delta.size() / 3,
                        values->size() / 3);
        for (size_t i = 0; i < delta.size(); i++)
            (*values)[i] += w * delta[i];
    }
    return RTK_OK;
}

rtk_status Loader::global(int index, int depth, Mat4 *out)
{
    if (parent_.empty()) {
        parent_.assign(model_.nodes.size(), -1);
        globals_.resize(model_.nodes.size());
        global_done_.assign(model_.nodes.size(), 0);
        for (size_t i = 0; i < model_.nodes.size(); i++)
            for (int child : model_.nodes[i].children)
                if (child >= 0 && size_t(child) < parent_.size() && parent_[size_t(child)] < 0)
                    parent_[size_t(child)] = int(i);
    }
    if (global_done_[size_t(index)]) {
        *out = globals_[size_t(index)];
        return RTK_OK;
    }
    if (depth > max_depth)
        return rtk_error(RTK_ERR_PARSE, "%s: %s has more than %d ancestors (or its parents form a cycle)", path_,
                         node_label(index).c_str(), max_depth);
    Mat4 local, up = identity();
    rtk_status status = local_matrix(index, &local);
    if (status == RTK_OK && parent_[size_t(index)] >= 0)
        status = global(parent_[size_t(index)], depth + 1, &up);
    if (status != RTK_OK)
        return status;
    *out = globals_[size_t(index)] = mul(up, local);
    global_done_[size_t(index)] = 1;
    return RTK_OK;
}

rtk_status Loader::joint_matrices(int node, std::vector<Mat4> *out)
{
    const int id = model_.nodes[size_t(node)].skin;
    if (size_t(id) >= model_.skins.size())
        return rtk_error(RTK_ERR_PARSE, "%s: %s uses skin %d, but the file has %zu skins", path_,
                         node_label(node).c_str(), id, model_.skins.size());
    const tinygltf::Skin &skin = model_.skins[size_t(id)];
    std::vector<double> ibm;
    if (skin.inverseBindMatrices >= 0) {
        const std::string what = "skin " + std::to_string(id) + " inverseBindMatrices";
        rtk_status status = read(skin.inverseBindMatrices, {node, -1, what.c_str()}, {TINYGLTF_COMPONENT_TYPE_FLOAT},
                                 TINYGLTF_TYPE_MAT4, &ibm);
        if (status != RTK_OK)
            return status;
        if (ibm.size() / 16 < skin.joints.size())
            return fail({node, -1, what.c_str()}, skin.inverseBindMatrices, "%zu matrices for %zu joints",
                        ibm.size() / 16, skin.joints.size());
    }
    out->resize(skin.joints.size());
    for (size_t j = 0; j < skin.joints.size(); j++) {
        const int joint = skin.joints[j];
        if (joint < 0 || size_t(joint) >= model_.nodes.size())
            return rtk_error(RTK_ERR_PARSE, "%s: skin %d: joint %zu is node %d, but the file has %zu nodes", path_, id,
                             j, joint, model_.nodes.size());
        Mat4 g, inverse_bind = identity();
        rtk_status status = global(joint, 0, &g);
        if (status != RTK_OK)
            return status;
        if (!ibm.empty())
            std::copy(ibm.begin() + std::ptrdiff_t(j * 16), ibm.begin() + std::ptrdiff_t(j * 16 + 16),
                      inverse_bind.begin());
        (*out)[j] = mul(g, inverse_bind);
    }
    return RTK_OK;
}

rtk_status Loader::skin_vertices(int mesh, int index, const std::vector<Mat4> &joints, const Mat4 &fallback,
                                 size_t count, std::vector<Mat4> *out)
{
    const tinygltf::Primitive &prim = model_.meshes[size_t(mesh)].primitives[size_t(index)];
    out->assign(count, Mat4{});
    std::vector<double> total(count, 0.0);
    for (int set = 0;; set++) {
        const std::string jname = "JOINTS_" + std::to_string(set), wname = "WEIGHTS_" + std::to_string(set);
        std::map<std::string, int>::const_iterator ja = prim.attributes.find(jname), wa = prim.attributes.find(wname);
        if (ja == prim.attributes.end() || wa == prim.attributes.end()) {
            if (set == 0)
                return rtk_error(RTK_ERR_PARSE, "%s: %s primitive %d is skinned but has no JOINTS_0 and WEIGHTS_0",
                                 path_, mesh_label(mesh).c_str(), index);
            break;
        }
        std::vector<double> j, w;
        rtk_status status = read(ja->second, {mesh, index, jname.c_str()},
                                 {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT},
                                 TINYGLTF_TYPE_VEC4, &j);
        if (status != RTK_OK || (status = read(wa->second, {mesh, index, wname.c_str()},
                                               {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
                                                TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT},
                                               TINYGLTF_TYPE_VEC4, &w)) != RTK_OK)
            return status;
        if (j.size() != count * 4 || w.size() != count * 4)
            return fail({mesh, index, j.size() != count * 4 ? jname.c_str() : wname.c_str()},
                        j.size() != count * 4 ? ja->second : wa->second, "%zu elements for %zu vertices",
                        (j.size() != count * 4 ? j.size() : w.size()) / 4, count);
        for (size_t i = 0; i < count; i++)
            for (size_t k = 0; k < 4; k++) {
                const double weight = w[i * 4 + k];
                if (weight == 0.0 || !std::isfinite(weight))
                    continue;
                if (j[i * 4 + k] >= double(joints.size()))
                    return fail({mesh, index, jname.c_str()}, ja->second,
                                "vertex %zu uses joint %.0f, but the skin has %zu joints", i, j[i * 4 + k],
                                joints.size());
                const Mat4 &m = joints[size_t(j[i * 4 + k])];
                for (size_t e = 0; e < 16; e++)
                    (*out)[i][e] += weight * m[e];
                total[i] += weight;
            }
    }
    /* Weights meant to sum to 1 are scaled to; none at all keep the node's place. */
    for (size_t i = 0; i < count; i++) {
        if (total[i] > 0.0) {
            for (double &e : (*out)[i])
                e /= total[i];
        } else {
            (*out)[i] = fallback;
        }
    }
    return RTK_OK;
}

rtk_status Loader::decode_draco(int mesh, int index, const tinygltf::Value &ext, std::vector<uint32_t> *indices)
{
    const tinygltf::Primitive &prim = model_.meshes[size_t(mesh)].primitives[size_t(index)];
    const std::string where = path_ + std::string(": ") + mesh_label(mesh) + " primitive " + std::to_string(index) +
                              ": " + draco_extension;
    const tinygltf::Value &bv = ext.Get("bufferView"), &attributes = ext.Get("attributes");
    const int view = bv.IsNumber() ? bv.GetNumberAsInt() : -1;
    if (view < 0 || size_t(view) >= model_.bufferViews.size() || !attributes.IsObject())
        return rtk_error(RTK_ERR_PARSE, "%s: needs a bufferView (the file has %zu) and attributes", where.c_str(),
                         model_.bufferViews.size());
    const tinygltf::BufferView &v = model_.bufferViews[size_t(view)];
    const size_t size = v.buffer >= 0 && size_t(v.buffer) < model_.buffers.size()
                            ? model_.buffers[size_t(v.buffer)].data.size()
                            : 0;
    if (v.byteOffset > size || v.byteLength > size - v.byteOffset || !v.byteLength)
        return rtk_error(RTK_ERR_PARSE, "%s: buffer view %d (%zu bytes from offset %zu) does not fit in its buffer",
                         where.c_str(), view, v.byteLength, v.byteOffset);
    /* Each attribute of the primitive that the extension names, by its Draco id. */
    std::vector<std::pair<int, int>> wanted; /* (accessor, Draco id) */
    std::vector<int> ids;
    for (const auto &attr : prim.attributes) {
        if (!attributes.Has(attr.first))
            continue;
        const tinygltf::Value &id = attributes.Get(attr.first);
        if (!id.IsNumber() || id.GetNumberAsInt() < 0)
            return rtk_error(RTK_ERR_PARSE, "%s: attribute %s has no Draco id", where.c_str(), attr.first.c_str());
        wanted.emplace_back(attr.second, id.GetNumberAsInt());
        ids.push_back(id.GetNumberAsInt());
    }
    rtk_draco::Mesh decoded;
    std::string why;
    if (!rtk_draco::decode(model_.buffers[size_t(v.buffer)].data.data() + v.byteOffset, v.byteLength, ids, &decoded,
                           &why))
        return rtk_error(RTK_ERR_PARSE, "%s: %s", where.c_str(), why.c_str());
    for (const std::pair<int, int> &w : wanted) {
        const int accessor = w.first;
        const size_t n = size_t(accessor) < model_.accessors.size()
                             ? component_count(model_.accessors[size_t(accessor)].type)
                             : 0;
        if (n == 0 || int(n) != decoded.components[w.second])
            return rtk_error(RTK_ERR_PARSE, "%s: Draco attribute %d has %d components, accessor %d wants %zu",
                             where.c_str(), w.second, decoded.components[w.second], accessor, n);
        decoded_[accessor] = std::move(decoded.attributes[w.second]);
    }
    *indices = std::move(decoded.indices);
    return RTK_OK;
}

rtk_status Loader::add_primitive(int mesh, int index, const Mat4 &world, const std::vector<double> &weights,
                                 rtk_scene *dst, const std::vector<Mat4> *joints)
{
    const tinygltf::Primitive &prim = model_.meshes[size_t(mesh)].primitives[size_t(index)];
    /* Draco: the decoded attributes stand in for their accessors while
     * this primitive is added, its faces for the indices. */
    struct Forget {
        std::map<int, std::vector<double>> &decoded;
        ~Forget() { decoded.clear(); }
    } forget{decoded_};
    decoded_.clear();
    std::vector<uint32_t> indices;
    tinygltf::ExtensionMap::const_iterator draco = prim.extensions.find(draco_extension);
    const bool compressed = draco != prim.extensions.end() && rtk_draco::available();
    rtk_status status;
    if (compressed && (status = decode_draco(mesh, index, draco->second, &indices)) != RTK_OK)
        return status;
    const bool indexed = compressed || prim.indices >= 0;
    const int mode = compressed ? TINYGLTF_MODE_TRIANGLES : prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
    if (mode == TINYGLTF_MODE_POINTS || mode == TINYGLTF_MODE_LINE || mode == TINYGLTF_MODE_LINE_LOOP ||
        mode == TINYGLTF_MODE_LINE_STRIP) {
        skipped_primitives_++;
        return RTK_OK;
    }
    if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP && mode != TINYGLTF_MODE_TRIANGLE_FAN)
        return rtk_error(RTK_ERR_PARSE, "%s: %s primitive %d has mode %d, which is not a glTF mode", path_,
                         mesh_label(mesh).c_str(), index, mode);
    uint32_t material = RTK_INVALID_ID;
    if (prim.material >= 0) {
        if (size_t(prim.material) >= materials_.size())
            return rtk_error(RTK_ERR_PARSE, "%s: %s primitive %d uses material %d, but the file has %zu", path_,
                             mesh_label(mesh).c_str(), index, prim.material, materials_.size());
        material = materials_[size_t(prim.material)];
    }

    std::map<std::string, int>::const_iterator attr = prim.attributes.find("POSITION");
    if (attr == prim.attributes.end())
        return rtk_error(RTK_ERR_PARSE, "%s: %s primitive %d has no POSITION attribute", path_,
                         mesh_label(mesh).c_str(), index);
    Where where = {mesh, index, "POSITION"};
    std::vector<double> pos, nrm, tex;
    if ((status = read(attr->second, where, vertex_components, TINYGLTF_TYPE_VEC3, &pos)) != RTK_OK)
        return status;
    const int pos_accessor = attr->second;
    const size_t nverts = pos.size() / 3;
    if ((status = morph(mesh, index, "POSITION", weights, &pos)) != RTK_OK)
        return status;
    if (nverts >= size_t(RTK_INVALID_ID) - dst->vertex_count)
        return rtk_error(RTK_ERR_NOMEM, "%s: more vertices than rtk can index", path_);

    if (want_normals_ && (attr = prim.attributes.find("NORMAL")) != prim.attributes.end()) {
        where.what = "NORMAL";
        if ((status = read(attr->second, where, vertex_components, TINYGLTF_TYPE_VEC3, &nrm)) != RTK_OK)
            return status;
        if (nrm.size() != pos.size())
            return fail(where, attr->second, "%zu normals for %zu positions", nrm.size() / 3, nverts);
        if ((status = morph(mesh, index, "NORMAL", weights, &nrm)) != RTK_OK)
            return status;
    }
    /* Texture coordinates also serve the alpha of cutout materials. */
    if ((want_uvs_ || dst->cutout_materials) && (attr = prim.attributes.find("TEXCOORD_0")) != prim.attributes.end()) {
        where.what = "TEXCOORD_0";
        if ((status = read(attr->second, where, vertex_components, TINYGLTF_TYPE_VEC2, &tex)) != RTK_OK)
            return status;
        if (tex.size() / 2 != nverts)
            return fail(where, attr->second, "%zu texture coordinates for %zu positions", tex.size() / 2, nverts);
    }
    /* The second set when a texture reads it; a primitive without it
     * gives those textures TEXCOORD_0. */
    std::vector<double> tex1;
    if ((want_uvs_ && uses_uv1_) || (dst->cutout_materials && alpha_uv1_)) {
        if ((attr = prim.attributes.find("TEXCOORD_1")) != prim.attributes.end()) {
            where.what = "TEXCOORD_1";
            if ((status = read(attr->second, where, vertex_components, TINYGLTF_TYPE_VEC2, &tex1)) != RTK_OK)
                return status;
            if (tex1.size() / 2 != nverts)
                return fail(where, attr->second, "%zu texture coordinates for %zu positions", tex1.size() / 2, nverts);
        } else {
            tex1 = tex;
        }
    }
    /* Vertex colours (RGB or RGBA) multiply the base colour and alpha. */
    std::vector<float> colors;
    if ((want_colors_ || dst->cutout_materials) && (attr = prim.attributes.find("COLOR_0")) != prim.attributes.end()) {
        where.what = "COLOR_0";
        const bool rgb = size_t(attr->second) < model_.accessors.size() &&
                         model_.accessors[size_t(attr->second)].type == TINYGLTF_TYPE_VEC3;
        std::vector<double> c;
        if ((status = read(attr->second, where,
                           {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
                            TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT},
                           rgb ? TINYGLTF_TYPE_VEC3 : TINYGLTF_TYPE_VEC4, &c)) != RTK_OK)
            return status;
        const size_t k = rgb ? 3 : 4;
        if (c.size() / k != nverts)
            return fail(where, attr->second, "%zu colours for %zu positions", c.size() / k, nverts);
        colors.assign(nverts * 4, 1.0f);
        for (size_t i = 0; i < nverts; i++)
            for (size_t j = 0; j < k; j++)
                colors[i * 4 + j] = std::isfinite(c[i * k + j]) ? clamp01(float(c[i * k + j])) : 1.0f;
    }
    for (size_t i = 0; compressed && i < indices.size(); i++)
        if (indices[i] >= nverts)
            return rtk_error(RTK_ERR_PARSE, "%s: %s primitive %d: Draco corner %zu is point %u, but POSITION has %zu",
                             path_, mesh_label(mesh).c_str(), index, i, indices[i], nverts);
    if (!compressed && prim.indices >= 0) {
        where.what = "indices";
        std::vector<double> iv;
        if ((status = read(prim.indices, where,
                           {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT,
                            TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT},
                           TINYGLTF_TYPE_SCALAR, &iv)) != RTK_OK)
            return status;
        indices.resize(iv.size());
        for (size_t i = 0; i < iv.size(); i++) {
            indices[i] = uint32_t(iv[i]);
            if (indices[i] >= nverts)
                return fail(where, prim.indices, "index %zu is %u, but POSITION has %zu vertices", i, indices[i],
                            nverts);
        }
    }
    const size_t n = indexed ? indices.size() : nverts;
    if (n < 3)
        return RTK_OK;

    /* Each vertex's transform: world, or its blend of joint matrices. */
    std::vector<Mat4> skinned;
    if (joints && (status = skin_vertices(mesh, index, *joints, world, nverts, &skinned)) != RTK_OK)
        return status;
    const uint32_t base = dst->vertex_count;
    for (size_t i = 0; i < nverts; i++) {
        const double *v = &pos[i * 3];
        if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2]))
            return fail({mesh, index, "POSITION"}, pos_accessor, "element %zu is not finite (%g, %g, %g)", i, v[0],
                        v[1], v[2]);
        double w[3];
        transform(skinned.empty() ? world : skinned[i], v[0], v[1], v[2], 1.0, w);
        if (!std::isfinite(w[0]) || !std::isfinite(w[1]) || !std::isfinite(w[2]))
            return fail({mesh, index, "POSITION"}, pos_accessor, "element %zu is not finite once placed", i);
        if ((status = rtk_scene_add_vertex(dst, w[0], w[1], w[2], NULL)) != RTK_OK)
            return status;
    }

    double det;
    std::array<double, 9> nm = normal_matrix(world, &det);
    /* Skinned: per vertex, the side its own matrix turns it to. */
    std::vector<char> flipped(skinned.size());
    for (size_t i = 0; i < skinned.size(); i++) {
        double d;
        normal_matrix(skinned[i], &d);
        flipped[i] = d < 0.0;
    }
    std::vector<float> normals(nrm.size());
    for (size_t i = 0; i < nrm.size() / 3; i++) {
        const double *v = &nrm[i * 3];
        if (!skinned.empty())
            nm = normal_matrix(skinned[i], &det);
        double w[3];
        for (int r = 0; r < 3; r++)
            w[r] = nm[size_t(r * 3)] * v[0] + nm[size_t(r * 3 + 1)] * v[1] + nm[size_t(r * 3 + 2)] * v[2];
        /* Unusable normals stay zero or non-finite: rtk_scene_finish
         * replaces them by the geometric normal. */
        const double len = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
        for (int r = 0; r < 3; r++)
            normals[i * 3 + size_t(r)] = len > 0.0 ? float(w[r] / len) : 0.0f;
    }
    /* glTF's convention (v = 0 at the top row) is the texture service's. */
    std::vector<float> uvs(tex.begin(), tex.end()), uvs1(tex1.begin(), tex1.end());

    size_t triangles;
    if (mode == TINYGLTF_MODE_TRIANGLES) {
        triangles = n / 3;
        if (n % 3)
            ragged_primitives_++;
    } else {
        triangles = n - 2;
    }
    /* A mirroring transform turns the winding around; swapping two corners
     * keeps counter-clockwise as the front side. */
    const bool mirrored = det < 0.0;
    for (size_t t = 0; t < triangles; t++) {
        /* Corner positions in the index list, per the glTF spec's topologies. */
        const size_t list[3][3] = {{3 * t, 3 * t + 1, 3 * t + 2},
                                   {t, t + 1 + t % 2, t + 2 - t % 2},
                                   {t + 1, t + 2, 0}};
        const size_t *c = list[mode == TINYGLTF_MODE_TRIANGLES ? 0 : mode == TINYGLTF_MODE_TRIANGLE_STRIP ? 1 : 2];
        uint32_t v[3];
        for (int k = 0; k < 3; k++)
            v[k] = indexed ? indices[c[k]] : uint32_t(c[k]);
        if (skinned.empty() ? mirrored : flipped[v[0]] != 0)
            std::swap(v[1], v[2]);
        float tn[9], tuv[6], tuv1[6], tc[12];
        for (int k = 0; k < 3; k++) {
            if (!normals.empty())
                std::memcpy(tn + k * 3, &normals[size_t(v[k]) * 3], 3 * sizeof(float));
            if (!uvs.empty())
                std::memcpy(tuv + k * 2, &uvs[size_t(v[k]) * 2], 2 * sizeof(float));
            if (!uvs1.empty())
                std::memcpy(tuv1 + k * 2, &uvs1[size_t(v[k]) * 2], 2 * sizeof(float));
            if (!colors.empty())
                std::memcpy(tc + k * 4, &colors[size_t(v[k]) * 4], 4 * sizeof(float));
        }
        status = rtk_scene_add_triangle(dst, base + v[0], base + v[1], base + v[2], normals.empty() ? NULL : tn,
                                        uvs.empty() ? NULL : tuv, material);
        if (status == RTK_OK && (!uvs1.empty() || !colors.empty()))
            status = rtk_scene_set_corners(dst, uvs1.empty() ? NULL : tuv1, colors.empty() ? NULL : tc);
        if (status != RTK_OK)
            return status;
    }
    return RTK_OK;
}

/* A node using a mesh that other nodes use too: the mesh is made once, in
 * object space, and placed by the node's world transform. */
rtk_status Loader::add_instance(int node, int mesh, const Mat4 &world)
{
    rtk_status status;
    uint32_t &index = mesh_index_[size_t(mesh)];
    if (index == RTK_INVALID_ID) {
        std::string name = std::string(path_) + ": " + mesh_label(mesh);
        if ((status = rtk_scene_add_mesh(scene_, name.c_str(), &index)) != RTK_OK)
            return status;
        rtk_scene *dst = scene_->meshes[index];
        for (size_t p = 0; p < model_.meshes[size_t(mesh)].primitives.size(); p++) {
            if ((status = add_primitive(mesh, int(p), identity(), model_.meshes[size_t(mesh)].weights, dst)) !=
                RTK_OK)
                return status;
        }
    }
    double det;
    normal_matrix(world, &det);
    if (det == 0.0 || !std::isfinite(det)) {
        flat_instances_++; /* a zero scale hides the node; flattening would drop it too */
        return RTK_OK;
    }
    double to_world[12];
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 4; c++)
            to_world[r * 4 + c] = world[size_t(c * 4 + r)];
    std::string where = std::string(path_) + ": " + node_label(node);
    return rtk_scene_add_instance(scene_, index, to_world, where.c_str());
}

rtk_status Loader::add_gpu_instances(int node, const Mat4 &world, const tinygltf::Value &ext)
{
    const char *names[3] = {"TRANSLATION", "ROTATION", "SCALE"};
    const int types[3] = {TINYGLTF_TYPE_VEC3, TINYGLTF_TYPE_VEC4, TINYGLTF_TYPE_VEC3};
    const std::vector<int> components[3] = {
        {TINYGLTF_COMPONENT_TYPE_FLOAT},
        {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_BYTE, TINYGLTF_COMPONENT_TYPE_SHORT},
        {TINYGLTF_COMPONENT_TYPE_FLOAT}};
    const tinygltf::Value &attributes = ext.Get("attributes");
    std::vector<double> values[3];
    size_t count = 0;
    bool any = false;
    for (int a = 0; a < 3; a++) {
        if (!attributes.IsObject() || !attributes.Has(names[a]))
            continue;
        const std::string what = std::string("EXT_mesh_gpu_instancing ") + names[a];
        const tinygltf::Value &id = attributes.Get(names[a]);
        const int accessor = id.IsNumber() ? id.GetNumberAsInt() : -1;
        rtk_status status = read(accessor, {node, -1, what.c_str()}, components[a], types[a], &values[a]);
        if (status != RTK_OK)
            return status;
        const size_t n = values[a].size() / component_count(types[a]);
        if (any && n != count)
            return fail({node, -1, what.c_str()}, accessor, "%zu elements, but the other attributes have %zu", n,
                        count);
        count = n;
        any = true;
    }
    if (!any)
        return rtk_error(RTK_ERR_PARSE, "%s: %s: EXT_mesh_gpu_instancing has no TRANSLATION, ROTATION or SCALE "
                         "attribute", path_, node_label(node).c_str());
    const int mesh = model_.nodes[size_t(node)].mesh;
    for (size_t i = 0; i < count; i++) {
        double t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 1}, s[3] = {1, 1, 1};
        if (!values[0].empty())
            std::memcpy(t, &values[0][i * 3], sizeof t);
        if (!values[1].empty())
            std::memcpy(q, &values[1][i * 4], sizeof q);
        if (!values[2].empty())
            std::memcpy(s, &values[2][i * 3], sizeof s);
        const Mat4 m = mul(world, trs(t, q, s));
        for (double v : m)
            if (!std::isfinite(v))
                return rtk_error(RTK_ERR_PARSE, "%s: %s: EXT_mesh_gpu_instancing element %zu has a non-finite "
                                 "transform", path_, node_label(node).c_str(), i);
        rtk_status status = add_instance(node, mesh, m);
        if (status != RTK_OK)
            return status;
    }
    return RTK_OK;
}

rtk_status Loader::visit(int index, const Mat4 &parent, int depth)
{
    if (index < 0 || size_t(index) >= model_.nodes.size())
        return rtk_error(RTK_ERR_PARSE, "%s: the scene refers to node %d, but the file has %zu nodes", path_, index,
                         model_.nodes.size());
    if (on_path_[size_t(index)])
        return rtk_error(RTK_ERR_PARSE, "%s: %s is its own ancestor: the node hierarchy has a cycle", path_,
                         node_label(index).c_str());
    if (depth > max_depth)
        return rtk_error(RTK_ERR_PARSE, "%s: %s is nested more than %d levels deep", path_,
                         node_label(index).c_str(), max_depth);
    if (++visits_ > max_node_visits)
        return rtk_error(RTK_ERR_PARSE, "%s: the node hierarchy expands to more than %zu node instances "
                         "(shared subtrees?)", path_, max_node_visits);
    Mat4 local;
    rtk_status status = local_matrix(index, &local);
    if (status != RTK_OK)
        return status;
    const Mat4 world = mul(parent, local);
    const tinygltf::Node &node = model_.nodes[size_t(index)];
    if (node.camera >= 0 && !scene_->has_camera)
        take_camera(index, world);
    if ((scene_->needs & RTK_NEED_LIGHTS) && (status = take_light(index, world)) != RTK_OK)
        return status;
    if (node.mesh >= 0) {
        if (size_t(node.mesh) >= model_.meshes.size())
            return rtk_error(RTK_ERR_PARSE, "%s: %s uses mesh %d, but the file has %zu meshes", path_,
                             node_label(index).c_str(), node.mesh, model_.meshes.size());
        const tinygltf::Mesh &mesh = model_.meshes[size_t(node.mesh)];
        tinygltf::ExtensionMap::const_iterator gpu = node.extensions.find("EXT_mesh_gpu_instancing");
        if (gpu != node.extensions.end()) {
            if ((status = add_gpu_instances(index, world, gpu->second)) != RTK_OK)
                return status;
        } else if (mesh_uses_[size_t(node.mesh)] > 1 && !own_shape(node)) {
            if ((status = add_instance(index, node.mesh, world)) != RTK_OK)
                return status;
        } else {
            /* Morph weights: the node's, else the mesh's defaults. A skin
             * places the vertices by its joints, not by the node. */
            const std::vector<double> &weights = node.weights.empty() ? mesh.weights : node.weights;
            std::vector<Mat4> joints;
            if (node.skin >= 0 && (status = joint_matrices(index, &joints)) != RTK_OK)
                return status;
            for (size_t p = 0; p < mesh.primitives.size(); p++) {
                if ((status = add_primitive(node.mesh, int(p), world, weights, scene_,
                                            node.skin >= 0 ? &joints : nullptr)) != RTK_OK)
                    return status;
            }
        }
    }
    on_path_[size_t(index)] = 1;
    for (int child : node.children) {
        if ((status = visit(child, world, depth + 1)) != RTK_OK)
            return status;
    }
    on_path_[size_t(index)] = 0;
    return RTK_OK;
}

rtk_status Loader::run()
{
    if (!starts_with(model_.asset.version, "2."))
        return rtk_error(RTK_ERR_UNSUPPORTED, "%s: the file is glTF %s; rtk reads glTF 2.0", path_,
                         model_.asset.version.empty() ? "of unknown version" : model_.asset.version.c_str());
    rtk_status status = check_extensions();
    if (status != RTK_OK || (status = add_materials()) != RTK_OK)
        return status;

    std::vector<int> roots;
    if (!model_.scenes.empty()) {
        int s = model_.defaultScene < 0 ? 0 : model_.defaultScene;
        if (size_t(s) >= model_.scenes.size()) {
            rtk_log(RTK_LOG_WARN, "%s: default scene %d does not exist; using scene 0", path_, s);
            s = 0;
        }
        roots = model_.scenes[size_t(s)].nodes;
    } else {
        /* No scenes: render every node that is nobody's child. */
        std::vector<char> is_child(model_.nodes.size(), 0);
        for (const tinygltf::Node &node : model_.nodes)
            for (int child : node.children)
                if (child >= 0 && size_t(child) < is_child.size())
                    is_child[size_t(child)] = 1;
        for (size_t i = 0; i < model_.nodes.size(); i++)
            if (!is_child[i])
                roots.push_back(int(i));
    }
    for (int root : roots) {
        if ((status = visit(root, identity(), 0)) != RTK_OK)
            return status;
    }
    if (skipped_primitives_)
        rtk_log(RTK_LOG_WARN, "%s: skipped %zu point and line primitive%s (only triangles are rendered)", path_,
                skipped_primitives_, skipped_primitives_ == 1 ? "" : "s");
    if (flat_instances_)
        rtk_log(RTK_LOG_DEBUG, "%s: %zu node%s with a zero-scale transform not placed", path_, flat_instances_,
                flat_instances_ == 1 ? "" : "s");
    if (ragged_primitives_)
        rtk_log(RTK_LOG_WARN, "%s: %zu TRIANGLES primitive%s had an index count that is not a multiple of 3; "
                "the extra indices were ignored", path_, ragged_primitives_, ragged_primitives_ == 1 ? "" : "s");
    return RTK_OK;
}

/* What rtk reads of the JSON text before tinygltf parses it. */
struct Prescan {
    std::vector<std::string> required; /* extensionsRequired */
    std::string version;               /* asset.version */
    /* Text to put in place of [at, at + erase), in order: meshopt
     * fallback buffers without a uri get four bytes of their own, since
     * tinygltf refuses a buffer without data. */
    struct Edit {
        size_t at, erase;
        std::string text;
    };
    std::vector<Edit> edits;
};

/* The JSON string whose opening quote is t[*i]; *i is left past its
 * closing quote. Escapes other than \" \\ \/ are kept as written. */
std::string json_string(const char *t, size_t n, size_t *i)
{
    std::string out;
    size_t k = *i + 1;
    while (k < n && t[k] != '"') {
        if (t[k] == '\\' && k + 1 < n) {
            const char c = t[k + 1];
            if (c != '"' && c != '\\' && c != '/')
                out += '\\';
            out += c;
            k += 2;
        } else {
            out += t[k++];
        }
    }
    *i = k < n ? k + 1 : n;
    return out;
}

/* Whether the open levels are those of meshes[m].primitives[p]'s object
 * or deeper. */
bool in_primitive(const std::vector<char> &open, const std::vector<std::string> &keys)
{
    return open.size() >= 5 && open[0] == '{' && open[1] == '[' && open[2] == '{' && open[3] == '[' &&
           open[4] == '{' && keys[0] == "meshes" && keys[2] == "primitives";
}

/* Scans the JSON text (strings skipped as such) for its nesting depth,
 * refused past max_json_depth since tinygltf's parser recurses once per
 * level, and for the required extensions and the version. Malformed JSON
 * is left to tinygltf to report. When Draco is available, the key
 * "indices" of a primitive that has KHR_draco_mesh_compression becomes
 * "_ndices" in t: its accessor has no buffer view (the faces are in the
 * Draco data), which tinygltf 2.7 refuses for indices. */
rtk_status prescan_json(const char *path, char *t, size_t n, Prescan *out)
{
    std::vector<char> open;        /* '{' or '[' per open level */
    std::vector<std::string> keys; /* the last key read at each level */
    size_t indices_key = std::string::npos; /* the current primitive's "indices", when Draco may take it */
    bool draco = false;                     /* the current primitive has the Draco extension */
    /* The current buffer: where it opens, its byteLength's digits, a uri,
     * the meshopt extension (its data is decoded into buffers of its own). */
    size_t buffer_open = 0, length_at = 0, length_size = 0;
    bool buffer_uri = false, buffer_meshopt = false;
    size_t i = 0;
    while (i < n) {
        const char c = t[i];
        if (c == '"') {
            const size_t at = i;
            std::string str = json_string(t, n, &i);
            size_t j = i;
            while (j < n && (t[j] == ' ' || t[j] == '\t' || t[j] == '\r' || t[j] == '\n'))
                j++;
            const size_t d = open.size();
            if (d > 0 && open[d - 1] == '{' && j < n && t[j] == ':') {
                keys[d - 1] = str;
                i = j + 1;
                if (d == 5 && str == "indices" && in_primitive(open, keys) && rtk_draco::available())
                    indices_key = at;
                if (d == 6 && str == draco_extension && in_primitive(open, keys) && keys[4] == "extensions")
                    draco = true;
                if (d == 3 && keys[0] == "buffers" && open[1] == '[') {
                    buffer_uri = buffer_uri || str == "uri";
                    if (str == "byteLength") {
                        size_t k = i;
                        while (k < n && (t[k] == ' ' || t[k] == '\t' || t[k] == '\r' || t[k] == '\n'))
                            k++;
                        length_at = k;
                        while (k < n && t[k] >= '0' && t[k] <= '9')
                            k++;
                        length_size = k - length_at;
                    }
                }
                if (d == 4 && keys[0] == "buffers" && keys[2] == "extensions" && str == meshopt_extension)
                    buffer_meshopt = true;
            } else if (d == 2 && open[1] == '[' && keys[0] == "extensionsRequired") {
                out->required.push_back(str);
            } else if (d == 2 && open[1] == '{' && keys[0] == "asset" && keys[1] == "version") {
                out->version = str;
            }
            continue;
        }
        if (c == '{' || c == '[') {
            if (open.size() >= size_t(max_json_depth))
                return rtk_error(RTK_ERR_PARSE, "%s: line %zu: the JSON is nested more than %d levels deep, "
                                 "rtk's limit (tinygltf's parser could not read it safely)",
                                 path, size_t(std::count(t, t + i, '\n')) + 1, max_json_depth);
            open.push_back(c);
            keys.emplace_back();
            if (open.size() == 3 && open[1] == '[' && keys[0] == "buffers") {
                buffer_open = i;
                buffer_uri = buffer_meshopt = false;
                length_size = 0;
            }
        } else if ((c == '}' || c == ']') && !open.empty()) {
            if (open.size() == 3 && open[1] == '[' && keys[0] == "buffers" && buffer_meshopt && !buffer_uri &&
                length_size > 0 && meshopt_available) {
                out->edits.push_back({buffer_open + 1, 0, "\"uri\":\"data:application/octet-stream;base64,AAAAAA==\","});
                out->edits.push_back({length_at, length_size, "4"});
            }
            if (open.size() == 5 && in_primitive(open, keys)) {
                if (draco && indices_key != std::string::npos)
                    t[indices_key + 1] = '_';
                indices_key = std::string::npos;
                draco = false;
            }
            open.pop_back();
            keys.pop_back();
        }
        i++;
    }
    return RTK_OK;
}

rtk_status refuse_version(const char *path, const std::string &version)
{
    return rtk_error(RTK_ERR_UNSUPPORTED, "%s: the file is glTF %s; rtk reads glTF 2.0", path,
                     version.empty() ? "of unknown version" : version.c_str());
}

bool has_extension(const char *path, const char *ext)
{
    size_t n = std::strlen(path), e = std::strlen(ext);
    return n >= e && strcasecmp(path + n - e, ext) == 0;
}

uint32_t read_u32le(const unsigned char *p) { return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24; }

/* tinygltf's file access for buffers and images: only regular files
 * under the folders the scene may read (files.c), no `~` or variable
 * expansion, no fallback to the working directory. */
struct SceneFiles {
    const rtk_scene *scene;
    std::string prefix; /* the glTF's folder with a slash: tinygltf's first place to look */

    static bool exists(const std::string &path, void *user)
    {
        const SceneFiles *self = static_cast<const SceneFiles *>(user);
        if (path.compare(0, self->prefix.size(), self->prefix) != 0)
            return false;
        /* A file outside is "found" without looking, and then refused by
         * read, so that nothing tells whether it exists. */
        if (rtk_scene_file_allowed(self->scene, path.c_str(), "file") != RTK_OK)
            return true;
        struct stat st;
        return stat(path.c_str(), &st) == 0;
    }
    static std::string expand(const std::string &path, void *) { return path; }
    static bool read(std::vector<unsigned char> *out, std::string *err, const std::string &path, void *user)
    {
        const SceneFiles *self = static_cast<const SceneFiles *>(user);
        unsigned char *bytes = NULL;
        size_t count = 0;
        if (rtk_scene_file_read(self->scene, path.c_str(), "file", RTK_MAX_BUFFER_FILE, &bytes, &count) != RTK_OK) {
            if (err)
                *err = rtk_error_message();
            return false;
        }
        out->assign(bytes, bytes + count);
        std::free(bytes);
        return true;
    }
    static bool write(std::string *err, const std::string &, const std::vector<unsigned char> &, void *)
    {
        if (err)
            *err = "rtk writes no glTF files";
        return false;
    }
    tinygltf::FsCallbacks callbacks()
    {
        tinygltf::FsCallbacks fs;
        fs.FileExists = exists;
        fs.ExpandFilePath = expand;
        fs.ReadWholeFile = read;
        fs.WriteWholeFile = write;
        fs.user_data = this;
        return fs;
    }
};

/* The whole file; only a regular file (rtk_file_open) of less than 4 GiB
 * (tinygltf takes 32-bit lengths). */
rtk_status read_whole(const char *path, std::vector<unsigned char> *out)
{
    int fd;
    uint64_t size;
    rtk_status status = rtk_file_open(path, "glTF file", &fd, &size);
    if (status != RTK_OK)
        return status;
    if (size >= (uint64_t(1) << 32))
        status = rtk_error(RTK_ERR_UNSUPPORTED, "%s: %llu bytes; rtk reads glTF files of less than 4 GiB", path,
                           (unsigned long long)size);
    if (status == RTK_OK) {
        out->resize(size_t(size));
        size_t done = 0;
        while (done < out->size()) {
            const ssize_t got = ::read(fd, out->data() + done, out->size() - done);
            if (got < 0 && errno == EINTR)
                continue;
            if (got <= 0) {
                status = rtk_error(RTK_ERR_IO, "%s: read failed after %zu of %zu bytes", path, done, out->size());
                break;
            }
            done += size_t(got);
        }
    }
    close(fd);
    return status;
}

/* Checks the file before tinygltf parses it: glTF 1.0 binaries, JSON
 * nesting, the version and required extensions (refused with rtk's own
 * message rather than tinygltf's failure on the data they change); and
 * readies Draco primitives for tinygltf (prescan_json). */
rtk_status prescan(const char *path, std::vector<unsigned char> &bytes, bool *binary)
{
    unsigned char *b = bytes.data();
    const size_t n = bytes.size();
    *binary = has_extension(path, ".glb") || (n >= 4 && std::memcmp(b, "glTF", 4) == 0);
    char *json = reinterpret_cast<char *>(b);
    size_t json_size = n;
    if (*binary) {
        if (n >= 8 && std::memcmp(b, "glTF", 4) == 0 && read_u32le(b + 4) == 1)
            return refuse_version(path, "1.0 (binary version 1)");
        /* A version 2 header (magic, version, length), then the JSON chunk
         * (length, "JSON", text), then an optional BIN chunk. */
        if (n >= 4 && n < 20 && std::memcmp(b, "glTF", 4) == 0)
            return rtk_error(RTK_ERR_PARSE,
                             "%s: the file is truncated: it ends inside its 20-byte header (%zu bytes); copy or "
                             "export it again",
                             path, n);
        if (n < 20 || std::memcmp(b, "glTF", 4) != 0 || read_u32le(b + 4) != 2 ||
            read_u32le(b + 16) != 0x4E4F534Au)
            return rtk_error(RTK_ERR_PARSE,
                             "%s: not a binary glTF 2.0 file: it does not start with the GLB header "
                             "(\"glTF\", version 2) and a JSON chunk; export it again as .glb, or as .gltf",
                             path);
        const uint64_t length = read_u32le(b + 8), bin_at = 20 + uint64_t(read_u32le(b + 12));
        if (length > n || bin_at > length)
            return rtk_error(RTK_ERR_PARSE,
                             "%s: the file is truncated: its header declares %llu bytes%s, and the file has %zu; "
                             "copy or export it again",
                             path, (unsigned long long)(length > n ? length : bin_at),
                             length > n ? "" : " up to the end of its JSON chunk", n);
        /* tinygltf 2.7 lets the BIN chunk run up to 8 bytes past the file
         * (it leaves the chunk's own header out of the sum) and reads them. */
        if (length > bin_at && (length - bin_at < 8 || read_u32le(b + bin_at) > length - bin_at - 8))
            return rtk_error(RTK_ERR_PARSE,
                             "%s: the file is truncated or damaged: its BIN chunk runs past the end of the file "
                             "(%llu bytes after the JSON chunk, 8 of them the chunk's header); export it again",
                             path, (unsigned long long)(length - bin_at));
        json += 20;
        json_size = size_t(bin_at - 20);
    }
    Prescan scan;
    rtk_status status = prescan_json(path, json, json_size, &scan);
    if (status != RTK_OK)
        return status;
    if (!scan.edits.empty()) {
        std::string text;
        size_t from = 0;
        for (const Prescan::Edit &e : scan.edits) {
            text.append(json + from, e.at - from);
            text += e.text;
            from = e.at + e.erase;
        }
        text.append(json + from, json_size - from);
        std::vector<unsigned char> edited;
        if (*binary) {
            /* The same container around the longer JSON chunk: header,
             * chunk length and type, the text padded with spaces, the rest. */
            while (text.size() % 4)
                text += ' ';
            const size_t rest = 20 + json_size;
            edited.resize(20 + text.size() + (n - rest));
            std::memcpy(edited.data(), b, 20);
            std::memcpy(edited.data() + 20, text.data(), text.size());
            std::memcpy(edited.data() + 20 + text.size(), b + rest, n - rest);
            /* The declared length moves with the JSON, so that tinygltf
             * judges it against the file as it would have the original. */
            const uint64_t length = read_u32le(b + 8) + uint64_t(text.size()) - json_size;
            if (length > UINT32_MAX)
                return rtk_error(RTK_ERR_PARSE, "%s: the file is larger than a GLB file may be (4 GiB)", path);
            const uint32_t sizes[2] = {uint32_t(length), uint32_t(text.size())};
            for (int k = 0; k < 2; k++)
                for (int byte = 0; byte < 4; byte++)
                    edited[size_t(8 + 4 * k + byte)] = (unsigned char)(sizes[k] >> (8 * byte));
        } else {
            edited.assign(text.begin(), text.end());
        }
        bytes.swap(edited);
    }
    if (!scan.version.empty() && !starts_with(scan.version, "2."))
        return refuse_version(path, scan.version);
    for (const std::string &ext : scan.required)
        if (!supported_extension(ext))
            return refuse_extension(path, ext);
    return RTK_OK;
}

/* Largest decoded size of one EXT_meshopt_compression buffer view: its
 * compressed data may expand by far more than the file's size. */
const size_t max_meshopt_bytes = size_t(1) << 30;

/* EXT_meshopt_compression: each compressed buffer view is decoded
 * (meshoptimizer, and its filter) into a buffer of its own, which the
 * view then names, so that accessors read it like any other. */
rtk_status decode_meshopt(const char *path, tinygltf::Model *model)
{
    for (size_t i = 0; i < model->bufferViews.size(); i++) {
        tinygltf::BufferView &bv = model->bufferViews[i];
        tinygltf::ExtensionMap::const_iterator ext = bv.extensions.find(meshopt_extension);
        if (ext == bv.extensions.end() || !meshopt_available)
            continue;
        const tinygltf::Value &e = ext->second;
        const int buffer = e.Get("buffer").IsNumber() ? e.Get("buffer").GetNumberAsInt() : -1;
        const double offset = number(e.Get("byteOffset"), 0.0), length = number(e.Get("byteLength"), -1.0);
        const double stride = number(e.Get("byteStride"), 0.0), count = number(e.Get("count"), -1.0);
        const std::string mode = e.Get("mode").IsString() ? e.Get("mode").Get<std::string>() : "";
        const std::string filter = e.Get("filter").IsString() ? e.Get("filter").Get<std::string>() : "NONE";
        const size_t have = buffer >= 0 && size_t(buffer) < model->buffers.size()
                                ? model->buffers[size_t(buffer)].data.size()
                                : 0;
        const char *bad = NULL;
        if (buffer < 0 || size_t(buffer) >= model->buffers.size())
            bad = "its buffer does not exist";
        else if (!(offset >= 0.0 && length > 0.0 && offset + length <= double(have)))
            bad = "its byteOffset and byteLength do not fit in its buffer";
        else if (!(count >= 0.0 && stride >= 1.0 && stride <= 256.0 && stride * count <= double(max_meshopt_bytes)))
            bad = "its count and byteStride are missing or decode to more than 1 GiB";
        else if (mode == "ATTRIBUTES" ? int(stride) % 4 != 0
                 : mode == "TRIANGLES" || mode == "INDICES" ? (stride != 2.0 && stride != 4.0) ||
                                                                  (mode == "TRIANGLES" && int64_t(count) % 3 != 0)
                                                            : true)
            bad = "its mode and byteStride do not go together (ATTRIBUTES: a multiple of 4; TRIANGLES, INDICES: 2 "
                  "or 4)";
        else if (filter != "NONE" && (mode != "ATTRIBUTES" ||
                                      (filter == "OCTAHEDRAL" ? stride != 4.0 && stride != 8.0
                                       : filter == "QUATERNION" ? stride != 8.0
                                       : filter != "EXPONENTIAL")))
            bad = "its filter is unknown or does not fit its mode and byteStride";
        if (bad)
            return rtk_error(RTK_ERR_PARSE, "%s: buffer view %zu: %s: %s", path, i, meshopt_extension, bad);
        const size_t n = size_t(count), size = size_t(stride);
        std::vector<unsigned char> out(n * size);
        int rc = -1;
#ifdef RTK_HAVE_MESHOPT
        const unsigned char *src = model->buffers[size_t(buffer)].data.data() + size_t(offset);
        if (mode == "ATTRIBUTES")
            rc = meshopt_decodeVertexBuffer(out.data(), n, size, src, size_t(length));
        else if (mode == "TRIANGLES")
            rc = meshopt_decodeIndexBuffer(out.data(), n, size, src, size_t(length));
        else
            rc = meshopt_decodeIndexSequence(out.data(), n, size, src, size_t(length));
        if (rc == 0 && filter == "OCTAHEDRAL")
            meshopt_decodeFilterOct(out.data(), n, size);
        else if (rc == 0 && filter == "QUATERNION")
            meshopt_decodeFilterQuat(out.data(), n, size);
        else if (rc == 0 && filter == "EXPONENTIAL")
            meshopt_decodeFilterExp(out.data(), n, size);
#endif
        if (rc != 0)
            return rtk_error(RTK_ERR_PARSE, "%s: buffer view %zu: %s: the data does not decode (meshoptimizer says %d)",
                             path, i, meshopt_extension, rc);
        tinygltf::Buffer decoded;
        decoded.data.swap(out);
        model->buffers.push_back(std::move(decoded));
        bv.buffer = int(model->buffers.size() - 1);
        bv.byteOffset = 0;
        bv.byteLength = model->buffers.back().data.size();
    }
    return RTK_OK;
}

rtk_status load(const char *path, rtk_scene *scene)
{
    tinygltf::TinyGLTF gltf;
    gltf.SetImageLoader(keep_image, NULL);
    tinygltf::Model model;
    std::string err, warn;
    std::vector<unsigned char> bytes;
    bool binary;
    rtk_status status = read_whole(path, &bytes);
    if (status != RTK_OK || (status = prescan(path, bytes, &binary)) != RTK_OK)
        return status;
    const std::string base = take(rtk_path_dirname(path));
    SceneFiles files{scene, base.back() == '/' ? base : base + "/"};
    gltf.SetFsCallbacks(files.callbacks());
    bool ok = binary ? gltf.LoadBinaryFromMemory(&model, &err, &warn, bytes.data(), unsigned(bytes.size()), base)
                     : gltf.LoadASCIIFromString(&model, &err, &warn, reinterpret_cast<const char *>(bytes.data()),
                                                unsigned(bytes.size()), base);
    log_warnings(path, warn);
    if (!ok)
        return rtk_error(RTK_ERR_PARSE, "%s: %s", path, one_line(err).c_str());
    if ((status = decode_meshopt(path, &model)) != RTK_OK)
        return status;
    Loader loader(path, scene, model);
    return loader.run();
}

} // namespace

extern "C" rtk_status rtk_load_gltf(const char *path, rtk_scene *scene)
{
    try {
        return load(path, scene);
    } catch (const std::bad_alloc &) {
        return rtk_error(RTK_ERR_NOMEM, "%s: out of memory while reading the glTF file", path);
    } catch (const std::exception &e) {
        return rtk_error(RTK_ERR_PARSE, "%s: %s", path, e.what());
    } catch (...) {
        return rtk_error(RTK_ERR_PARSE, "%s: unexpected failure while reading the glTF file", path);
    }
}

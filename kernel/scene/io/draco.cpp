/* KHR_draco_mesh_compression through libdraco, when the build found it
 * (RTK_HAVE_DRACO); otherwise available() is false and glTF files that
 * require the extension are refused with a message saying so. */
#include "draco.h"

#ifdef RTK_HAVE_DRACO
#include <draco/compression/decode.h>
#endif

namespace rtk_draco {

#ifdef RTK_HAVE_DRACO

bool available() { return true; }

bool decode(const unsigned char *bytes, size_t size, const std::vector<int> &ids, Mesh *out, std::string *why)
{
    draco::DecoderBuffer buffer;
    buffer.Init(reinterpret_cast<const char *>(bytes), size);
    draco::Decoder decoder;
    draco::StatusOr<std::unique_ptr<draco::Mesh>> result = decoder.DecodeMeshFromBuffer(&buffer);
    if (!result.ok()) {
        *why = "Draco could not decode it: " + result.status().error_msg_string();
        return false;
    }
    const std::unique_ptr<draco::Mesh> mesh = std::move(result).value();
    if (!mesh) {
        *why = "Draco decoded no mesh";
        return false;
    }
    out->points = mesh->num_points();
    out->indices.resize(size_t(mesh->num_faces()) * 3);
    for (draco::FaceIndex f(0); f < mesh->num_faces(); ++f)
        for (int k = 0; k < 3; k++)
            out->indices[size_t(f.value()) * 3 + size_t(k)] = mesh->face(f)[k].value();
    for (int id : ids) {
        const draco::PointAttribute *att = mesh->GetAttributeByUniqueId(uint32_t(id));
        if (!att || att->num_components() < 1 || att->num_components() > 16) {
            *why = "the Draco data has no usable attribute " + std::to_string(id);
            return false;
        }
        const int n = att->num_components();
        std::vector<double> &values = out->attributes[id];
        values.resize(out->points * size_t(n));
        float v[16];
        for (draco::PointIndex p(0); p < mesh->num_points(); ++p) {
            if (!att->ConvertValue<float>(att->mapped_index(p), int8_t(n), v)) {
                *why = "Draco attribute " + std::to_string(id) + " cannot be read as numbers";
                return false;
            }
            for (int k = 0; k < n; k++)
                values[size_t(p.value()) * size_t(n) + size_t(k)] = v[k];
        }
        out->components[id] = n;
    }
    return true;
}

#else

bool available() { return false; }

bool decode(const unsigned char *, size_t, const std::vector<int> &, Mesh *, std::string *why)
{
    *why = "this rtk was built without Draco";
    return false;
}

#endif

} // namespace rtk_draco

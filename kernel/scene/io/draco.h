/* KHR_draco_mesh_compression's decoder (io/draco.cpp, C++ only): a thin
 * adapter over libdraco, or a stand-in that says rtk was built without it. */
#ifndef RTK_IO_DRACO_H
#define RTK_IO_DRACO_H

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace rtk_draco {

/* A decoded Draco mesh: corner point indices, 3 per face, and the
 * attributes asked for by their Draco unique ids, components per point
 * in a row (normalized integers already mapped to floats). */
struct Mesh {
    size_t points = 0;
    std::vector<uint32_t> indices;
    std::map<int, std::vector<double>> attributes;
    std::map<int, int> components;
};

/* Whether this build decodes Draco. */
bool available();

/* Decodes size bytes into out with the attributes of ids; false with
 * why set (a sentence) when the data is not a Draco mesh or an id has no
 * attribute. */
bool decode(const unsigned char *bytes, size_t size, const std::vector<int> &ids, Mesh *out, std::string *why);

} // namespace rtk_draco

#endif

#pragma once
// Reading glTF accessors: every range (accessor in buffer view, buffer view in buffer,
// sparse indices and values) is checked before a byte is read or a vector allocated.
// `element` is where the accessor is used ("/meshes/0/primitives/1/attributes/NORMAL"),
// for messages about its type; problems of the accessor itself name "/accessors/N".
#include "scene/gltf/Document.h"

#include <cstdint>
#include <string_view>
#include <vector>

namespace penumbra::scene::gltf {

enum class AttributeKind {
    Position,  // VEC3 FLOAT
    Normal,    // VEC3 FLOAT
    TexCoord,  // VEC2 FLOAT, or normalized UNSIGNED_BYTE / UNSIGNED_SHORT
    KeyTimes,  // animation sampler input: SCALAR FLOAT
    KeyVec3,   // animation output of translation or scale: VEC3 FLOAT
    KeyRotation,  // animation output of rotation: VEC4 FLOAT, or normalized BYTE / UNSIGNED_BYTE / SHORT / UNSIGNED_SHORT
};

// How many elements a read may allocate, and what that bound is, for the message.
struct CountLimit {
    size_t max = 0;
    std::string what;  // "vertices left of the limit of 16777216 per file"
};

// Bytes of one component of a glTF componentType (5120 BYTE ... 5126 FLOAT); 0 for any
// other value.
size_t componentBytes(int componentType);

// The accessor's element count (checks only that the accessor exists).
size_t accessorCount(const Document& doc, int accessor, std::string_view element);

// count × components floats (1 to 4), sparse substitutions applied. Throws if the
// count exceeds `limit` before allocating.
std::vector<float> readAttribute(const Document& doc, int accessor, std::string_view element, AttributeKind kind,
                                 const CountLimit& limit);

// SCALAR UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT indices; not range-checked
// against any vertex count (the caller knows it).
std::vector<uint32_t> readIndices(const Document& doc, int accessor, std::string_view element, const CountLimit& limit);

} // namespace penumbra::scene::gltf

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
};

// The accessor's element count (checks only that the accessor exists).
size_t accessorCount(const Document& doc, int accessor, std::string_view element);

// count × components floats (3 or 2), sparse substitutions applied. Throws if the
// count exceeds `maxCount` (the caller's budget) before allocating.
std::vector<float> readAttribute(const Document& doc, int accessor, std::string_view element, AttributeKind kind,
                                 size_t maxCount);

// SCALAR UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT indices; not range-checked
// against any vertex count (the caller knows it).
std::vector<uint32_t> readIndices(const Document& doc, int accessor, std::string_view element, size_t maxCount);

} // namespace penumbra::scene::gltf

#include "scene/gltf/Accessors.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstring>

namespace penumbra::scene::gltf {

size_t componentBytes(int componentType)
{
    switch (componentType) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
    default: return 0;
    }
}

namespace {

std::string componentName(int componentType)
{
    switch (componentType) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: return "BYTE";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return "UNSIGNED_BYTE";
    case TINYGLTF_COMPONENT_TYPE_SHORT: return "SHORT";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return "UNSIGNED_SHORT";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: return "UNSIGNED_INT";
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return "FLOAT";
    default: return fmt::format("componentType {}", componentType);
    }
}

size_t componentsOf(int type)
{
    switch (type) {
    case TINYGLTF_TYPE_SCALAR: return 1;
    case TINYGLTF_TYPE_VEC2: return 2;
    case TINYGLTF_TYPE_VEC3: return 3;
    case TINYGLTF_TYPE_VEC4:
    case TINYGLTF_TYPE_MAT2: return 4;
    case TINYGLTF_TYPE_MAT3: return 9;
    case TINYGLTF_TYPE_MAT4: return 16;
    default: return 0;
    }
}

std::string typeName(int type)
{
    switch (type) {
    case TINYGLTF_TYPE_SCALAR: return "SCALAR";
    case TINYGLTF_TYPE_VEC2: return "VEC2";
    case TINYGLTF_TYPE_VEC3: return "VEC3";
    case TINYGLTF_TYPE_VEC4: return "VEC4";
    case TINYGLTF_TYPE_MAT2: return "MAT2";
    case TINYGLTF_TYPE_MAT3: return "MAT3";
    case TINYGLTF_TYPE_MAT4: return "MAT4";
    default: return fmt::format("type {}", type);
    }
}

std::string accessorPath(int index) { return fmt::format("/accessors/{}", index); }

const tinygltf::Accessor& accessorAt(const Document& doc, int index, std::string_view element)
{
    if (index < 0 || size_t(index) >= doc.model.accessors.size()) {
        doc.fail(element, fmt::format("accessor {} does not exist ({} accessors)", index, doc.model.accessors.size()));
    }
    return doc.model.accessors[size_t(index)];
}

// Checks that buffer view `view` exists and lies inside its buffer.
const tinygltf::BufferView& viewAt(const Document& doc, int view, std::string_view who)
{
    const tinygltf::Model& model = doc.model;
    if (view < 0 || size_t(view) >= model.bufferViews.size()) {
        doc.fail(who, fmt::format("buffer view {} does not exist ({} buffer views)", view, model.bufferViews.size()));
    }
    const tinygltf::BufferView& bv = model.bufferViews[size_t(view)];
    const std::string viewPath = fmt::format("/bufferViews/{}", view);
    if (bv.buffer < 0 || size_t(bv.buffer) >= model.buffers.size()) {
        doc.fail(viewPath, fmt::format("buffer {} does not exist ({} buffers)", bv.buffer, model.buffers.size()));
    }
    const size_t bufferBytes = model.buffers[size_t(bv.buffer)].data.size();
    if (bv.byteOffset > bufferBytes || bv.byteLength > bufferBytes - bv.byteOffset) {
        doc.fail(viewPath, fmt::format("byteOffset {} + byteLength {} exceeds buffer {} ({} bytes)", bv.byteOffset,
                                       bv.byteLength, bv.buffer, bufferBytes));
    }
    return bv;
}

// The first of `count` elements of `elementBytes`, `stride` apart, starting `offset`
// bytes into buffer view `view`; fails unless all of them lie inside the view.
const unsigned char* viewBytes(const Document& doc, int view, size_t offset, size_t count, size_t elementBytes,
                               size_t stride, std::string_view who)
{
    const tinygltf::BufferView& bv = viewAt(doc, view, who);
    const size_t available = bv.byteLength;
    // A count above the view's byte length cannot fit, and is refused before the
    // product below could overflow.
    bool fits = offset <= available && count <= available;
    if (fits && count > 0) fits = (count - 1) * stride + elementBytes <= available - offset;
    if (!fits) {
        if (offset == 0 && stride == elementBytes) {
            doc.fail(who, fmt::format("count {} × {} bytes exceeds buffer view {} ({} bytes)", count, elementBytes, view,
                                      available));
        }
        doc.fail(who, fmt::format("byteOffset {} + count {} × stride {} bytes exceeds buffer view {} ({} bytes)", offset,
                                  count, stride, view, available));
    }
    return doc.model.buffers[size_t(bv.buffer)].data.data() + bv.byteOffset + offset;
}

// memcpy: glTF requires aligned data, but a broken file must not become an unaligned load.
template <class T>
T load(const unsigned char* p)
{
    T value;
    std::memcpy(&value, p, sizeof(T));
    return value;
}

double rawComponent(const unsigned char* p, int componentType)
{
    switch (componentType) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: return load<int8_t>(p);
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return load<uint8_t>(p);
    case TINYGLTF_COMPONENT_TYPE_SHORT: return load<int16_t>(p);
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return load<uint16_t>(p);
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: return load<uint32_t>(p);
    default: return load<float>(p);
    }
}

// glTF's normalized integers: unsigned c / max, signed max(c / max, -1).
float normalizedComponent(const unsigned char* p, int componentType)
{
    const double c = rawComponent(p, componentType);
    switch (componentType) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: return float(std::max(c / 127.0, -1.0));
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return float(c / 255.0);
    case TINYGLTF_COMPONENT_TYPE_SHORT: return float(std::max(c / 32767.0, -1.0));
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return float(c / 65535.0);
    default: return float(c);
    }
}

// Reads `components` values per element through `convert(bytes, componentType)`; an
// accessor without a buffer view starts as zeros (glTF), then sparse values replace
// the elements they name.
template <class T, class Convert>
std::vector<T> readElements(const Document& doc, int index, std::string_view element, const CountLimit& limit,
                            Convert convert)
{
    const tinygltf::Accessor& acc = accessorAt(doc, index, element);
    const std::string path = accessorPath(index);
    const size_t componentSize = componentBytes(acc.componentType);
    const size_t components = componentsOf(acc.type);
    const size_t elementBytes = componentSize * components;

    const unsigned char* data = nullptr;
    size_t stride = elementBytes;
    if (acc.bufferView >= 0) {
        const tinygltf::BufferView& bv = viewAt(doc, acc.bufferView, path);
        if (bv.byteStride != 0) stride = bv.byteStride;
        if (stride < elementBytes) {
            doc.fail(fmt::format("/bufferViews/{}", acc.bufferView),
                     fmt::format("byteStride {} is smaller than accessor {}'s {}-byte elements", stride, index, elementBytes));
        }
        data = viewBytes(doc, acc.bufferView, acc.byteOffset, acc.count, elementBytes, stride, path);
    }
    if (acc.count > limit.max) doc.fail(path, fmt::format("count {} exceeds {} ({})", acc.count, limit.max, limit.what));

    std::vector<T> out(acc.count * components, T{});
    if (data) {
        for (size_t i = 0; i < acc.count; ++i) {
            for (size_t c = 0; c < components; ++c) {
                out[i * components + c] = convert(data + i * stride + c * componentSize, acc.componentType);
            }
        }
    }
    if (!acc.sparse.isSparse) return out;

    const std::string sparsePath = path + "/sparse";
    const auto& sparse = acc.sparse;
    if (sparse.count < 1 || size_t(sparse.count) > acc.count) {
        doc.fail(sparsePath, fmt::format("count {} must be in [1, {}] (the accessor's count)", sparse.count, acc.count));
    }
    const int indexType = sparse.indices.componentType;
    const size_t indexBytes = indexType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE    ? 1
                              : indexType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT ? 2
                              : indexType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT   ? 4
                                                                                     : 0;
    if (indexBytes == 0) {
        doc.fail(sparsePath + "/indices", fmt::format("{} is not UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT",
                                                      componentName(indexType)));
    }
    if (sparse.indices.byteOffset < 0 || sparse.values.byteOffset < 0) {
        doc.fail(sparsePath, "byteOffset must not be negative");
    }
    const size_t count = size_t(sparse.count);
    const unsigned char* indices = viewBytes(doc, sparse.indices.bufferView, size_t(sparse.indices.byteOffset), count,
                                             indexBytes, indexBytes, sparsePath + "/indices");
    const unsigned char* values = viewBytes(doc, sparse.values.bufferView, size_t(sparse.values.byteOffset), count,
                                            elementBytes, elementBytes, sparsePath + "/values");
    for (size_t k = 0; k < count; ++k) {
        const auto target = size_t(rawComponent(indices + k * indexBytes, indexType));
        if (target >= acc.count) {
            doc.fail(sparsePath + "/indices",
                     fmt::format("index {} at position {} is out of range of {} elements", target, k, acc.count));
        }
        for (size_t c = 0; c < components; ++c) {
            out[target * components + c] = convert(values + k * elementBytes + c * componentSize, acc.componentType);
        }
    }
    return out;
}

const char* kindName(AttributeKind kind)
{
    switch (kind) {
    case AttributeKind::Position: return "POSITION";
    case AttributeKind::Normal: return "NORMAL";
    case AttributeKind::KeyTimes: return "an animation sampler's input";
    case AttributeKind::KeyVec3: return "a translation or scale output";
    case AttributeKind::KeyRotation: return "a rotation output";
    default: return "TEXCOORD_0";
    }
}

// Fails unless `acc`'s type and componentType are what glTF allows for `kind`.
void checkAttributeType(const Document& doc, const tinygltf::Accessor& acc, int index, std::string_view element,
                        AttributeKind kind)
{
    const int ct = acc.componentType;
    const bool isFloat = ct == TINYGLTF_COMPONENT_TYPE_FLOAT;
    bool ok = false;
    const char* allowed = "VEC3 of FLOAT";
    switch (kind) {
    case AttributeKind::TexCoord:
        ok = acc.type == TINYGLTF_TYPE_VEC2 &&
             (isFloat || (acc.normalized && (ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                                             ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT)));
        allowed = "VEC2 of FLOAT or normalized UNSIGNED_BYTE / UNSIGNED_SHORT";
        break;
    case AttributeKind::KeyTimes:
        ok = acc.type == TINYGLTF_TYPE_SCALAR && isFloat;
        allowed = "SCALAR of FLOAT";
        break;
    case AttributeKind::KeyRotation:
        ok = acc.type == TINYGLTF_TYPE_VEC4 && (isFloat || (acc.normalized && ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT));
        allowed = "VEC4 of FLOAT or normalized BYTE / UNSIGNED_BYTE / SHORT / UNSIGNED_SHORT";
        break;
    default: ok = acc.type == TINYGLTF_TYPE_VEC3 && isFloat; break;
    }
    if (ok) return;
    doc.fail(element, fmt::format("accessor {} is {} of {}{}; {} must be {}", index, typeName(acc.type), componentName(ct),
                                  acc.normalized ? " (normalized)" : "", kindName(kind), allowed));
}

} // namespace

size_t accessorCount(const Document& doc, int accessor, std::string_view element)
{
    return accessorAt(doc, accessor, element).count;
}

std::vector<float> readAttribute(const Document& doc, int accessor, std::string_view element, AttributeKind kind,
                                 const CountLimit& limit)
{
    const tinygltf::Accessor& acc = accessorAt(doc, accessor, element);
    checkAttributeType(doc, acc, accessor, element, kind);
    if (acc.normalized) return readElements<float>(doc, accessor, element, limit, normalizedComponent);
    return readElements<float>(doc, accessor, element, limit,
                               [](const unsigned char* p, int ct) { return float(rawComponent(p, ct)); });
}

std::vector<uint32_t> readIndices(const Document& doc, int accessor, std::string_view element, const CountLimit& limit)
{
    const tinygltf::Accessor& acc = accessorAt(doc, accessor, element);
    const int ct = acc.componentType;
    if (acc.type != TINYGLTF_TYPE_SCALAR ||
        (ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE && ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
         ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)) {
        doc.fail(element, fmt::format("accessor {} is {} of {}; indices must be SCALAR of UNSIGNED_BYTE, UNSIGNED_SHORT or "
                                      "UNSIGNED_INT",
                                      accessor, typeName(acc.type), componentName(ct)));
    }
    return readElements<uint32_t>(doc, accessor, element, limit,
                                  [](const unsigned char* p, int type) { return uint32_t(rawComponent(p, type)); });
}

} // namespace penumbra::scene::gltf

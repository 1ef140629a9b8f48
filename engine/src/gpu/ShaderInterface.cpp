#include "penumbra/gpu/ShaderInterface.h"

#include "penumbra/core/Error.h"

#include <fmt/format.h>

#include <algorithm>
#include <optional>
#include <unordered_map>

namespace penumbra::gpu {
namespace {

// The few SPIR-V opcodes, decorations and enumerants the interface needs (SPIR-V
// specification, section 3). Parsed by hand: glslang's own reflection reports only the
// variables the entry point uses, and a pipeline must also accept descriptors for the
// ones a shader variant declares but leaves unused.
constexpr uint32_t kMagic = 0x07230203;
constexpr uint32_t kHeaderWords = 5;
enum Op : uint32_t {
    OpName = 5,
    OpExecutionMode = 16,
    OpTypeImage = 25,
    OpTypeSampler = 26,
    OpTypeSampledImage = 27,
    OpTypeArray = 28,
    OpTypeRuntimeArray = 29,
    OpTypeStruct = 30,
    OpTypePointer = 32,
    OpConstant = 43,
    OpSpecConstant = 50,
    OpVariable = 59,
    OpDecorate = 71,
    OpExecutionModeId = 331,
    OpTypeAccelerationStructureKHR = 5341,
};
enum Decoration : uint32_t { BufferBlock = 3, Binding = 33, DescriptorSet = 34 };
enum StorageClass : uint32_t { UniformConstant = 0, Uniform = 2, StorageBuffer = 12 };
constexpr uint32_t kExecutionModeLocalSize = 17, kExecutionModeLocalSizeId = 38;
constexpr uint32_t kDimBuffer = 5, kDimSubpassData = 6;

struct Instruction {
    uint32_t opcode;
    std::span<const uint32_t> operands;  // the words after the first
};

std::string literalString(std::span<const uint32_t> words)
{
    std::string s;
    for (uint32_t word : words) {
        for (int byte = 0; byte < 4; ++byte) {
            const char c = char((word >> (8 * byte)) & 0xffu);
            if (c == '\0') return s;
            s += c;
        }
    }
    return s;
}

// What the module says about its ids, collected in one pass over it.
struct Module {
    std::unordered_map<uint32_t, std::string> names;
    std::unordered_map<uint32_t, Instruction> types;      // OpType* by result id
    std::unordered_map<uint32_t, uint32_t> constants;  // scalar (spec) constants: their (default) value
    std::unordered_map<uint32_t, uint32_t> bindings, sets;
    std::vector<uint32_t> bufferBlocks;  // structs decorated BufferBlock (storage buffers before SPIR-V 1.3)
    std::vector<Instruction> variables;
    std::optional<Instruction> localSize;  // OpExecutionMode(Id) LocalSize(Id)
};

Module parse(std::span<const uint32_t> spirv, std::string_view shader)
{
    if (spirv.size() < kHeaderWords || spirv[0] != kMagic) {
        throw ShaderCompileError(fmt::format("{}: not a SPIR-V module", shader));
    }
    Module m;
    for (size_t at = kHeaderWords; at < spirv.size();) {
        const uint32_t count = spirv[at] >> 16, opcode = spirv[at] & 0xffffu;
        if (count == 0 || at + count > spirv.size()) {
            throw ShaderCompileError(fmt::format("{}: malformed SPIR-V at word {}", shader, at));
        }
        const Instruction inst{opcode, spirv.subspan(at + 1, count - 1)};
        const std::span<const uint32_t> o = inst.operands;
        at += count;
        switch (opcode) {
        case OpName:
            if (!o.empty()) m.names[o[0]] = literalString(o.subspan(1));
            break;
        case OpDecorate:
            if (o.size() < 2) break;
            if (o[1] == Binding && o.size() > 2) m.bindings[o[0]] = o[2];
            if (o[1] == DescriptorSet && o.size() > 2) m.sets[o[0]] = o[2];
            if (o[1] == BufferBlock) m.bufferBlocks.push_back(o[0]);
            break;
        case OpTypeImage:
        case OpTypeSampler:
        case OpTypeSampledImage:
        case OpTypeArray:
        case OpTypeRuntimeArray:
        case OpTypeStruct:
        case OpTypePointer:
        case OpTypeAccelerationStructureKHR:
            if (!o.empty()) m.types[o[0]] = inst;
            break;
        case OpConstant:
        case OpSpecConstant:
            if (o.size() > 2) m.constants[o[1]] = o[2];
            break;
        case OpVariable:
            if (o.size() > 2) m.variables.push_back(inst);
            break;
        case OpExecutionMode:
        case OpExecutionModeId:
            if (o.size() == 5 && (o[1] == kExecutionModeLocalSize || o[1] == kExecutionModeLocalSizeId)) m.localSize = inst;
            break;
        default: break;
        }
    }
    return m;
}

uint32_t constantValue(const Module& m, uint32_t id, std::string_view shader)
{
    const auto it = m.constants.find(id);
    if (it == m.constants.end()) throw ShaderCompileError(fmt::format("{}: SPIR-V id {} is not a constant", shader, id));
    return it->second;
}

// SPIR-V 1.6 (what ShaderCompiler targets) gives it as LocalSizeId, with constants; the
// WorkgroupSize built-in that older modules may carry instead is not emitted there.
std::array<uint32_t, 3> workgroupSize(const Module& m, std::string_view shader)
{
    if (!m.localSize) return {1, 1, 1};
    const std::span<const uint32_t> o = m.localSize->operands;
    if (m.localSize->opcode == OpExecutionMode) return {o[2], o[3], o[4]};
    return {constantValue(m, o[2], shader), constantValue(m, o[3], shader), constantValue(m, o[4], shader)};
}

// The descriptor type and array length of a variable of `storage` class pointing to `type`;
// nullopt for a variable that is no descriptor.
struct Descriptor {
    VkDescriptorType type;
    uint32_t count = 1;
    uint32_t blockType = 0;  // the struct of a buffer (its name is the block's)
};

std::optional<Descriptor> descriptorOf(const Module& m, uint32_t storage, uint32_t typeId, const std::string& name,
                                       std::string_view shader)
{
    if (storage != UniformConstant && storage != Uniform && storage != StorageBuffer) return std::nullopt;
    uint32_t count = 1;
    const Instruction* type = nullptr;
    for (;;) {
        const auto it = m.types.find(typeId);
        if (it == m.types.end()) {
            throw ShaderCompileError(fmt::format("{}: '{}': a descriptor of a type Penumbra cannot bind", shader, name));
        }
        type = &it->second;
        if (type->opcode == OpTypeRuntimeArray) {
            throw ShaderCompileError(fmt::format("{}: '{}': an array of descriptors needs a length (the pipelines "
                                                 "use no descriptor indexing)",
                                                 shader, name));
        }
        if (type->opcode != OpTypeArray) break;
        count *= constantValue(m, type->operands[2], shader);
        typeId = type->operands[1];
    }
    const std::span<const uint32_t> o = type->operands;
    if (storage == StorageBuffer) return Descriptor{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, count, o[0]};
    if (storage == Uniform) {
        const bool storageBlock = std::find(m.bufferBlocks.begin(), m.bufferBlocks.end(), o[0]) != m.bufferBlocks.end();
        return Descriptor{storageBlock ? VK_DESCRIPTOR_TYPE_STORAGE_BUFFER : VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, count,
                          o[0]};
    }
    switch (type->opcode) {
    case OpTypeSampler: return Descriptor{VK_DESCRIPTOR_TYPE_SAMPLER, count};
    case OpTypeAccelerationStructureKHR: return Descriptor{VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR, count};
    case OpTypeSampledImage: {
        const auto image = m.types.find(o[1]);
        const bool texelBuffer = image != m.types.end() && image->second.operands[2] == kDimBuffer;
        return Descriptor{texelBuffer ? VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER : VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER,
                          count};
    }
    case OpTypeImage: {
        // Operands: result, sampled type, Dim, Depth, Arrayed, MS, Sampled (1 with a
        // sampler, 2 storage), format.
        const uint32_t dim = o[2], sampled = o[6];
        if (dim == kDimSubpassData) return Descriptor{VK_DESCRIPTOR_TYPE_INPUT_ATTACHMENT, count};
        if (sampled == 2) {
            return Descriptor{dim == kDimBuffer ? VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER : VK_DESCRIPTOR_TYPE_STORAGE_IMAGE,
                              count};
        }
        return Descriptor{dim == kDimBuffer ? VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER : VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE,
                          count};
    }
    default:
        throw ShaderCompileError(fmt::format("{}: '{}': a descriptor of a type Penumbra cannot bind", shader, name));
    }
}

std::string lookup(const std::unordered_map<uint32_t, std::string>& names, uint32_t id)
{
    const auto it = names.find(id);
    return it == names.end() ? std::string() : it->second;
}

// Adds `b` to `bindings` (ascending by number), or joins it with a declaration of the
// same binding: another name for it (aliased declarations, or another stage's) is fine
// as long as type and count agree.
void addBinding(std::vector<ShaderBinding>& bindings, ShaderBinding b, std::string_view where)
{
    auto it = std::lower_bound(bindings.begin(), bindings.end(), b.binding,
                               [](const ShaderBinding& x, uint32_t n) { return x.binding < n; });
    if (it == bindings.end() || it->binding != b.binding) {
        bindings.insert(it, std::move(b));
        return;
    }
    if (it->type != b.type || it->count != b.count) {
        throw ShaderCompileError(fmt::format("{}: binding {} is declared as '{}' ({} x {}) and as '{}' ({} x {}); one "
                                             "binding has one type",
                                             where, b.binding, it->name, it->count, descriptorTypeName(it->type), b.name,
                                             b.count, descriptorTypeName(b.type)));
    }
    it->stages |= b.stages;
}

} // namespace

const char* descriptorTypeName(VkDescriptorType type)
{
    switch (type) {
    case VK_DESCRIPTOR_TYPE_SAMPLER: return "sampler";
    case VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER: return "combined image sampler";
    case VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE: return "sampled image";
    case VK_DESCRIPTOR_TYPE_STORAGE_IMAGE: return "storage image";
    case VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER: return "uniform texel buffer";
    case VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER: return "storage texel buffer";
    case VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER: return "uniform buffer";
    case VK_DESCRIPTOR_TYPE_STORAGE_BUFFER: return "storage buffer";
    case VK_DESCRIPTOR_TYPE_INPUT_ATTACHMENT: return "input attachment";
    case VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR: return "acceleration structure";
    default: return "descriptor";
    }
}

const ShaderBinding* ShaderInterface::find(std::string_view name) const
{
    for (const ShaderBinding& b : bindings)
        if (b.isNamed(name)) return &b;
    return nullptr;
}

void ShaderInterface::merge(const ShaderInterface& other, std::string_view pipeline)
{
    for (const ShaderBinding& b : other.bindings) addBinding(bindings, b, pipeline);
}

ShaderInterface reflectShaderInterface(std::span<const uint32_t> spirv, VkShaderStageFlagBits stage,
                                       std::string_view shader)
{
    const Module m = parse(spirv, shader);
    ShaderInterface result;
    for (const Instruction& variable : m.variables) {
        const uint32_t pointerType = variable.operands[0], id = variable.operands[1], storage = variable.operands[2];
        const auto pointer = m.types.find(pointerType);
        if (pointer == m.types.end() || pointer->second.opcode != OpTypePointer) continue;
        const std::string name = lookup(m.names, id);
        const std::optional<Descriptor> d = descriptorOf(m, storage, pointer->second.operands[2], name, shader);
        if (!d) continue;
        const auto set = m.sets.find(id);
        if (set != m.sets.end() && set->second != 0) {
            throw ShaderCompileError(fmt::format("{}: '{}' is in descriptor set {}; a pipeline has one push-descriptor "
                                                 "set, set 0 (leave `set` out of the layout)",
                                                 shader, name, set->second));
        }
        const auto binding = m.bindings.find(id);
        ShaderBinding b;
        b.blockName = d->blockType ? lookup(m.names, d->blockType) : std::string();
        b.name = name.empty() ? b.blockName : name;
        b.binding = binding == m.bindings.end() ? 0 : binding->second;
        b.type = d->type;
        b.count = d->count;
        b.stages = stage;
        addBinding(result.bindings, std::move(b), shader);
    }
    if (stage == VK_SHADER_STAGE_COMPUTE_BIT) result.localSize = workgroupSize(m, shader);
    return result;
}

} // namespace penumbra::gpu

#include "penumbra/gpu/ShaderInterface.h"

#include "penumbra/core/Error.h"

#include <fmt/format.h>

#include <spirv_cross_c.h>

#include <algorithm>
#include <memory>

namespace penumbra::gpu {
namespace {

// The module's descriptors are read with SPIRV-Cross (Debian's libspirv-cross-c-shared)
// rather than glslang's reflection: glslang reports only the variables the entry point
// uses, and a pipeline must also accept descriptors for the ones a shader variant
// declares but leaves unused. SPIRV-Cross lists every declared resource.

// One SPIRV-Cross context for one reflection; its errors become ShaderCompileError naming
// the shader.
class Reflector {
public:
    Reflector(std::span<const uint32_t> spirv, std::string_view shader) : shader_(shader), context_(create(shader))
    {
        spvc_context_set_error_callback(
            context_.get(), [](void* self, const char* error) { static_cast<Reflector*>(self)->error_ = error; }, this);
        spvc_parsed_ir ir = nullptr;
        check(spvc_context_parse_spirv(context_.get(), spirv.data(), spirv.size(), &ir), "not a valid SPIR-V module");
        check(spvc_context_create_compiler(context_.get(), SPVC_BACKEND_NONE, ir, SPVC_CAPTURE_MODE_TAKE_OWNERSHIP,
                                           &compiler_),
              "SPIR-V the reflection cannot read");
        check(spvc_compiler_create_shader_resources(compiler_, &resources_), "SPIR-V the reflection cannot read");
    }

    std::span<const spvc_reflected_resource> resources(spvc_resource_type type) const
    {
        const spvc_reflected_resource* list = nullptr;
        size_t count = 0;
        spvc_resources_get_resource_list_for_type(resources_, type, &list, &count);
        return {list, count};
    }
    uint32_t decoration(spvc_variable_id id, SpvDecoration d) const { return spvc_compiler_get_decoration(compiler_, id, d); }
    std::string name(spvc_variable_id id) const
    {
        const char* n = spvc_compiler_get_name(compiler_, id);
        return n ? n : "";
    }
    spvc_type type(spvc_type_id id) const { return spvc_compiler_get_type_handle(compiler_, id); }
    uint32_t localSize(unsigned axis) const
    {
        return spvc_compiler_get_execution_mode_argument_by_index(compiler_, SpvExecutionModeLocalSize, axis);
    }

private:
    // The context owns everything made from it: the parsed module, compiler, resources.
    using Context = std::unique_ptr<spvc_context_s, decltype(&spvc_context_destroy)>;
    static Context create(std::string_view shader)
    {
        spvc_context context = nullptr;
        if (spvc_context_create(&context) != SPVC_SUCCESS) {
            throw ShaderCompileError(fmt::format("{}: SPIRV-Cross could not create a context", shader));
        }
        return {context, &spvc_context_destroy};
    }
    void check(spvc_result result, std::string_view what) const
    {
        if (result != SPVC_SUCCESS) throw ShaderCompileError(fmt::format("{}: {}: {}", shader_, what, error_));
    }

    std::string_view shader_;
    std::string error_;
    Context context_;
    spvc_compiler compiler_ = nullptr;
    spvc_resources resources_ = nullptr;
};

// The Vulkan descriptor of each kind of resource SPIRV-Cross lists; a texel buffer is an
// image of dimension Buffer. Push constants, stage inputs and outputs are no descriptors.
struct ResourceKind {
    spvc_resource_type resource;
    VkDescriptorType type;
    VkDescriptorType bufferDimType;  // the type when the image's dimension is Buffer
};
constexpr ResourceKind kResourceKinds[] = {
    {SPVC_RESOURCE_TYPE_UNIFORM_BUFFER, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER},
    {SPVC_RESOURCE_TYPE_STORAGE_BUFFER, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
    {SPVC_RESOURCE_TYPE_STORAGE_IMAGE, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER},
    {SPVC_RESOURCE_TYPE_SAMPLED_IMAGE, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER},
    {SPVC_RESOURCE_TYPE_SEPARATE_IMAGE, VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE, VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER},
    {SPVC_RESOURCE_TYPE_SEPARATE_SAMPLERS, VK_DESCRIPTOR_TYPE_SAMPLER, VK_DESCRIPTOR_TYPE_SAMPLER},
    {SPVC_RESOURCE_TYPE_SUBPASS_INPUT, VK_DESCRIPTOR_TYPE_INPUT_ATTACHMENT, VK_DESCRIPTOR_TYPE_INPUT_ATTACHMENT},
    {SPVC_RESOURCE_TYPE_ACCELERATION_STRUCTURE, VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR,
     VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR},
};

bool isBufferKind(spvc_resource_type r)
{
    return r == SPVC_RESOURCE_TYPE_UNIFORM_BUFFER || r == SPVC_RESOURCE_TYPE_STORAGE_BUFFER;
}

bool isImageKind(spvc_resource_type r)
{
    return r == SPVC_RESOURCE_TYPE_STORAGE_IMAGE || r == SPVC_RESOURCE_TYPE_SAMPLED_IMAGE ||
           r == SPVC_RESOURCE_TYPE_SEPARATE_IMAGE;
}

// The number of descriptors of an arrayed binding (the product of its dimensions).
uint32_t descriptorCount(spvc_type type, const std::string& name, std::string_view shader)
{
    uint32_t count = 1;
    for (unsigned d = 0; d < spvc_type_get_num_array_dimensions(type); ++d) {
        const uint32_t length = spvc_type_get_array_dimension(type, d);
        if (!spvc_type_array_dimension_is_literal(type, d) || length == 0) {
            throw ShaderCompileError(fmt::format("{}: '{}': an array of descriptors needs a constant length (the "
                                                 "pipelines use no descriptor indexing)",
                                                 shader, name));
        }
        count *= length;
    }
    return count;
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
    const Reflector reflector(spirv, shader);
    ShaderInterface result;
    for (const ResourceKind& kind : kResourceKinds) {
        for (const spvc_reflected_resource& r : reflector.resources(kind.resource)) {
            const std::string variable = reflector.name(r.id);
            const std::string blockName = isBufferKind(kind.resource) ? reflector.name(r.base_type_id) : std::string();
            const std::string name = variable.empty() ? blockName : variable;
            const uint32_t set = reflector.decoration(r.id, SpvDecorationDescriptorSet);
            if (set != 0) {
                throw ShaderCompileError(fmt::format("{}: '{}' is in descriptor set {}; a pipeline has one "
                                                     "push-descriptor set, set 0 (leave `set` out of the layout)",
                                                     shader, name, set));
            }
            const spvc_type type = reflector.type(r.type_id);
            ShaderBinding b;
            b.name = name;
            b.blockName = blockName;
            b.binding = reflector.decoration(r.id, SpvDecorationBinding);
            b.type = isImageKind(kind.resource) && spvc_type_get_image_dimension(type) == SpvDimBuffer ? kind.bufferDimType
                                                                                                      : kind.type;
            b.count = descriptorCount(type, name, shader);
            b.stages = stage;
            addBinding(result.bindings, std::move(b), shader);
        }
    }
    // LocalSize or LocalSizeId (what SPIR-V 1.6 emits): SPIRV-Cross gives the value of either.
    if (stage == VK_SHADER_STAGE_COMPUTE_BIT) result.localSize = {reflector.localSize(0), reflector.localSize(1), reflector.localSize(2)};
    return result;
}

} // namespace penumbra::gpu

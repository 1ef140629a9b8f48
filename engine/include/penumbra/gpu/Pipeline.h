#pragma once
// Compute and graphics pipelines with one push-descriptor set (VK_KHR_push_descriptor:
// no descriptor pools to size; lavapipe has no descriptor indexing, so bindings are
// plain and few) and push constants. The set's layout and a compute shader's workgroup
// size come from the shaders themselves (gpu/ShaderInterface.h): the C++ names bindings
// as the GLSL does (`DescriptorPush().storageImage("visibilityOut", image)`) and
// dispatches over an image with dispatchOver, so no number is kept equal to the GLSL by
// hand.
#include "penumbra/gpu/ShaderCompiler.h"
#include "penumbra/gpu/ShaderInterface.h"

#include <vulkan/vulkan.h>

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace penumbra::gpu {

class Context;
class Buffer;
class Image;

struct VertexLayout {
    uint32_t stride = 0;                        // 0: no vertex buffer
    std::vector<VkVertexInputAttributeDescription> attributes;
};

struct GraphicsPipelineDesc {
    std::string name;
    std::filesystem::path vertexShader;
    std::optional<std::filesystem::path> fragmentShader;  // none: depth-only pass
    std::vector<ShaderDefine> defines;
    uint32_t pushConstantBytes = 0;
    VertexLayout vertexLayout;
    std::vector<VkFormat> colorFormats;
    VkFormat depthFormat = VK_FORMAT_UNDEFINED;
    VkCompareOp depthCompare = VK_COMPARE_OP_GREATER_OR_EQUAL;  // reversed-Z
    bool depthWrite = true;
    bool depthBias = false;  // constant/slope/clamp set per draw (dynamic state)
    VkCullModeFlags cullMode = VK_CULL_MODE_BACK_BIT;
};

struct ComputePipelineDesc {
    std::string name;
    std::filesystem::path shader;
    std::vector<ShaderDefine> defines;
    uint32_t pushConstantBytes = 0;
    // When not empty, the shader's text, composed by its owner: `shader` then only names
    // it in diagnostics and is where its relative #includes start.
    std::string source;
};

class Pipeline {
public:
    Pipeline() = default;
    Pipeline(Context& context, const ShaderCompiler& compiler, const ComputePipelineDesc& desc);
    Pipeline(Context& context, const ShaderCompiler& compiler, const GraphicsPipelineDesc& desc);
    ~Pipeline();
    Pipeline(Pipeline&& other) noexcept;
    Pipeline& operator=(Pipeline&& other) noexcept;
    Pipeline(const Pipeline&) = delete;
    Pipeline& operator=(const Pipeline&) = delete;

    VkPipeline handle() const { return pipeline_; }
    VkPipelineLayout layout() const { return layout_; }
    VkPipelineBindPoint bindPoint() const { return bindPoint_; }
    VkShaderStageFlags stages() const { return stages_; }
    const std::string& name() const { return name_; }
    // What the shaders declare: bindings by name, the compute shader's local size.
    const ShaderInterface& shaderInterface() const { return interface_; }
    // The binding the shaders call `name` (a variable's name, or a buffer's block name).
    // Throws penumbra::Error naming the pipeline, `name` and the names there are.
    const ShaderBinding& binding(std::string_view name) const;

    void bind(VkCommandBuffer cmd) const;
    void pushConstants(VkCommandBuffer cmd, const void* data, uint32_t bytes) const;
    // Dispatches a compute pipeline over a width x height grid of invocations (one per
    // pixel of an image, say): ceil(width / local_size_x) x ceil(height / local_size_y)
    // workgroups, with the shader's own local size. The last groups overhang a size that
    // is no multiple of it: the shader skips invocations outside (gl_GlobalInvocationID
    // against imageSize). Throws penumbra::Error for a graphics pipeline.
    void dispatchOver(VkCommandBuffer cmd, uint32_t width, uint32_t height = 1) const;
    // The same over every texel of `image` (its full size).
    void dispatchOver(VkCommandBuffer cmd, const Image& image) const;
    // Only the workgroups that cover `region` (vkCmdDispatchBase: gl_GlobalInvocationID
    // counts from the image's origin, as with dispatchOver, so a shader needs no offset).
    // Returns the invocations it ran: `region` grown to whole workgroups (empty for an
    // empty region, when nothing runs).
    VkRect2D dispatchOverRegion(VkCommandBuffer cmd, VkRect2D region) const;

private:
    void reflect(const std::vector<uint32_t>& spirv, VkShaderStageFlagBits stage, const std::filesystem::path& shader);
    void createLayout(uint32_t pushConstantBytes);
    void release();

    VkDevice device_ = VK_NULL_HANDLE;
    VkDescriptorSetLayout setLayout_ = VK_NULL_HANDLE;
    VkPipelineLayout layout_ = VK_NULL_HANDLE;
    VkPipeline pipeline_ = VK_NULL_HANDLE;
    VkPipelineBindPoint bindPoint_ = VK_PIPELINE_BIND_POINT_COMPUTE;
    VkShaderStageFlags stages_ = 0;
    std::string name_;
    ShaderInterface interface_;
};

// Collects the descriptors of one draw or dispatch and pushes them. A binding is named as
// the shader names it (`"gPosition"`; a buffer by its instance or block name); names are
// looked up in the pipeline at push(), which throws penumbra::Error naming the pipeline
// and the binding for a name its shaders do not declare or a descriptor of another type
// than they declare there. There are no binding numbers on the C++ side.
class DescriptorPush {
public:
    DescriptorPush& storageImage(std::string_view name, const Image& image);
    DescriptorPush& sampledImage(std::string_view name, const Image& image, VkSampler sampler,
                                 VkImageLayout layout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    // One array binding of combined image samplers, all in `layout`.
    DescriptorPush& sampledImages(std::string_view name, const std::vector<const Image*>& images, VkSampler sampler,
                                  VkImageLayout layout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    DescriptorPush& storageBuffer(std::string_view name, const Buffer& buffer);
    DescriptorPush& uniformBuffer(std::string_view name, const Buffer& buffer);
    // Prefixed to the names given from here on: a unit that a shader holds under a prefix
    // (gpu/GlslNames.h) is bound by the names its own source gives.
    void setNamePrefix(std::string prefix) { prefix_ = std::move(prefix); }

    void push(const Context& context, VkCommandBuffer cmd, const Pipeline& pipeline);

private:
    struct Entry {
        std::string name;  // the binding's, as the shaders name it
        VkDescriptorType type;
        std::vector<VkDescriptorImageInfo> images;
        VkDescriptorBufferInfo buffer{};
    };
    DescriptorPush& add(std::string_view name, VkDescriptorType type, std::vector<VkDescriptorImageInfo> images,
                        VkDescriptorBufferInfo buffer = {});
    static uint32_t resolve(const Entry& entry, const Pipeline& pipeline);
    std::vector<Entry> entries_;
    std::string prefix_;
};

// An owned VkSampler, destroyed with its owner: a constructor that throws after creating
// one (a technique whose pipeline fails to compile) leaks nothing.
class Sampler {
public:
    Sampler() = default;
    Sampler(VkDevice device, VkSampler sampler) : device_(device), sampler_(sampler) {}
    ~Sampler() { reset(); }
    Sampler(Sampler&& other) noexcept { *this = std::move(other); }
    Sampler& operator=(Sampler&& other) noexcept
    {
        if (this != &other) {
            reset();
            device_ = std::exchange(other.device_, VK_NULL_HANDLE);
            sampler_ = std::exchange(other.sampler_, VK_NULL_HANDLE);
        }
        return *this;
    }
    Sampler(const Sampler&) = delete;
    Sampler& operator=(const Sampler&) = delete;

    VkSampler handle() const { return sampler_; }
    // Converts where a VkSampler is expected; never from a temporary, whose sampler is
    // destroyed at once.
    operator VkSampler() const& { return sampler_; }
    operator VkSampler() const&& = delete;

private:
    void reset()
    {
        if (sampler_) vkDestroySampler(device_, sampler_, nullptr);
        sampler_ = VK_NULL_HANDLE;
    }
    VkDevice device_ = VK_NULL_HANDLE;
    VkSampler sampler_ = VK_NULL_HANDLE;
};

// compare = a comparison op makes a depth-comparison sampler.
Sampler createSampler(Context& context, VkFilter filter, VkSamplerAddressMode address,
                      std::optional<VkCompareOp> compare = std::nullopt);

} // namespace penumbra::gpu

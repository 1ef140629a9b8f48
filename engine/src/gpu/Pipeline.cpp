#include "penumbra/gpu/Pipeline.h"

#include "penumbra/core/Error.h"
#include "penumbra/gpu/Check.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/Resources.h"

#include <fmt/format.h>

#include <utility>

namespace penumbra::gpu {
namespace {

VkShaderModule createModule(VkDevice device, const std::vector<uint32_t>& spirv, const std::string& name)
{
    VkShaderModuleCreateInfo info{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
    info.codeSize = spirv.size() * sizeof(uint32_t);
    info.pCode = spirv.data();
    VkShaderModule module = VK_NULL_HANDLE;
    check(vkCreateShaderModule(device, &info, nullptr, &module), "vkCreateShaderModule " + name);
    return module;
}

struct ModuleGuard {
    VkDevice device;
    std::vector<VkShaderModule> modules;
    ~ModuleGuard()
    {
        for (VkShaderModule m : modules) vkDestroyShaderModule(device, m, nullptr);
    }
};

} // namespace

void Pipeline::createLayout(const std::vector<Binding>& bindings, uint32_t pushConstantBytes,
                            const std::string& name)
{
    std::vector<VkDescriptorSetLayoutBinding> vkBindings;
    for (const Binding& b : bindings) {
        VkDescriptorSetLayoutBinding vb{};
        vb.binding = b.binding;
        vb.descriptorType = b.type;
        vb.descriptorCount = b.count;
        vb.stageFlags = stages_;
        vkBindings.push_back(vb);
    }
    VkDescriptorSetLayoutCreateInfo setInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
    setInfo.flags = VK_DESCRIPTOR_SET_LAYOUT_CREATE_PUSH_DESCRIPTOR_BIT_KHR;
    setInfo.bindingCount = static_cast<uint32_t>(vkBindings.size());
    setInfo.pBindings = vkBindings.data();
    check(vkCreateDescriptorSetLayout(device_, &setInfo, nullptr, &setLayout_), "vkCreateDescriptorSetLayout " + name);

    VkPushConstantRange range{stages_, 0, pushConstantBytes};
    VkPipelineLayoutCreateInfo layoutInfo{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
    layoutInfo.setLayoutCount = 1;
    layoutInfo.pSetLayouts = &setLayout_;
    layoutInfo.pushConstantRangeCount = pushConstantBytes ? 1 : 0;
    layoutInfo.pPushConstantRanges = &range;
    check(vkCreatePipelineLayout(device_, &layoutInfo, nullptr, &layout_), "vkCreatePipelineLayout " + name);
}

Pipeline::Pipeline(Context& context, const ShaderCompiler& compiler, const ComputePipelineDesc& desc)
    : device_(context.device()), bindPoint_(VK_PIPELINE_BIND_POINT_COMPUTE), stages_(VK_SHADER_STAGE_COMPUTE_BIT)
{
    try {
        ModuleGuard guard{device_, {createModule(device_, compiler.compile(desc.shader, desc.defines), desc.name)}};
        createLayout(desc.bindings, desc.pushConstantBytes, desc.name);
        VkComputePipelineCreateInfo info{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
        info.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
        info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
        info.stage.module = guard.modules[0];
        info.stage.pName = "main";
        info.layout = layout_;
        check(vkCreateComputePipelines(device_, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline_),
              "vkCreateComputePipelines " + desc.name);
        context.setName(VK_OBJECT_TYPE_PIPELINE, reinterpret_cast<uint64_t>(pipeline_), desc.name);
    } catch (...) {
        release();
        throw;
    }
}

Pipeline::Pipeline(Context& context, const ShaderCompiler& compiler, const GraphicsPipelineDesc& desc)
    : device_(context.device()), bindPoint_(VK_PIPELINE_BIND_POINT_GRAPHICS)
{
    try {
        ModuleGuard guard{device_, {}};
        std::vector<VkPipelineShaderStageCreateInfo> stageInfos;
        auto addStage = [&](const std::filesystem::path& path, VkShaderStageFlagBits stage) {
            guard.modules.push_back(createModule(device_, compiler.compile(path, desc.defines), desc.name));
            VkPipelineShaderStageCreateInfo s{VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
            s.stage = stage;
            s.module = guard.modules.back();
            s.pName = "main";
            stageInfos.push_back(s);
            stages_ |= stage;
        };
        addStage(desc.vertexShader, VK_SHADER_STAGE_VERTEX_BIT);
        if (desc.fragmentShader) {
            addStage(*desc.fragmentShader, VK_SHADER_STAGE_FRAGMENT_BIT);
        }
        createLayout(desc.bindings, desc.pushConstantBytes, desc.name);

        VkVertexInputBindingDescription vertexBinding{0, desc.vertexLayout.stride, VK_VERTEX_INPUT_RATE_VERTEX};
        VkPipelineVertexInputStateCreateInfo vertexInput{VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
        if (desc.vertexLayout.stride) {
            vertexInput.vertexBindingDescriptionCount = 1;
            vertexInput.pVertexBindingDescriptions = &vertexBinding;
            vertexInput.vertexAttributeDescriptionCount = static_cast<uint32_t>(desc.vertexLayout.attributes.size());
            vertexInput.pVertexAttributeDescriptions = desc.vertexLayout.attributes.data();
        }
        VkPipelineInputAssemblyStateCreateInfo assembly{VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
        assembly.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
        VkPipelineViewportStateCreateInfo viewport{VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
        viewport.viewportCount = 1;
        viewport.scissorCount = 1;
        VkPipelineRasterizationStateCreateInfo raster{VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
        raster.polygonMode = VK_POLYGON_MODE_FILL;
        raster.cullMode = desc.cullMode;
        raster.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
        raster.depthBiasEnable = desc.depthBias ? VK_TRUE : VK_FALSE;
        raster.lineWidth = 1.0f;
        VkPipelineMultisampleStateCreateInfo multisample{VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
        multisample.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
        VkPipelineDepthStencilStateCreateInfo depth{VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO};
        depth.depthTestEnable = desc.depthFormat != VK_FORMAT_UNDEFINED;
        depth.depthWriteEnable = desc.depthWrite && desc.depthFormat != VK_FORMAT_UNDEFINED;
        depth.depthCompareOp = desc.depthCompare;
        std::vector<VkPipelineColorBlendAttachmentState> blends(desc.colorFormats.size());
        for (auto& b : blends) {
            b.colorWriteMask = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT | VK_COLOR_COMPONENT_B_BIT |
                               VK_COLOR_COMPONENT_A_BIT;
        }
        VkPipelineColorBlendStateCreateInfo blend{VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
        blend.attachmentCount = static_cast<uint32_t>(blends.size());
        blend.pAttachments = blends.data();
        std::vector<VkDynamicState> dynamic = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
        if (desc.depthBias) {
            dynamic.push_back(VK_DYNAMIC_STATE_DEPTH_BIAS);
        }
        VkPipelineDynamicStateCreateInfo dynamicState{VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO};
        dynamicState.dynamicStateCount = static_cast<uint32_t>(dynamic.size());
        dynamicState.pDynamicStates = dynamic.data();

        VkPipelineRenderingCreateInfo rendering{VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO};
        rendering.colorAttachmentCount = static_cast<uint32_t>(desc.colorFormats.size());
        rendering.pColorAttachmentFormats = desc.colorFormats.data();
        rendering.depthAttachmentFormat = desc.depthFormat;

        VkGraphicsPipelineCreateInfo info{VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO, &rendering};
        info.stageCount = static_cast<uint32_t>(stageInfos.size());
        info.pStages = stageInfos.data();
        info.pVertexInputState = &vertexInput;
        info.pInputAssemblyState = &assembly;
        info.pViewportState = &viewport;
        info.pRasterizationState = &raster;
        info.pMultisampleState = &multisample;
        info.pDepthStencilState = &depth;
        info.pColorBlendState = &blend;
        info.pDynamicState = &dynamicState;
        info.layout = layout_;
        check(vkCreateGraphicsPipelines(device_, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline_),
              "vkCreateGraphicsPipelines " + desc.name);
        context.setName(VK_OBJECT_TYPE_PIPELINE, reinterpret_cast<uint64_t>(pipeline_), desc.name);
    } catch (...) {
        release();
        throw;
    }
}

Pipeline::~Pipeline() { release(); }

Pipeline::Pipeline(Pipeline&& other) noexcept { *this = std::move(other); }

Pipeline& Pipeline::operator=(Pipeline&& other) noexcept
{
    if (this != &other) {
        release();
        device_ = std::exchange(other.device_, VK_NULL_HANDLE);
        setLayout_ = std::exchange(other.setLayout_, VK_NULL_HANDLE);
        layout_ = std::exchange(other.layout_, VK_NULL_HANDLE);
        pipeline_ = std::exchange(other.pipeline_, VK_NULL_HANDLE);
        bindPoint_ = other.bindPoint_;
        stages_ = other.stages_;
    }
    return *this;
}

void Pipeline::release()
{
    if (!device_) return;
    if (pipeline_) vkDestroyPipeline(device_, pipeline_, nullptr);
    if (layout_) vkDestroyPipelineLayout(device_, layout_, nullptr);
    if (setLayout_) vkDestroyDescriptorSetLayout(device_, setLayout_, nullptr);
    pipeline_ = VK_NULL_HANDLE;
    layout_ = VK_NULL_HANDLE;
    setLayout_ = VK_NULL_HANDLE;
    device_ = VK_NULL_HANDLE;
}

void Pipeline::bind(VkCommandBuffer cmd) const { vkCmdBindPipeline(cmd, bindPoint_, pipeline_); }

void Pipeline::pushConstants(VkCommandBuffer cmd, const void* data, uint32_t bytes) const
{
    vkCmdPushConstants(cmd, layout_, stages_, 0, bytes, data);
}

DescriptorPush& DescriptorPush::storageImage(uint32_t binding, const Image& image)
{
    entries_.push_back({binding, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE,
                        {{VK_NULL_HANDLE, image.view(), VK_IMAGE_LAYOUT_GENERAL}}, {}});
    return *this;
}

DescriptorPush& DescriptorPush::sampledImage(uint32_t binding, const Image& image, VkSampler sampler,
                                             VkImageLayout layout)
{
    entries_.push_back({binding, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, {{sampler, image.view(), layout}}, {}});
    return *this;
}

DescriptorPush& DescriptorPush::sampledImages(uint32_t binding, const std::vector<const Image*>& images,
                                              VkSampler sampler, VkImageLayout layout)
{
    Entry e{binding, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, {}, {}};
    for (const Image* image : images) {
        e.images.push_back({sampler, image->view(), layout});
    }
    entries_.push_back(std::move(e));
    return *this;
}

DescriptorPush& DescriptorPush::storageBuffer(uint32_t binding, const Buffer& buffer)
{
    entries_.push_back({binding, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, {}, {buffer.handle(), 0, VK_WHOLE_SIZE}});
    return *this;
}

DescriptorPush& DescriptorPush::uniformBuffer(uint32_t binding, const Buffer& buffer)
{
    entries_.push_back({binding, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, {}, {buffer.handle(), 0, VK_WHOLE_SIZE}});
    return *this;
}

void DescriptorPush::push(const Context& context, VkCommandBuffer cmd, const Pipeline& pipeline)
{
    std::vector<VkWriteDescriptorSet> writes;
    writes.reserve(entries_.size());
    for (const Entry& e : entries_) {
        VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
        w.dstBinding = e.binding;
        w.descriptorType = e.type;
        if (e.images.empty()) {
            w.descriptorCount = 1;
            w.pBufferInfo = &e.buffer;
        } else {
            w.descriptorCount = static_cast<uint32_t>(e.images.size());
            w.pImageInfo = e.images.data();
        }
        writes.push_back(w);
    }
    context.pushDescriptorSet(cmd, pipeline.bindPoint(), pipeline.layout(), writes);
    entries_.clear();
}

Sampler createSampler(Context& context, VkFilter filter, VkSamplerAddressMode address,
                      std::optional<VkCompareOp> compare)
{
    VkSamplerCreateInfo info{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
    info.magFilter = filter;
    info.minFilter = filter;
    info.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
    info.addressModeU = address;
    info.addressModeV = address;
    info.addressModeW = address;
    info.borderColor = VK_BORDER_COLOR_FLOAT_OPAQUE_WHITE;
    info.maxLod = 0.0f;
    if (compare) {
        info.compareEnable = VK_TRUE;
        info.compareOp = *compare;
    }
    VkSampler sampler = VK_NULL_HANDLE;
    check(vkCreateSampler(context.device(), &info, nullptr, &sampler), "vkCreateSampler");
    return Sampler(context.device(), sampler);
}

} // namespace penumbra::gpu

#include "penumbra/gpu/Pipeline.h"

#include "penumbra/core/Error.h"
#include "penumbra/gpu/Check.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/Resources.h"

#include "core/Text.h"

#include <fmt/format.h>

#include <algorithm>

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

std::vector<VkDescriptorImageInfo> sampledInfos(const std::vector<const Image*>& images, VkSampler sampler,
                                                VkImageLayout layout)
{
    std::vector<VkDescriptorImageInfo> infos;
    for (const Image* image : images) infos.push_back({sampler, image->view(), layout});
    return infos;
}

VkDescriptorBufferInfo wholeBuffer(const Buffer& buffer) { return {buffer.handle(), 0, VK_WHOLE_SIZE}; }

} // namespace

void Pipeline::reflect(const std::vector<uint32_t>& spirv, VkShaderStageFlagBits stage,
                       const std::filesystem::path& shader)
{
    const ShaderInterface declared = reflectShaderInterface(spirv, stage, fmt::format("{} ({})", shader.string(), name_));
    interface_.merge(declared, name_);
    if (stage == VK_SHADER_STAGE_COMPUTE_BIT) interface_.localSize = declared.localSize;
}

void Pipeline::createLayout(uint32_t pushConstantBytes)
{
    std::vector<VkDescriptorSetLayoutBinding> vkBindings;
    for (const ShaderBinding& b : interface_.bindings) vkBindings.push_back({b.binding, b.type, b.count, b.stages, nullptr});
    VkDescriptorSetLayoutCreateInfo setInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
    setInfo.flags = VK_DESCRIPTOR_SET_LAYOUT_CREATE_PUSH_DESCRIPTOR_BIT_KHR;
    setInfo.bindingCount = static_cast<uint32_t>(vkBindings.size());
    setInfo.pBindings = vkBindings.data();
    check(vkCreateDescriptorSetLayout(device_, &setInfo, nullptr, &setLayout_), "vkCreateDescriptorSetLayout " + name_);

    VkPushConstantRange range{stages_, 0, pushConstantBytes};
    VkPipelineLayoutCreateInfo layoutInfo{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
    layoutInfo.setLayoutCount = 1;
    layoutInfo.pSetLayouts = &setLayout_;
    layoutInfo.pushConstantRangeCount = pushConstantBytes ? 1 : 0;
    layoutInfo.pPushConstantRanges = &range;
    check(vkCreatePipelineLayout(device_, &layoutInfo, nullptr, &layout_), "vkCreatePipelineLayout " + name_);
}

Pipeline::Pipeline(Context& context, const ShaderCompiler& compiler, const ComputePipelineDesc& desc)
    : device_(context.device()),
      bindPoint_(VK_PIPELINE_BIND_POINT_COMPUTE),
      stages_(VK_SHADER_STAGE_COMPUTE_BIT),
      name_(desc.name)
{
    try {
        // Composed source is named as if it lay in the first shader folder: diagnostics
        // then say which folder's shaders it was composed of.
        const std::filesystem::path named = desc.shader.is_absolute() || compiler.searchPath().empty()
                                                ? desc.shader
                                                : compiler.searchPath().front() / desc.shader;
        const std::vector<uint32_t> spirv =
            desc.source.empty() ? compiler.compile(desc.shader, desc.defines)
                                : compiler.compileSource(desc.source, named, VK_SHADER_STAGE_COMPUTE_BIT, desc.defines);
        reflect(spirv, VK_SHADER_STAGE_COMPUTE_BIT, desc.shader);
        ModuleGuard guard{device_, {createModule(device_, spirv, desc.name)}};
        createLayout(desc.pushConstantBytes);
        VkComputePipelineCreateInfo info{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
        // dispatchOverRegion starts its workgroups past the origin (vkCmdDispatchBase).
        info.flags = VK_PIPELINE_CREATE_DISPATCH_BASE_BIT;
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
    : device_(context.device()), bindPoint_(VK_PIPELINE_BIND_POINT_GRAPHICS), name_(desc.name)
{
    try {
        ModuleGuard guard{device_, {}};
        std::vector<VkPipelineShaderStageCreateInfo> stageInfos;
        auto addStage = [&](const std::filesystem::path& path, VkShaderStageFlagBits stage) {
            const std::vector<uint32_t> spirv = compiler.compile(path, desc.defines);
            reflect(spirv, stage, path);
            guard.modules.push_back(createModule(device_, spirv, desc.name));
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
        createLayout(desc.pushConstantBytes);

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
        name_ = std::move(other.name_);
        interface_ = std::move(other.interface_);
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

const ShaderBinding& Pipeline::binding(std::string_view name) const
{
    if (const ShaderBinding* b = interface_.find(name)) return *b;
    std::vector<std::string> names;
    for (const ShaderBinding& b : interface_.bindings) {
        names.push_back(b.name);
        if (!b.blockName.empty() && b.blockName != b.name) names.push_back(b.blockName);
    }
    const std::string suggestion = core::closestMatch(name, names);
    throw Error(fmt::format("pipeline '{}': its shaders declare no binding '{}'{}; they declare: {}", name_, name,
                            suggestion.empty() ? "" : fmt::format(" (did you mean '{}'?)", suggestion),
                            names.empty() ? "none" : fmt::format("{}", fmt::join(names, ", "))));
}

void Pipeline::dispatchOver(VkCommandBuffer cmd, uint32_t width, uint32_t height) const
{
    if (bindPoint_ != VK_PIPELINE_BIND_POINT_COMPUTE) {
        throw Error(fmt::format("pipeline '{}': dispatchOver needs a compute pipeline", name_));
    }
    const auto groups = [](uint32_t invocations, uint32_t local) { return (invocations + local - 1) / local; };
    vkCmdDispatch(cmd, groups(width, interface_.localSize[0]), groups(height, interface_.localSize[1]), 1);
}

void Pipeline::dispatchOver(VkCommandBuffer cmd, const Image& image) const
{
    dispatchOver(cmd, image.desc().width, image.desc().height);
}

VkRect2D Pipeline::dispatchOverRegion(VkCommandBuffer cmd, VkRect2D region) const
{
    if (bindPoint_ != VK_PIPELINE_BIND_POINT_COMPUTE) {
        throw Error(fmt::format("pipeline '{}': dispatchOverRegion needs a compute pipeline", name_));
    }
    const uint32_t lx = interface_.localSize[0], ly = interface_.localSize[1];
    const uint32_t x0 = uint32_t(std::max(region.offset.x, 0)) / lx, y0 = uint32_t(std::max(region.offset.y, 0)) / ly;
    const uint32_t x1 = (uint32_t(std::max(region.offset.x, 0)) + region.extent.width + lx - 1) / lx;
    const uint32_t y1 = (uint32_t(std::max(region.offset.y, 0)) + region.extent.height + ly - 1) / ly;
    if (x1 <= x0 || y1 <= y0) return VkRect2D{};
    vkCmdDispatchBase(cmd, x0, y0, 0, x1 - x0, y1 - y0, 1);
    return VkRect2D{{int32_t(x0 * lx), int32_t(y0 * ly)}, {(x1 - x0) * lx, (y1 - y0) * ly}};
}

DescriptorPush& DescriptorPush::add(std::string_view name, VkDescriptorType type,
                                    std::vector<VkDescriptorImageInfo> images, VkDescriptorBufferInfo buffer)
{
    entries_.push_back({prefix_ + std::string(name), type, std::move(images), buffer});
    return *this;
}

DescriptorPush& DescriptorPush::storageImage(std::string_view name, const Image& image)
{
    return add(name, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, {{VK_NULL_HANDLE, image.view(), VK_IMAGE_LAYOUT_GENERAL}});
}

DescriptorPush& DescriptorPush::sampledImage(std::string_view name, const Image& image, VkSampler sampler,
                                             VkImageLayout layout)
{
    return add(name, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, {{sampler, image.view(), layout}});
}

DescriptorPush& DescriptorPush::sampledImages(std::string_view name, const std::vector<const Image*>& images,
                                              VkSampler sampler, VkImageLayout layout)
{
    return add(name, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, sampledInfos(images, sampler, layout));
}

DescriptorPush& DescriptorPush::storageBuffer(std::string_view name, const Buffer& buffer)
{
    return add(name, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, {}, wholeBuffer(buffer));
}

DescriptorPush& DescriptorPush::uniformBuffer(std::string_view name, const Buffer& buffer)
{
    return add(name, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, {}, wholeBuffer(buffer));
}

// An entry's binding number, checked against what the shaders declare there.
uint32_t DescriptorPush::resolve(const Entry& entry, const Pipeline& pipeline)
{
    const ShaderBinding& b = pipeline.binding(entry.name);
    if (b.type != entry.type) {
        throw Error(fmt::format("pipeline '{}': binding '{}' is a {} in its shaders, set here as a {}", pipeline.name(),
                                entry.name, descriptorTypeName(b.type), descriptorTypeName(entry.type)));
    }
    return b.binding;
}

void DescriptorPush::push(const Context& context, VkCommandBuffer cmd, const Pipeline& pipeline)
{
    std::vector<VkWriteDescriptorSet> writes;
    writes.reserve(entries_.size());
    for (const Entry& e : entries_) {
        VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
        w.dstBinding = resolve(e, pipeline);
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

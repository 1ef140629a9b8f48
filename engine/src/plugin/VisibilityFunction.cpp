#include "penumbra/plugin/VisibilityFunction.h"

#include "penumbra/core/Error.h"

#include <fmt/format.h>

#include <cmath>
#include <utility>

namespace penumbra::plugin {
namespace {

namespace fs = std::filesystem;

// The visibility pass's own bindings are 0..3 (common/gbuffer.glsl's three, visibilityOut);
// the function's follow.
constexpr uint32_t kPassFunctionBindingBase = 4;

std::string bindingMacro(uint32_t base)
{
    return fmt::format("#define VISIBILITY_BINDING(k) ({} + (k))\n", base);
}

std::string includeLine(const fs::path& file) { return fmt::format("#include \"{}\"\n", file.string()); }

} // namespace

std::string visibilityFunctionHead(const std::string& extensions)
{
    return "#version 460\n" + extensions +
           "#define GBUFFER_BINDING 0\n"
           "#include \"common/gbuffer.glsl\"\n"
           "#include \"common/visibility.glsl\"\n";
}

std::string visibilityPassSource(const fs::path& function)
{
    return visibilityFunctionHead() + bindingMacro(kPassFunctionBindingBase) + includeLine(function) +
           "#include \"engine/visibility_function_pass.glsl\"\n";
}

std::string floatLiteral(float value)
{
    if (!std::isfinite(value)) throw Error(fmt::format("GLSL float literal: {} is not a finite float", value));
    std::string literal = fmt::format("{}", value);  // the shortest text that reads back as `value`
    if (literal.find_first_of(".e") == std::string::npos) literal += ".0";
    return literal;
}

gpu::ShaderDefine floatDefine(std::string name, float value)
{
    try {
        return {name, floatLiteral(value)};
    } catch (const Error& e) {
        throw Error(fmt::format("shader define {}: {}", name, e.what()));
    }
}

VisibilityFunction::VisibilityFunction(const TechniqueSetup& setup, const fs::path& shader,
                                       std::vector<gpu::ShaderDefine> defines, uint32_t localSizeX, uint32_t localSizeY)
    : compiler_(&setup.shaders), shader_(setup.shaders.resolve(shader)), defines_(std::move(defines))
{
    gpu::ComputePipelineDesc desc;
    desc.name = setup.local("visibility");
    // Named beside the function, so that its relative #includes start in its folder.
    desc.shader = shader_.parent_path() / (shader_.filename().string() + ".pass.comp");
    desc.defines = defines_;
    desc.defines.push_back({"VISIBILITY_LOCAL_SIZE_X", std::to_string(localSizeX)});
    desc.defines.push_back({"VISIBILITY_LOCAL_SIZE_Y", std::to_string(localSizeY)});
    desc.source = visibilityPassSource(shader_);
    pass_ = gpu::Pipeline(setup.context, setup.shaders, desc);
    for (const gpu::ShaderBinding& b : pass_.shaderInterface().bindings) {
        if (b.binding >= kPassFunctionBindingBase + kMaxVisibilityFunctionBindings) {
            throw Error(fmt::format("{}: binding '{}' is past VISIBILITY_BINDING({}): a visibility function has {} "
                                    "bindings, VISIBILITY_BINDING(0) to ({})",
                                    shader_.string(), b.name, b.binding - kPassFunctionBindingBase,
                                    kMaxVisibilityFunctionBindings, kMaxVisibilityFunctionBindings - 1));
        }
    }
    for (const gpu::ShaderBinding& b : pass_.shaderInterface().bindings)
        if (b.binding >= kPassFunctionBindingBase) descriptorCount_ += b.count;
}

std::string VisibilityFunction::preprocessedUnit(uint32_t bindingBase) const
{
    static constexpr const char* kMarker = "penumbraVisibilityFunctionBegins";
    const std::string source = visibilityFunctionHead() + fmt::format("const int {} = 1;\n", kMarker) + bindingMacro(bindingBase) +
                               includeLine(shader_);
    const std::string text = compiler_->preprocess(source, shader_.parent_path() / (shader_.filename().string() + ".unit.comp"),
                                                   VK_SHADER_STAGE_COMPUTE_BIT, defines_);
    const size_t marker = text.find(kMarker);
    const size_t end = marker == std::string::npos ? marker : text.find(';', marker);
    if (end == std::string::npos) throw Error(shader_.string() + ": the preprocessed unit lost its marker");
    return text.substr(end + 1);
}

void addVisibilityFunction(graph::RenderGraph& graph, const LightPassIo& io, const VisibilityFunction& function,
                           std::vector<std::string> sampledReads, BindVisibilityFn bind)
{
    if (io.evaluateInShading && io.evaluateInShading(VisibilityInShading{&function, sampledReads, bind})) return;
    graph::PassBuilder pass = addVisibilityPass(graph, io, function.passPipeline(), std::move(bind));
    for (const std::string& read : sampledReads) pass.read(read, graph::Usage::Sampled);
    pass.dependsOn(io.lightState).dependsOn(io.cameraState);
}

} // namespace penumbra::plugin

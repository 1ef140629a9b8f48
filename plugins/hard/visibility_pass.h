#pragma once
// The C++ side of visibility.glsl: which shader variant a parameter set compiles (the
// filter and the receiver-side bias are chosen by defines, not by branches on uniforms:
// each variant is straight-line code with its tap count known to the compiler). hard.cpp
// and the shader tests
// include it, so that the tests compile exactly the variants the plugin can ask for.
#include "penumbra/gpu/ShaderCompiler.h"
#include "penumbra/render/ShadowMap.h"

#include <cstdint>
#include <string>
#include <vector>

namespace penumbra::hard {

// Parameter `bias_mode`, in ParamSpec choice order.
enum class BiasMode : uint32_t { Constant, Slope, NormalOffset, ReceiverPlane };
inline constexpr const char* kBiasModeNames[] = {"constant", "slope", "normal_offset", "receiver_plane"};

// Parameter `filter`, in ParamSpec choice order.
enum class Filter : uint32_t { None, Pcf, Poisson, Bilinear };
inline constexpr const char* kFilterNames[] = {"none", "pcf", "poisson", "bilinear"};

inline constexpr int kPcfKernelMin = 1, kPcfKernelMax = 15;
inline constexpr int kPoissonSamplesMin = 4, kPoissonSamplesMax = render::kPoissonDiskPoints;

struct VisibilityVariant {
    Filter filter = Filter::None;
    BiasMode bias = BiasMode::Slope;
    uint32_t pcfKernel = 3;       // Filter::Pcf only
    uint32_t poissonSamples = 16;  // Filter::Poisson only

    // Constant and slope-scaled bias live in the rasterizer (depth pass); the shader
    // only sees the two receiver-side modes (shaders/common/shadow_receiver.glsl).
    bool offsetsAlongNormal() const { return bias == BiasMode::NormalOffset; }
    bool usesReceiverPlane() const { return bias == BiasMode::ReceiverPlane; }
    render::ReceiverBias receiverBias() const
    {
        return offsetsAlongNormal()  ? render::ReceiverBias::NormalOffset
               : usesReceiverPlane() ? render::ReceiverBias::Plane
                                     : render::ReceiverBias::None;
    }
    // Bilinear compares in the sampler (hardware 2 x 2 PCF), except with receiver plane
    // bias, which needs each of the four texels compared against its own reference
    // depth: those four taps are done by hand with a nearest sampler.
    bool hardwareBilinear() const { return filter == Filter::Bilinear && !usesReceiverPlane(); }
    VkFilter samplerFilter() const { return hardwareBilinear() ? VK_FILTER_LINEAR : VK_FILTER_NEAREST; }
};

// The defines that select `variant` in visibility.glsl. Only the defines a variant
// reads are set, so two parameter sets that compile the same code give equal lists.
inline std::vector<gpu::ShaderDefine> visibilityDefines(const VisibilityVariant& variant)
{
    std::vector<gpu::ShaderDefine> defines = {{"FILTER", std::to_string(uint32_t(variant.filter))},
                                              {"RECEIVER_BIAS", std::to_string(uint32_t(variant.receiverBias()))}};
    if (variant.filter == Filter::Pcf) defines.push_back({"PCF_KERNEL", std::to_string(variant.pcfKernel)});
    if (variant.filter == Filter::Poisson) defines.push_back({"POISSON_SAMPLES", std::to_string(variant.poissonSamples)});
    return defines;
}

} // namespace penumbra::hard

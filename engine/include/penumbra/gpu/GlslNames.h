#pragma once
// GLSL has no namespaces: two copies of one library (a technique's visibility function
// for two lights, each compiled with its own defines and bindings) cannot share a
// shader. prefixTopLevelNames gives every name a preprocessed unit declares at file scope
// (functions, variables, constants, structs, blocks and their instances) a prefix, and
// renames every use of it in the unit, so that units evaluated by one shader
// (frame::FrameRenderer's shading) never collide.
#include <string>
#include <string_view>
#include <vector>

namespace penumbra::gpu {

struct PrefixedUnit {
    std::string text;                     // the unit with its names prefixed, no directives
    std::vector<std::string> extensions;  // its "#extension ..." lines, for the shader's head
    std::vector<std::string> names;       // the file-scope names it declares, unprefixed, sorted
};

// `glsl` is preprocessed GLSL (gpu::ShaderCompiler::preprocess: no macros, no #include);
// its lines that start with '#' (#version, #extension, #line, #pragma) are dropped from
// the text. Member names (after '.', inside a struct's or block's braces) are never
// renamed. Throws penumbra::Error on unbalanced brackets.
PrefixedUnit prefixTopLevelNames(std::string_view glsl, std::string_view prefix);

} // namespace penumbra::gpu

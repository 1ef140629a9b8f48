#pragma once
// Run-time GLSL -> SPIR-V with the glslang library, so that shaders can be edited
// without rebuilding. `#include "x.glsl"` resolves against the including file's folder
// first, then the search path (the engine's shaders/ folder, then a plugin's folder).
// Compiled SPIR-V is kept in a ShaderCache (by default the one the process shares, on
// disk between runs): a shader whose source, defines and #included files are unchanged
// is not compiled again.
#include "penumbra/gpu/ShaderCache.h"

#include <vulkan/vulkan.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace penumbra::gpu {

struct ShaderDefine {
    std::string name;
    std::string value;
};

class ShaderCompiler {
public:
    explicit ShaderCompiler(std::vector<std::filesystem::path> searchPath, ShaderCache& cache = ShaderCache::shared());

    // Compiles `file` (absolute, or relative to the search path) for the stage implied
    // by its extension (.vert .frag .comp .geom .tesc .tese). Throws ShaderCompileError
    // whose message has one "path:line: error: message" line per diagnostic (a shader that
    // fails is never cached: every run reports its errors).
    std::vector<uint32_t> compile(const std::filesystem::path& file,
                                  const std::vector<ShaderDefine>& defines = {}) const;

    // Same, for source text that names itself `virtualPath` in diagnostics.
    std::vector<uint32_t> compileSource(const std::string& source, const std::filesystem::path& virtualPath,
                                        VkShaderStageFlagBits stage,
                                        const std::vector<ShaderDefine>& defines = {}) const;

    // `source` preprocessed as compileSource would see it (#includes resolved, macros
    // expanded, comments gone): GLSL text to compose into another shader
    // (gpu/GlslNames.h). Never cached. Throws ShaderCompileError.
    std::string preprocess(const std::string& source, const std::filesystem::path& virtualPath,
                           VkShaderStageFlagBits stage, const std::vector<ShaderDefine>& defines = {}) const;

    std::filesystem::path resolve(const std::filesystem::path& file) const;
    const std::vector<std::filesystem::path>& searchPath() const { return searchPath_; }

private:
    std::vector<std::filesystem::path> searchPath_;
    ShaderCache* cache_;
};

// The engine's shader folder: $PENUMBRA_SHADER_DIR; else, for an installed engine,
// share/penumbra/shaders found relative to the engine library at run time; else the
// source tree's shaders/ (build-tree runs: edits take effect without reinstalling).
std::filesystem::path engineShaderDir();

VkShaderStageFlagBits stageFromExtension(const std::filesystem::path& file);

} // namespace penumbra::gpu

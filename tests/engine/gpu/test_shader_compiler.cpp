#include "ScratchFolder.h"
#include "TestPaths.h"  // support/: the build tree's paths

#include "penumbra/core/Error.h"
#include "penumbra/gpu/ShaderCompiler.h"

#include <gtest/gtest.h>

#include <sys/stat.h>

#include <fstream>
#include <regex>

using namespace penumbra;
namespace fs = std::filesystem;

namespace {

const fs::path kData = penumbra::test::testDataDir() / "shaders";

gpu::ShaderCompiler compiler() { return gpu::ShaderCompiler({gpu::engineShaderDir(), kData}); }

std::string compileError(const fs::path& file)
{
    try {
        compiler().compile(file);
    } catch (const ShaderCompileError& e) {
        return e.what();
    }
    ADD_FAILURE() << file << " compiled but should not have";
    return {};
}

} // namespace

TEST(ShaderCompiler, CompilesWithEngineInclude)
{
    const std::vector<uint32_t> spirv = compiler().compile(kData / "ok.comp");
    ASSERT_GT(spirv.size(), 5u);
    EXPECT_EQ(spirv[0], 0x07230203u);  // SPIR-V magic
}

TEST(ShaderCompiler, CompilesEveryEngineShader)
{
    // Every shader shipped in shaders/ compiles (the shading pass needs its define).
    size_t count = 0;
    for (const auto& entry : fs::recursive_directory_iterator(gpu::engineShaderDir())) {
        // Shader stages only: *.glsl are included by them, and a generator script
        // (common/poisson_disk.py) lives beside its output.
        const std::string ext = entry.path().extension().string();
        if (!entry.is_regular_file() || (ext != ".vert" && ext != ".frag" && ext != ".comp")) continue;
        SCOPED_TRACE(entry.path().string());
        EXPECT_NO_THROW(compiler().compile(entry.path(), {{"LIGHT_COUNT", "8"}}));
        ++count;
    }
    EXPECT_GE(count, 3u);  // gbuffer.vert, gbuffer.frag, shading.comp; plugins test their own
}

TEST(ShaderCompiler, CompilesEveryPluginShader)
{
    // Every plugin's GLSL compiles with the search path a technique gets
    // (TechniqueSetup::shaders: the plugin's folder, then the engine's shaders/).
    size_t count = 0;
    for (const auto& plugin : fs::directory_iterator(penumbra::test::sourceDir() / "plugins")) {
        if (!plugin.is_directory()) continue;
        const gpu::ShaderCompiler pluginCompiler({plugin.path(), gpu::engineShaderDir()});
        for (const auto& entry : fs::recursive_directory_iterator(plugin.path())) {
            const std::string ext = entry.path().extension().string();
            if (!entry.is_regular_file() || ext == ".glsl") continue;
            if (ext != ".vert" && ext != ".frag" && ext != ".comp" && ext != ".geom" && ext != ".tesc" && ext != ".tese")
                continue;
            SCOPED_TRACE(entry.path().string());
            EXPECT_NO_THROW(pluginCompiler.compile(entry.path()));
            ++count;
        }
    }
    EXPECT_GE(count, 2u);  // plugins/example has one; the others more
}

TEST(ShaderCompiler, ErrorNamesFileAndLine)
{
    const std::string what = compileError(kData / "syntax_error.comp");
    EXPECT_NE(what.find("syntax_error.comp:6: error:"), std::string::npos) << what;
    EXPECT_NE(what.find("undefinedThing"), std::string::npos) << what;
}

TEST(ShaderCompiler, ErrorInIncludedFileNamesThatFile)
{
    const std::string what = compileError(kData / "includes_broken.comp");
    EXPECT_NE(what.find("broken_helper.glsl:4: error:"), std::string::npos) << what;
}

TEST(ShaderCompiler, MissingIncludeIsNamed)
{
    const std::string what = compileError(kData / "missing_include.comp");
    EXPECT_NE(what.find("missing_include.comp:2: error:"), std::string::npos) << what;
    EXPECT_NE(what.find("does_not_exist.glsl"), std::string::npos) << what;
}

TEST(ShaderCompiler, MissingFileIsNamed)
{
    const std::string what = compileError("nowhere/nothing.comp");
    EXPECT_NE(what.find("nothing.comp: shader file not found"), std::string::npos) << what;
}

// Shaders and their #includes are read as regular files of bounded size (issue 43): an
// include that is a FIFO (it blocked the read) or /proc/self/mem (unreadable) is an error
// at the #include line naming the file, never a hang.
TEST(ShaderCompiler, IncludesThatAreNotRegularFilesAreNamed)
{
    const fs::path dir = penumbra::test::makeScratchFolder("shader");
    ASSERT_EQ(::mkfifo((dir / "pipe.glsl").c_str(), 0600), 0);
    fs::create_symlink("/proc/self/mem", dir / "mem.glsl");
    for (const char* include : {"pipe.glsl", "mem.glsl"}) {
        SCOPED_TRACE(include);
        std::ofstream(dir / "main.comp") << "#version 460\n#include \"" << include << "\"\nlayout(local_size_x = 1) in;\nvoid main() {}\n";
        const std::string what = compileError(dir / "main.comp");
        EXPECT_NE(what.find("main.comp:2: error:"), std::string::npos) << what;
        EXPECT_NE(what.find(include), std::string::npos) << what;
        EXPECT_NE(what.find(std::string(include) == "pipe.glsl" ? "is a FIFO (named pipe)" : "cannot be read"), std::string::npos)
            << what;
    }
    // The shader itself: only a regular file is found.
    EXPECT_NE(compileError(dir / "pipe.glsl").find("shader file not found"), std::string::npos);
    fs::remove_all(dir);
}

TEST(ShaderCompiler, DefinesReachTheSource)
{
    const std::string src = "#version 460\nlayout(local_size_x = 1) in;\n#ifndef FLAG\n#error FLAG missing\n#endif\nvoid main() {}\n";
    EXPECT_THROW(compiler().compileSource(src, "inline.comp", VK_SHADER_STAGE_COMPUTE_BIT), ShaderCompileError);
    EXPECT_NO_THROW(compiler().compileSource(src, "inline.comp", VK_SHADER_STAGE_COMPUTE_BIT, {{"FLAG", "1"}}));
}

TEST(ShaderCompiler, UnknownExtensionIsRejected)
{
    EXPECT_THROW(gpu::stageFromExtension("shader.txt"), ShaderCompileError);
}

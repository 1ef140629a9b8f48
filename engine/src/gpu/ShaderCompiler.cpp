#include "penumbra/gpu/ShaderCompiler.h"

#include "penumbra/core/Digest.h"
#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"
#include "penumbra/io/ReadFile.h"

#include "core/BuildTree.h"
#include "core/LibraryBuildId.h"

#include <glslang/SPIRV/GlslangToSpv.h>
#include <glslang/Public/ResourceLimits.h>
#include <glslang/Public/ShaderLang.h>
#include <fmt/format.h>

#include <dlfcn.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <memory>
#include <optional>
#include <sstream>

namespace fs = std::filesystem;

namespace penumbra::gpu {
namespace {

// glslang keeps global state: initialise once per process, finalise at exit.
struct GlslangProcess {
    GlslangProcess() { glslang::InitializeProcess(); }
    ~GlslangProcess() { glslang::FinalizeProcess(); }
};

void ensureGlslang()
{
    static GlslangProcess process;
}

// A shader or an #include'd file: the shipped ones are at most a few tens of KB.
constexpr uint64_t kMaxShaderBytes = uint64_t(4) << 20;

std::string readText(const fs::path& path)
{
    try {
        return io::readRegularTextFile(path, kMaxShaderBytes, "a GLSL shader file");
    } catch (const io::FileReadError& e) {
        throw ShaderCompileError(fmt::format("{}: shader file {}", core::shortText(path.string()), e.reason()));
    }
}

EShLanguage toLanguage(VkShaderStageFlagBits stage)
{
    switch (stage) {
    case VK_SHADER_STAGE_VERTEX_BIT: return EShLangVertex;
    case VK_SHADER_STAGE_FRAGMENT_BIT: return EShLangFragment;
    case VK_SHADER_STAGE_COMPUTE_BIT: return EShLangCompute;
    case VK_SHADER_STAGE_GEOMETRY_BIT: return EShLangGeometry;
    case VK_SHADER_STAGE_TESSELLATION_CONTROL_BIT: return EShLangTessControl;
    case VK_SHADER_STAGE_TESSELLATION_EVALUATION_BIT: return EShLangTessEvaluation;
    default: throw ShaderCompileError("unsupported shader stage");
    }
}

// What one #include request resolves to: for #include "x" the including file's folder
// first, then (for both forms) the search path. The first file that exists is the answer,
// even when it cannot be read (a FIFO, /proc/self/mem): the inclusion then fails.
struct ResolvedInclude {
    std::string name;        // the file, canonical; empty when none was found or readable
    std::string text;
    std::string unreadable;  // why a file that exists could not be read, as a line
};

ResolvedInclude resolveInclude(bool local, const std::string& header, const std::string& includer,
                               const std::vector<fs::path>& searchPath)
{
    std::vector<fs::path> candidates;
    if (const fs::path dir = fs::path(includer).parent_path(); local && !dir.empty()) candidates.push_back(dir / header);
    for (const fs::path& dir : searchPath) candidates.push_back(dir / header);
    for (const fs::path& path : candidates) {
        std::error_code ec;
        if (!fs::exists(path, ec)) continue;
        try {
            std::string text = io::readRegularTextFile(path, kMaxShaderBytes, "a GLSL shader file");
            return {fs::weakly_canonical(path).string(), std::move(text), {}};
        } catch (const io::FileReadError& e) {
            return {{}, {}, fmt::format("\n{}: included shader file {}", core::shortText(path.string()), e.reason())};
        }
    }
    return {};  // glslang reports "cannot find include file" at the #include line
}

ShaderInclude recordOf(bool local, const std::string& header, const std::string& includer, const ResolvedInclude& resolved)
{
    return {local, header, includer, resolved.name, core::Digest128().text(resolved.text).finish()};
}

// Whether every #include a cached compile made still gets the same file with the same content.
bool includesUnchanged(const std::vector<ShaderInclude>& includes, const std::vector<fs::path>& searchPath)
{
    return std::all_of(includes.begin(), includes.end(), [&](const ShaderInclude& i) {
        return recordOf(i.local, i.header, i.includer, resolveInclude(i.local, i.header, i.includer, searchPath)) == i;
    });
}

// Answers glslang's #include requests (resolveInclude) and records each with its answer,
// for the cache. glslang asks includeSystem itself when includeLocal finds nothing.
class RecordingIncluder : public glslang::TShader::Includer {
public:
    explicit RecordingIncluder(const std::vector<fs::path>& searchPath) : searchPath_(searchPath) {}

    IncludeResult* includeLocal(const char* header, const char* includer, size_t) override
    {
        return include(true, header, includer);
    }
    IncludeResult* includeSystem(const char* header, const char* includer, size_t) override
    {
        return include(false, header, includer);
    }

    void releaseInclude(IncludeResult* result) override
    {
        if (result) {
            delete static_cast<std::string*>(result->userData);
            delete result;
        }
    }

    std::vector<ShaderInclude> takeIncludes() { return std::move(includes_); }
    // Why #included files that exist could not be read (a FIFO, /proc/self/mem), a line
    // each: glslang reports such an #include without the reason.
    const std::string& unreadable() const { return unreadable_; }

private:
    IncludeResult* include(bool local, const char* header, const char* includer)
    {
        ResolvedInclude resolved = resolveInclude(local, header, includer, searchPath_);
        includes_.push_back(recordOf(local, header, includer, resolved));
        unreadable_ += resolved.unreadable;
        if (resolved.name.empty()) return resolved.unreadable.empty() ? nullptr : new IncludeResult("", "", 0, nullptr);
        auto text = std::make_unique<std::string>(std::move(resolved.text));
        const std::string* data = text.get();
        return new IncludeResult(resolved.name, data->data(), data->size(), text.release());
    }

    const std::vector<fs::path>& searchPath_;
    std::vector<ShaderInclude> includes_;
    std::string unreadable_;
};

// glslang writes "ERROR: <name>:<line>: <message>"; we rewrite each diagnostic as the
// compiler-style "<path>:<line>: error: <message>" that editors and terminals link.
// (Parsed by hand: GCC 12's <regex> trips -Wmaybe-uninitialized under the sanitizers.)
std::string formatDiagnostic(const std::string& line, const std::string& mainName)
{
    std::string severity;
    std::string rest;
    for (const char* prefix : {"ERROR: ", "WARNING: "}) {
        if (line.rfind(prefix, 0) == 0) {
            severity = prefix[0] == 'E' ? "error" : "warning";
            rest = line.substr(std::char_traits<char>::length(prefix));
        }
    }
    if (severity.empty()) return line.empty() ? std::string() : mainName + ": " + line;
    // "<name>:<line>: <message>", where <name> may itself contain ':' (never "...:<digits>: ").
    for (size_t colon = rest.find(':'); colon != std::string::npos; colon = rest.find(':', colon + 1)) {
        size_t end = colon + 1;
        while (end < rest.size() && std::isdigit(static_cast<unsigned char>(rest[end]))) ++end;
        if (end > colon + 1 && rest.compare(end, 2, ": ") == 0) {
            std::string file = rest.substr(0, colon);
            if (file.empty() || file == "0") file = mainName;
            return file + ":" + rest.substr(colon + 1, end - colon - 1) + ": " + severity + ": " + rest.substr(end + 2);
        }
    }
    return mainName + ": " + severity + ": " + rest;
}

std::string formatLog(const std::string& log, const std::string& mainName)
{
    std::ostringstream out;
    std::istringstream in(log);
    std::string line;
    while (std::getline(in, line)) {
        if (line.find("compilation errors") != std::string::npos) continue;  // glslang's summary line
        const std::string formatted = formatDiagnostic(line, mainName);
        if (!formatted.empty()) out << formatted << '\n';
    }
    return out.str();
}

// An installed engine's GLSL: <folder of this library>/core::shaderDirFromLibrary()
// (../share/penumbra/shaders), found at run time so that the install prefix can move.
// Empty when that folder does not exist (a build-tree library).
fs::path installedShaderDir()
{
    Dl_info self{};
    if (dladdr(reinterpret_cast<const void*>(&engineShaderDir), &self) == 0 || self.dli_fname == nullptr) return {};
    std::error_code ec;
    const fs::path dir = fs::weakly_canonical(fs::path(self.dli_fname).parent_path() / core::shaderDirFromLibrary(), ec);
    return !ec && fs::is_directory(dir, ec) ? dir : fs::path();
}

// Every option a compile runs with, in one place: the cache key hashes them all.
struct CompileOptions {
    int inputVersion = 100;  // Vulkan GLSL (GL_KHR_vulkan_glsl) version 100
    glslang::EShTargetClientVersion client = glslang::EShTargetVulkan_1_3;
    glslang::EShTargetLanguageVersion spirv = glslang::EShTargetSpv_1_6;
    int defaultVersion = 460;  // for a shader without #version
    EShMessages messages = static_cast<EShMessages>(EShMsgSpvRules | EShMsgVulkanRules);
    bool debugInfo = false;
};
constexpr CompileOptions kOptions;

// Everything a compile reads besides its #includes (ShaderCache.h): the engine build (its
// glslang and this code), glslang's version, the options and resource limits, the stage,
// and the shader's name, defines and source.
ShaderKey shaderKey(const std::string& source, const std::string& name, EShLanguage language, const std::string& preamble)
{
    core::Digest128 d;
    d.value(ShaderCache::kFormatVersion).text(core::engineBuildId());
    const glslang::Version version = glslang::GetVersion();
    d.value(version.major).value(version.minor).value(version.patch).text(version.flavor);
    d.text(glslang::GetGlslVersionString()).value(glslang::GetKhronosToolId()).value(glslang::GetSpirvGeneratorVersion());
    d.value(kOptions.inputVersion).value(kOptions.client).value(kOptions.spirv).value(kOptions.defaultVersion);
    d.value(kOptions.messages).value(kOptions.debugInfo).value(*GetDefaultResources());
    d.value(language).text(name).text(preamble).text(source);
    return d.finish();
}

std::string preambleOf(const std::vector<ShaderDefine>& defines)
{
    std::string preamble = "#extension GL_GOOGLE_include_directive : require\n";
    for (const ShaderDefine& d : defines) preamble += fmt::format("#define {} {}\n", d.name, d.value);
    return preamble;
}

// glslang's run: throws ShaderCompileError with the formatted diagnostics.
std::vector<uint32_t> compileWithGlslang(const std::string& source, const std::string& name, EShLanguage language,
                                         const std::string& preamble, RecordingIncluder& includer)
{
    ensureGlslang();
    glslang::TShader shader(language);
    const char* text = source.c_str();
    const int length = static_cast<int>(source.size());
    const char* names = name.c_str();
    shader.setStringsWithLengthsAndNames(&text, &length, &names, 1);
    shader.setPreamble(preamble.c_str());
    shader.setEnvInput(glslang::EShSourceGlsl, language, glslang::EShClientVulkan, kOptions.inputVersion);
    shader.setEnvClient(glslang::EShClientVulkan, kOptions.client);
    shader.setEnvTarget(glslang::EShTargetSpv, kOptions.spirv);

    if (!shader.parse(GetDefaultResources(), kOptions.defaultVersion, false, kOptions.messages, includer)) {
        throw ShaderCompileError(formatLog(std::string(shader.getInfoLog()) + shader.getInfoDebugLog(), name) +
                                 includer.unreadable());
    }
    glslang::TProgram program;
    program.addShader(&shader);
    if (!program.link(kOptions.messages)) {
        throw ShaderCompileError(formatLog(std::string(program.getInfoLog()) + program.getInfoDebugLog(), name));
    }
    std::vector<uint32_t> spirv;
    glslang::SpvOptions options;
    options.generateDebugInfo = kOptions.debugInfo;
    glslang::GlslangToSpv(*program.getIntermediate(language), spirv, &options);
    return spirv;
}

} // namespace

VkShaderStageFlagBits stageFromExtension(const fs::path& file)
{
    const std::string ext = file.extension().string();
    if (ext == ".vert") return VK_SHADER_STAGE_VERTEX_BIT;
    if (ext == ".frag") return VK_SHADER_STAGE_FRAGMENT_BIT;
    if (ext == ".comp") return VK_SHADER_STAGE_COMPUTE_BIT;
    if (ext == ".geom") return VK_SHADER_STAGE_GEOMETRY_BIT;
    if (ext == ".tesc") return VK_SHADER_STAGE_TESSELLATION_CONTROL_BIT;
    if (ext == ".tese") return VK_SHADER_STAGE_TESSELLATION_EVALUATION_BIT;
    throw ShaderCompileError(fmt::format("{}: unknown shader stage for extension '{}' "
                                         "(expected .vert .frag .comp .geom .tesc .tese)",
                                         file.string(), ext));
}

fs::path engineShaderDir()
{
    if (const char* env = std::getenv("PENUMBRA_SHADER_DIR"); env && *env) {
        return env;
    }
    // An installed engine reads the shaders installed with it, never a source tree that
    // may still exist on the build machine (and may be newer or older than the library).
    if (fs::path installed = installedShaderDir(); !installed.empty()) {
        return installed;
    }
    return core::buildTreeShaderDir();
}

ShaderCompiler::ShaderCompiler(std::vector<fs::path> searchPath, ShaderCache& cache)
    : searchPath_(std::move(searchPath)), cache_(&cache)
{
}

fs::path ShaderCompiler::resolve(const fs::path& file) const
{
    std::error_code ec;
    if (file.is_absolute()) {
        if (fs::is_regular_file(file, ec)) return file;
    } else {
        for (const fs::path& dir : searchPath_) {
            if (fs::is_regular_file(dir / file, ec)) return fs::weakly_canonical(dir / file);
        }
    }
    std::string dirs;
    for (const fs::path& dir : searchPath_) dirs += (dirs.empty() ? "" : ", ") + dir.string();
    throw ShaderCompileError(fmt::format("{}: shader file not found (searched: {})", file.string(), dirs));
}

std::vector<uint32_t> ShaderCompiler::compile(const fs::path& file, const std::vector<ShaderDefine>& defines) const
{
    const fs::path path = resolve(file);
    return compileSource(readText(path), path, stageFromExtension(path), defines);
}

std::string ShaderCompiler::preprocess(const std::string& source, const fs::path& virtualPath,
                                       VkShaderStageFlagBits stage, const std::vector<ShaderDefine>& defines) const
{
    ensureGlslang();
    const std::string name = virtualPath.string();
    const std::string preamble = preambleOf(defines);
    glslang::TShader shader(toLanguage(stage));
    const char* text = source.c_str();
    const int length = static_cast<int>(source.size());
    const char* names = name.c_str();
    shader.setStringsWithLengthsAndNames(&text, &length, &names, 1);
    shader.setPreamble(preamble.c_str());
    shader.setEnvInput(glslang::EShSourceGlsl, toLanguage(stage), glslang::EShClientVulkan, kOptions.inputVersion);
    shader.setEnvClient(glslang::EShClientVulkan, kOptions.client);
    shader.setEnvTarget(glslang::EShTargetSpv, kOptions.spirv);
    RecordingIncluder includer(searchPath_);
    std::string out;
    if (!shader.preprocess(GetDefaultResources(), kOptions.defaultVersion, ENoProfile, false, false, kOptions.messages,
                           &out, includer)) {
        throw ShaderCompileError(formatLog(std::string(shader.getInfoLog()) + shader.getInfoDebugLog(), name) +
                                 includer.unreadable());
    }
    return out;
}

std::vector<uint32_t> ShaderCompiler::compileSource(const std::string& source, const fs::path& virtualPath,
                                                    VkShaderStageFlagBits stage,
                                                    const std::vector<ShaderDefine>& defines) const
{
    const EShLanguage language = toLanguage(stage);
    const std::string name = virtualPath.string();
    const std::string preamble = preambleOf(defines);
    const ShaderKey key = shaderKey(source, name, language, preamble);
    const auto isCurrent = [&](const std::vector<ShaderInclude>& includes) { return includesUnchanged(includes, searchPath_); };
    if (std::optional<std::vector<uint32_t>> cached = cache_->find(key, isCurrent)) return std::move(*cached);

    RecordingIncluder includer(searchPath_);
    std::vector<uint32_t> spirv = compileWithGlslang(source, name, language, preamble, includer);
    cache_->store(key, includer.takeIncludes(), spirv);
    return spirv;
}

} // namespace penumbra::gpu

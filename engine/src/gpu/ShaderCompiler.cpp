#include "penumbra/gpu/ShaderCompiler.h"

#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"
#include "penumbra/io/ReadFile.h"

#include "core/BuildTree.h"

#include <glslang/SPIRV/GlslangToSpv.h>
#include <glslang/Public/ResourceLimits.h>
#include <glslang/Public/ShaderLang.h>
#include <fmt/format.h>

#include <dlfcn.h>

#include <cstdlib>
#include <memory>
#include <mutex>
#include <cctype>
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

// Resolves #include: the including file's folder first, then the search path.
class Includer : public glslang::TShader::Includer {
public:
    explicit Includer(const std::vector<fs::path>& searchPath) : searchPath_(searchPath) {}

    IncludeResult* includeLocal(const char* header, const char* includer, size_t depth) override
    {
        fs::path dir = fs::path(includer).parent_path();
        if (!dir.empty()) {
            if (IncludeResult* r = tryOpen(dir / header)) return r;
        }
        return includeSystem(header, includer, depth);
    }

    IncludeResult* includeSystem(const char* header, const char*, size_t) override
    {
        for (const fs::path& dir : searchPath_) {
            if (IncludeResult* r = tryOpen(dir / header)) return r;
        }
        return nullptr;  // glslang reports "cannot find include file" at the #include line
    }

    void releaseInclude(IncludeResult* result) override
    {
        if (result) {
            delete static_cast<std::string*>(result->userData);
            delete result;
        }
    }

    // Why #included files that exist could not be read (a FIFO, /proc/self/mem), a line
    // each: glslang reports such an #include without the reason.
    const std::string& unreadable() const { return unreadable_; }

private:
    IncludeResult* tryOpen(const fs::path& path)
    {
        std::error_code ec;
        if (!fs::exists(path, ec)) return nullptr;  // the next folder of the search path
        auto text = std::make_unique<std::string>();
        try {
            *text = io::readRegularTextFile(path, kMaxShaderBytes, "a GLSL shader file");
        } catch (const io::FileReadError& e) {
            unreadable_ += fmt::format("\n{}: included shader file {}", core::shortText(path.string()), e.reason());
            return new IncludeResult("", "", 0, nullptr);  // a failed inclusion
        }
        const std::string* data = text.get();
        return new IncludeResult(fs::weakly_canonical(path).string(), data->data(), data->size(), text.release());
    }

    const std::vector<fs::path>& searchPath_;
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

ShaderCompiler::ShaderCompiler(std::vector<fs::path> searchPath) : searchPath_(std::move(searchPath)) {}

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

std::vector<uint32_t> ShaderCompiler::compileSource(const std::string& source, const fs::path& virtualPath,
                                                    VkShaderStageFlagBits stage,
                                                    const std::vector<ShaderDefine>& defines) const
{
    ensureGlslang();
    const EShLanguage language = toLanguage(stage);
    glslang::TShader shader(language);
    const std::string name = virtualPath.string();
    const char* text = source.c_str();
    const int length = static_cast<int>(source.size());
    const char* names = name.c_str();
    shader.setStringsWithLengthsAndNames(&text, &length, &names, 1);

    std::string preamble = "#extension GL_GOOGLE_include_directive : require\n";
    for (const ShaderDefine& d : defines) {
        preamble += fmt::format("#define {} {}\n", d.name, d.value);
    }
    shader.setPreamble(preamble.c_str());
    shader.setEnvInput(glslang::EShSourceGlsl, language, glslang::EShClientVulkan, 100);
    shader.setEnvClient(glslang::EShClientVulkan, glslang::EShTargetVulkan_1_3);
    shader.setEnvTarget(glslang::EShTargetSpv, glslang::EShTargetSpv_1_6);

    Includer includer(searchPath_);
    const auto messages = static_cast<EShMessages>(EShMsgSpvRules | EShMsgVulkanRules);
    if (!shader.parse(GetDefaultResources(), 460, false, messages, includer)) {
        throw ShaderCompileError(formatLog(std::string(shader.getInfoLog()) + shader.getInfoDebugLog(), name) +
                                 includer.unreadable());
    }
    glslang::TProgram program;
    program.addShader(&shader);
    if (!program.link(messages)) {
        throw ShaderCompileError(formatLog(std::string(program.getInfoLog()) + program.getInfoDebugLog(), name));
    }
    std::vector<uint32_t> spirv;
    glslang::SpvOptions options;
    options.generateDebugInfo = false;
    glslang::GlslangToSpv(*program.getIntermediate(language), spirv, &options);
    return spirv;
}

} // namespace penumbra::gpu

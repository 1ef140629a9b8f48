// The plugin module: loading from the search path, one error kind (and a message that
// names plugin, file and what to do) per way a plugin can fail, the registry still
// working after each failure, reflected parameters from spec to config to the plugin's
// own view, and --set overrides. The test plugins are in tests/fixtures/plugins/.
#include "ErrorText.h"
#include "ScratchFolder.h"
#include "TestContext.h"
#include "TestPaths.h"  // support/: the build tree's paths

#include "penumbra/config/Config.h"
#include "penumbra/config/Overrides.h"
#include "penumbra/graph/GraphExecutor.h"
#include "penumbra/graph/RenderGraph.h"
#include "penumbra/plugin/ComputePipeline.h"
#include "penumbra/plugin/DebugViews.h"
#include "penumbra/plugin/LibraryFile.h"
#include "penumbra/plugin/Params.h"
#include "penumbra/plugin/PluginRegistry.h"
#include "penumbra/render/Casters.h"
#include "penumbra/render/SceneGpu.h"
#include "penumbra/scene/Generators.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <dlfcn.h>
#include <link.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <map>
#include <optional>

namespace fs = std::filesystem;
using nlohmann::json;
using namespace penumbra;
using plugin::ParamSpec;
using plugin::ParamType;
using plugin::ParamValues;
using plugin::PluginError;
using plugin::PluginErrorKind;
using plugin::PluginRegistry;

namespace {

const fs::path kPlugins = penumbra::test::testPluginDir();
const fs::path kShadowedPlugins = penumbra::test::shadowedTestPluginDir();

::testing::AssertionResult contains(const std::string& text, const std::string& part)
{
    if (text.find(part) != std::string::npos) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << "\"" << part << "\" not in:\n" << text;
}

template <typename Fn>
std::string configErrorOf(Fn&& fn)
{
    try {
        fn();
    } catch (const ConfigError& e) {
        return e.what();
    }
    ADD_FAILURE() << "no ConfigError";
    return {};
}

// Sets an environment variable for one scope and puts the old value back.
class ScopedEnv {
public:
    ScopedEnv(const char* name, const std::string& value) : name_(name)
    {
        if (const char* old = std::getenv(name)) old_ = old;
        setenv(name, value.c_str(), 1);
    }
    ~ScopedEnv()
    {
        if (old_) setenv(name_, old_->c_str(), 1);
        else unsetenv(name_);
    }

private:
    const char* name_;
    std::optional<std::string> old_;
};

// The registry as the engine builds it, with the test plugins' folders on
// PENUMBRA_PLUGIN_PATH (the build tree's own plugins may follow).
class Registry : public ::testing::Test {
protected:
    Registry() : env_("PENUMBRA_PLUGIN_PATH", kPlugins.string() + ":" + kShadowedPlugins.string()) {}

    PluginError loadError(const std::string& name, PluginErrorKind kind)
    {
        try {
            registry.load(name);
        } catch (const PluginError& e) {
            EXPECT_EQ(plugin::pluginErrorKindName(e.kind()), std::string(plugin::pluginErrorKindName(kind))) << e.what();
            return e;
        }
        ADD_FAILURE() << "plugin '" << name << "' loaded";
        return PluginError(kind, "");
    }

    // After any failure, the registry still loads and lists the good plugin.
    void expectStillWorks()
    {
        const plugin::LoadedPlugin& good = registry.load("testgood");
        EXPECT_EQ(good.name(), "testgood");
        EXPECT_EQ(good.info->paramCount, 5u);
    }

    ScopedEnv env_;
    PluginRegistry registry;
};

} // namespace

// --- parameter values --------------------------------------------------------------

namespace {

const char* const kModes[] = {"clear", "unshadowed"};
const ParamSpec kSpecs[] = {
    {"enabled", ParamType::Bool, 1, 0, 1, "", "on or off"},
    {"kernel", ParamType::Int, 5, 1, 15, "texels", "kernel width"},
    {"fill", ParamType::Float, 0.5, 0, 1, "", "fill value"},
    {"mode", ParamType::Enum, 1, 0, 0, "", "what to do", kModes, std::size(kModes)},
};

ParamValues specValues() { return ParamValues("t", kSpecs, std::size(kSpecs)); }

} // namespace

TEST(ParamValues, DefaultsComeFromTheSpecs)
{
    const ParamValues v = specValues();
    EXPECT_TRUE(v.getBool("enabled"));
    EXPECT_EQ(v.getInt("kernel"), 5);
    EXPECT_FLOAT_EQ(v.getFloat("fill"), 0.5f);
    EXPECT_EQ(v.getEnum("mode"), "unshadowed");
    EXPECT_EQ(v.getEnumIndex("mode"), 1u);
    EXPECT_EQ(v.toJson(), json::parse(R"({"enabled": true, "kernel": 5, "fill": 0.5, "mode": "unshadowed"})"));
}

TEST(ParamValues, SetAcceptsEveryTypeInRange)
{
    ParamValues v = specValues();
    v.set("enabled", false, "w");
    v.set("kernel", 15, "w");
    v.set("fill", 0, "w");  // an integer where a float is expected is fine
    v.set("mode", "clear", "w");
    EXPECT_EQ(v.toJson(), json::parse(R"({"enabled": false, "kernel": 15, "fill": 0.0, "mode": "clear"})"));
    v.set("kernel", 7.0, "w");  // integral, written as a float
    EXPECT_EQ(v.getInt("kernel"), 7);
    v.set("kernel", 1, "w");  // the range is inclusive
    v.set("fill", 1.0, "w");
    EXPECT_EQ(v.getInt("kernel"), 1);
}

TEST(ParamValues, SetRejectsWrongTypesRangesAndChoicesNamingWhere)
{
    const double inf = std::numeric_limits<double>::infinity();
    const std::string where = "a.json: /lights/0/shadow/kernel";
    const std::vector<std::pair<std::pair<std::string, json>, std::string>> cases = {
        {{"kernel", 4.5}, "a.json: /lights/0/shadow/kernel: must be an integer in [1, 15] (plugin t, parameter kernel: "
                          "kernel width), got 4.5"},
        {{"kernel", 16}, "must be an integer in [1, 15] (plugin t, parameter kernel: kernel width), got 16"},
        {{"kernel", 0}, "must be an integer in [1, 15]"},
        {{"kernel", "5"}, "must be an integer in [1, 15] (plugin t, parameter kernel: kernel width), got \"5\""},
        {{"kernel", true}, "got true"},
        {{"kernel", json::array({5})}, "got [5]"},
        {{"fill", 1.5}, "must be a number in [0, 1] (plugin t, parameter fill: fill value), got 1.5"},
        {{"fill", -0.001}, "must be a number in [0, 1]"},
        {{"fill", std::nan("")}, "got nan"},
        {{"fill", inf}, "got inf"},
        {{"fill", -inf}, "got -inf"},
        {{"fill", nullptr}, "got null"},
        {{"enabled", 1}, "must be true or false (plugin t, parameter enabled: on or off), got 1"},
        {{"enabled", "true"}, "must be true or false"},
        {{"mode", "claer"}, "must be one of \"clear\", \"unshadowed\" (plugin t, parameter mode: what to do), got "
                            "\"claer\"; did you mean \"clear\"?"},
        {{"mode", 0}, "must be one of \"clear\", \"unshadowed\""},
        {{"mode", "CLEAR"}, "got \"CLEAR\""},
    };
    for (const auto& [input, expected] : cases) {
        ParamValues v = specValues();
        const json before = v.toJson();
        const std::string message = configErrorOf([&] { v.set(input.first, input.second, where); });
        EXPECT_TRUE(contains(message, where + ": ")) << input.first;
        EXPECT_TRUE(contains(message, expected)) << input.first << " = " << input.second.dump();
        EXPECT_EQ(v.toJson(), before) << "a refused value must not change anything";
    }
}

TEST(ParamValues, UnknownNameSuggestsTheClosest)
{
    ParamValues v = specValues();
    EXPECT_TRUE(contains(configErrorOf([&] { v.set("kernal", 3, "b.json: /lights/1/shadow/kernal"); }),
                         "b.json: /lights/1/shadow/kernal: plugin 't' has no parameter 'kernal'; did you mean 'kernel'? "
                         "(it has: enabled, kernel, fill, mode)"));
    EXPECT_TRUE(contains(configErrorOf([&] { v.set("resolution", 3, "--set t.resolution"); }),
                         "--set t.resolution: plugin 't' has no parameter 'resolution' (it has: enabled, kernel, fill, mode)"));
    ParamValues none("empty", nullptr, 0);
    EXPECT_TRUE(contains(configErrorOf([&] { none.set("x", 1, "w"); }), "plugin 'empty' has no parameter 'x' (it has none)"));
}

TEST(ParamValues, GettersThrowForAnUnknownNameOrAnotherType)
{
    const ParamValues v = specValues();
    auto errorOf = [](auto&& fn) -> std::string {
        try {
            fn();
        } catch (const ConfigError&) {
            return "a ConfigError: but this is the plugin's mistake, not the config's";
        } catch (const Error& e) {
            return e.what();
        }
        return "no error";
    };
    EXPECT_EQ(errorOf([&] { v.getFloat("kernel"); }), "plugin 't': parameter 'kernel' is of type int, read as float");
    EXPECT_EQ(errorOf([&] { v.getBool("mode"); }), "plugin 't': parameter 'mode' is of type enum, read as bool");
    EXPECT_EQ(errorOf([&] { v.getEnum("fill"); }), "plugin 't': parameter 'fill' is of type float, read as enum");
    EXPECT_TRUE(contains(errorOf([&] { v.getInt("radius"); }), "plugin 't': no parameter 'radius' is declared"));
}

TEST(ParamValues, SpecToJsonDescribesEveryField)
{
    EXPECT_EQ(plugin::specToJson(kSpecs[1]), json::parse(R"({"name": "kernel", "type": "int", "default": 5, "min": 1,
        "max": 15, "unit": "texels", "doc": "kernel width"})"));
    EXPECT_EQ(plugin::specToJson(kSpecs[2]), json::parse(R"({"name": "fill", "type": "float", "default": 0.5, "min": 0.0,
        "max": 1.0, "unit": "", "doc": "fill value"})"));
    EXPECT_EQ(plugin::specToJson(kSpecs[0]), json::parse(R"({"name": "enabled", "type": "bool", "default": true,
        "unit": "", "doc": "on or off"})"));
    EXPECT_EQ(plugin::specToJson(kSpecs[3]), json::parse(R"({"name": "mode", "type": "enum", "default": "unshadowed",
        "choices": ["clear", "unshadowed"], "unit": "", "doc": "what to do"})"));
}

// ParamSpec::odd: a box of taps centred on a texel (plugin::oddKernelParam) refuses even
// values where they are set, and says so in its JSON.
TEST(ParamValues, AnOddOnlyIntRefusesEvenValuesNamingWhere)
{
    const ParamSpec specs[] = {{"taps", ParamType::Int, 3, 1, 7, "texels", "box side", nullptr, 0, true}};
    ParamValues v("t", specs, 1);
    v.set("taps", 5, "a.json: /lights/0/shadow/taps");
    EXPECT_EQ(v.getInt("taps"), 5);
    try {
        v.set("taps", 4, "--set t.taps");
        ADD_FAILURE() << "4 was accepted";
    } catch (const ConfigError& e) {
        EXPECT_TRUE(contains(e.what(), "--set t.taps: must be an odd integer in [1, 7] (plugin t, parameter taps"))
            << e.what();
    }
    EXPECT_EQ(v.getInt("taps"), 5);
    EXPECT_EQ(plugin::specToJson(specs[0]), json::parse(R"({"name": "taps", "type": "int", "default": 3, "min": 1,
        "max": 7, "unit": "texels", "doc": "box side", "odd": true})"));
}

// --- what a plugin's entry returns ---------------------------------------------------

namespace {

plugin::Technique* createNothing(const plugin::TechniqueSetup&) { return nullptr; }

std::string infoErrorOf(const PenumbraPluginInfo& info)
{
    try {
        plugin::checkPluginInfo(info, "/p/penumbra-x.so");
    } catch (const PluginError& e) {
        EXPECT_EQ(e.kind(), PluginErrorKind::InvalidInfo);
        EXPECT_EQ(e.file(), "/p/penumbra-x.so");
        return e.what();
    }
    return "accepted";
}

} // namespace

TEST(PluginInfo, AcceptsAWellFormedInfo)
{
    const PenumbraPluginInfo info{PENUMBRA_PLUGIN_ABI_VERSION, "x", "1", "s", kSpecs, std::size(kSpecs), &createNothing,
                                  nullptr};
    EXPECT_EQ(infoErrorOf(info), "accepted");
}

TEST(PluginInfo, RejectsEachMalformedField)
{
    const PenumbraPluginInfo good{PENUMBRA_PLUGIN_ABI_VERSION, "x", "1", "s", nullptr, 0, &createNothing, nullptr};
    auto withInfo = [&](auto change) {
        PenumbraPluginInfo info = good;
        change(info);
        return infoErrorOf(info);
    };
    EXPECT_TRUE(contains(withInfo([](auto& i) { i.name = nullptr; }), "/p/penumbra-x.so: malformed plugin info: name is null"));
    EXPECT_TRUE(contains(withInfo([](auto& i) { i.name = "Has Space"; }), "name 'Has Space' is not a plugin name"));
    EXPECT_TRUE(contains(withInfo([](auto& i) { i.version = nullptr; }), "plugin 'x' (/p/penumbra-x.so): malformed plugin "
                                                                          "info: version is null"));
    EXPECT_TRUE(contains(withInfo([](auto& i) { i.summary = nullptr; }), "summary is null"));
    EXPECT_TRUE(contains(withInfo([](auto& i) { i.create = nullptr; }), "create (the technique factory) is null"));
    EXPECT_TRUE(contains(withInfo([](auto& i) { i.paramCount = 2; }), "params is null but paramCount is 2"));
    EXPECT_TRUE(contains(withInfo([](auto& i) { i.name = ""; }), "fix what the plugin's penumbra_plugin_entry returns"));
}

TEST(PluginInfo, RejectsEachMalformedParamSpec)
{
    const char* const twice[] = {"a", "a"};
    const char* const withNull[] = {"a", nullptr};
    const double nan = std::nan("");
    const std::vector<std::pair<std::vector<ParamSpec>, std::string>> cases = {
        {{{nullptr, ParamType::Bool, 0, 0, 1, "", "d"}}, "params[0]: name is null"},
        {{{"Kernel", ParamType::Int, 1, 0, 2, "", "d"}}, "params[0] 'Kernel': not a snake_case name"},
        {{{"2x", ParamType::Int, 1, 0, 2, "", "d"}}, "params[0] '2x': not a snake_case name"},
        {{{"required", ParamType::Bool, 0, 0, 1, "", "d"}}, "params[0] 'required': the name is reserved"},
        {{{"technique", ParamType::Bool, 0, 0, 1, "", "d"}}, "the name is reserved by the config's \"shadow\" object"},
        {{{"a", ParamType::Bool, 0, 0, 1, "", "d"}, {"a", ParamType::Int, 1, 0, 2, "", "d"}},
         "params[1] 'a': the name is declared twice"},
        {{{"a", ParamType::Int, 1, 0, 2, nullptr, "d"}}, "params[0] 'a': unit is null (use \"\" when unitless)"},
        {{{"a", ParamType::Int, 1, 0, 2, "", nullptr}}, "params[0] 'a': doc is null"},
        {{{"a", ParamType(7), 1, 0, 2, "", "d"}}, "params[0] 'a': unknown type 7"},
        {{{"a", ParamType::Bool, 2, 0, 1, "", "d"}}, "a bool's default must be 0 or 1, got 2"},
        {{{"a", ParamType::Int, 20, 1, 15, "", "d"}}, "needs min <= default <= max, got min 1, default 20, max 15"},
        {{{"a", ParamType::Float, 0.5, 1, 0, "", "d"}}, "needs min <= default <= max"},
        {{{"a", ParamType::Float, nan, 0, 1, "", "d"}}, "params[0] 'a': the default is not finite"},
        {{{"a", ParamType::Float, 0, 0, std::numeric_limits<double>::infinity(), "", "d"}}, "max is not finite"},
        {{{"a", ParamType::Int, 1.5, 0, 2, "", "d"}}, "an int's min, default and max must be integers within int, got 1.5"},
        {{{"a", ParamType::Int, 0, 0, 1e10, "", "d"}}, "must be integers within int, got 10000000000"},
        {{{"a", ParamType::Enum, 0, 0, 0, "", "d"}}, "an enum needs choices"},
        {{{"a", ParamType::Enum, 0, 0, 0, "", "d", twice, 2}}, "choice 'a' is listed twice"},
        {{{"a", ParamType::Enum, 0, 0, 0, "", "d", withNull, 2}}, "choice 1 is null or empty"},
        {{{"a", ParamType::Enum, 2, 0, 0, "", "d", twice, 1}}, "an enum's default is a choice index in [0, 1), got 2"},
        {{{"a", ParamType::Int, 3, 2, 7, "", "d", nullptr, 0, true}},
         "params[0] 'a': an odd-only int's min, default and max must be odd, got 2"},
        {{{"a", ParamType::Float, 1, 1, 7, "", "d", nullptr, 0, true}}, "params[0] 'a': only an int can be odd-only"},
    };
    for (const auto& [specs, expected] : cases) {
        const PenumbraPluginInfo info{PENUMBRA_PLUGIN_ABI_VERSION, "x", "1", "s", specs.data(), uint32_t(specs.size()),
                                      &createNothing, nullptr};
        EXPECT_TRUE(contains(infoErrorOf(info), expected));
    }
}

// --- loading -------------------------------------------------------------------------

TEST_F(Registry, LoadsTheGoodPlugin)
{
    const plugin::LoadedPlugin& good = registry.load("testgood");
    EXPECT_EQ(good.name(), "testgood");
    // What PENUMBRA_DEFINE_PLUGIN (tests/fixtures/plugins/testgood.cpp) put in the info.
    EXPECT_STREQ(good.info->version, "1.2.0");
    EXPECT_STREQ(good.info->summary, "test plugin: clears V_l to a constant");
    EXPECT_EQ(good.info->paramCount, 5u);
    EXPECT_NE(good.info->create, nullptr);
    EXPECT_EQ(good.info->abiVersion, PENUMBRA_PLUGIN_ABI_VERSION);
    EXPECT_EQ(good.file, kPlugins / "penumbra-testgood.so");
    // Its declared shader folder exists, so it is used as is.
    EXPECT_EQ(good.shaderDir, penumbra::test::testPluginSourceDir());
    EXPECT_EQ(&registry.load("testgood"), &good) << "a second load returns the plugin loaded before";
    EXPECT_EQ(good.defaultParams().toJson(),
              json::parse(R"({"enabled": true, "kernel": 5, "fill": 0.5, "bias": 0.01, "mode": "clear"})"));
}

TEST_F(Registry, ShaderFolderFallsBackBesideThePluginFile)
{
    // penumbra-throws.so declares no shader folder.
    EXPECT_EQ(registry.load("throws").shaderDir, kPlugins / "throws");
}

TEST_F(Registry, FileMissingListsTheFoldersSearched)
{
    const PluginError e = loadError("testgod", PluginErrorKind::FileMissing);
    EXPECT_TRUE(contains(e.what(), "plugin 'testgod': no file penumbra-testgod.so on the plugin search path"));
    EXPECT_TRUE(contains(e.what(), "searched: " + kPlugins.string() + ", " + kShadowedPlugins.string()));
    EXPECT_TRUE(contains(e.what(), "did you mean 'testgood'?"));
    EXPECT_TRUE(contains(e.what(), "add the folder that holds it to PENUMBRA_PLUGIN_PATH"));
    EXPECT_TRUE(contains(e.what(), "PENUMBRA_PLUGIN_PATH=" + kPlugins.string()));
    EXPECT_TRUE(e.file().empty());
    expectStillWorks();
}

TEST_F(Registry, APathIsNotAPluginName)
{
    for (const char* name : {"../testgood", "", "Test Good", "a/b"}) {
        const PluginError e = loadError(name, PluginErrorKind::FileMissing);
        EXPECT_TRUE(contains(e.what(), "is not a plugin name"));
    }
    expectStillWorks();
}

TEST_F(Registry, GarbageFileIsNotALibrary)
{
    const PluginError e = loadError("garbage", PluginErrorKind::NotALibrary);
    EXPECT_TRUE(contains(e.what(), "plugin 'garbage' (" + (kPlugins / "penumbra-garbage.so").string() +
                                       "): not a shared library: it is not an ELF file"));
    EXPECT_TRUE(contains(e.what(), "rebuild the plugin"));
    EXPECT_EQ(e.file(), kPlugins / "penumbra-garbage.so");
    expectStillWorks();
}

TEST_F(Registry, TruncatedAndEmptyFilesAreNotLibraries)
{
    const test::ScratchFolder scratch("plugins");
    const fs::path& dir = scratch.path;
    std::ofstream(dir / "penumbra-truncated.so", std::ios::binary) << "\x7f" "ELF\x02\x01";
    std::ofstream(dir / "penumbra-empty.so", std::ios::binary);
    PluginRegistry local({dir, kPlugins});
    const auto discovery = local.scanAll();
    std::map<std::string, std::string> messages;
    for (const PluginError& e : discovery.errors) {
        if (e.file().parent_path() != dir) continue;
        EXPECT_EQ(e.kind(), PluginErrorKind::NotALibrary) << e.what();
        messages[e.file().filename().string()] = e.what();
    }
    EXPECT_TRUE(contains(messages["penumbra-truncated.so"], "the ELF header is truncated (6 bytes)"));
    EXPECT_TRUE(contains(messages["penumbra-empty.so"], "it is not an ELF file"));
    EXPECT_EQ(local.load("testgood").name(), "testgood");
}

// Damaged copies of a real plugin, and things named like plugins that are not files
// (issue 20): a truncated library or one whose headers point past its end made dlopen
// die of SIGBUS, a FIFO blocked the read forever, a directory passed `plugins --strict`
// and failed `render`. Each is not-a-library, the same way for the listing
// (scanAll) as for a load by name (render).
TEST_F(Registry, DamagedLibrariesAndNonFilesAreNotLibrariesEverywhere)
{
    const test::ScratchFolder scratch("damaged");
    const fs::path& dir = scratch.path;
    std::vector<char> good;
    {
        std::ifstream in(kPlugins / "penumbra-testgood.so", std::ios::binary);
        good.assign(std::istreambuf_iterator<char>(in), {});
    }
    ASSERT_GT(good.size(), 4096u);
    const auto write = [&](const std::string& name, const std::vector<char>& bytes) {
        std::ofstream(dir / ("penumbra-" + name + ".so"), std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
    };
    std::map<std::string, std::string> expected;  // plugin name -> what the message says
    for (size_t keep : {size_t(64) + 8, good.size() / 8, good.size() / 4, good.size() / 2, good.size() * 3 / 4,
                        good.size() - 1}) {
        const std::string name = fmt::format("cut{}", keep);
        write(name, std::vector<char>(good.begin(), good.begin() + std::ptrdiff_t(keep)));
        expected[name] = "it is damaged or truncated";
    }
    // Header fields pointing past the end: the program header table, a segment's offset
    // and its size (a flipped high bit each).
    ElfW(Ehdr) header;
    std::memcpy(&header, good.data(), sizeof header);
    const auto flipped = [&](size_t offset, size_t bytes) {
        std::vector<char> copy = good;
        copy[offset + bytes - 1] = char(copy[offset + bytes - 1] ^ 0x40);
        return copy;
    };
    write("phoff", flipped(offsetof(ElfW(Ehdr), e_phoff), sizeof header.e_phoff));
    expected["phoff"] = "program header table";
    size_t load = header.e_phoff;
    for (size_t i = 0; i < header.e_phnum; ++i, load += sizeof(ElfW(Phdr))) {
        ElfW(Phdr) p;
        std::memcpy(&p, good.data() + load, sizeof p);
        if (p.p_type == PT_LOAD) break;
    }
    write("segoffset", flipped(load + offsetof(ElfW(Phdr), p_offset), sizeof(ElfW(Phdr)::p_offset)));
    write("segsize", flipped(load + offsetof(ElfW(Phdr), p_filesz), sizeof(ElfW(Phdr)::p_filesz)));
    expected["segoffset"] = expected["segsize"] = "beyond the file's end";
    // Not regular files.
    ASSERT_EQ(::mkfifo((dir / "penumbra-fifo.so").c_str(), 0600), 0);
    fs::create_directories(dir / "penumbra-folder.so");
    fs::create_symlink(dir / "nowhere.so", dir / "penumbra-dangling.so");
    expected["fifo"] = "it is a FIFO";
    expected["folder"] = "it is a directory";
    expected["dangling"] = "it is a dangling link";

    PluginRegistry local({dir, kPlugins});
    std::map<std::string, std::string> listed;
    for (const PluginError& e : local.scanAll().errors) {
        if (e.file().parent_path() != dir) continue;
        EXPECT_EQ(e.kind(), PluginErrorKind::NotALibrary) << e.what();
        listed[e.file().filename().string()] = e.what();
    }
    for (const auto& [name, what] : expected) {
        SCOPED_TRACE(name);
        const std::string file = "penumbra-" + name + ".so";
        EXPECT_TRUE(contains(listed[file], what)) << listed[file];
        try {
            local.load(name);
            ADD_FAILURE() << "loaded";
        } catch (const PluginError& e) {
            EXPECT_EQ(e.kind(), PluginErrorKind::NotALibrary) << e.what();
            EXPECT_EQ(std::string(e.what()), listed[file]) << "the same report for a load by name";
        }
    }
    EXPECT_EQ(local.load("testgood").name(), "testgood");
}

TEST_F(Registry, DependencyMissingQuotesTheLoader)
{
    const PluginError e = loadError("nodep", PluginErrorKind::DependencyMissing);
    EXPECT_TRUE(contains(e.what(), "plugin 'nodep' (" + (kPlugins / "penumbra-nodep.so").string() + "): cannot be loaded: "));
    // dlerror()'s own words, verbatim.
    EXPECT_TRUE(contains(e.what(), "libpenumbra_test_absent.so: cannot open shared object file: No such file or directory"));
    EXPECT_TRUE(contains(e.what(), "ldd -r"));
    EXPECT_TRUE(contains(e.what(), "LD_LIBRARY_PATH"));
    expectStillWorks();
}

TEST_F(Registry, EntryMissingIsNotAPlugin)
{
    const PluginError e = loadError("noentry", PluginErrorKind::EntryMissing);
    EXPECT_TRUE(contains(e.what(), "plugin 'noentry' (" + (kPlugins / "penumbra-noentry.so").string() +
                                       "): not a Penumbra plugin: no penumbra_plugin_entry symbol"));
    EXPECT_TRUE(contains(e.what(), "PENUMBRA_PLUGIN_EXPORT"));
    expectStillWorks();
}

TEST_F(Registry, AbiMismatchNamesBothVersions)
{
    const PluginError e = loadError("abi", PluginErrorKind::AbiMismatch);
    EXPECT_TRUE(contains(e.what(), "plugin 'abi' (" + (kPlugins / "penumbra-abi.so").string() +
                                       "): built for plugin ABI 9999, this engine has ABI " +
                                       std::to_string(PENUMBRA_PLUGIN_ABI_VERSION) +
                                       ": rebuild the plugin against this engine"));
    expectStillWorks();
}

TEST_F(Registry, MalformedInfoIsInvalidInfo)
{
    const PluginError e = loadError("badinfo", PluginErrorKind::InvalidInfo);
    EXPECT_TRUE(contains(e.what(), "plugin 'badinfo' (" + (kPlugins / "penumbra-badinfo.so").string() +
                                       "): malformed plugin info: params[0] 'kernel': needs min <= default <= max"));
    expectStillWorks();
}

TEST_F(Registry, NameMismatchSaysWhichNameTheFileDeclares)
{
    const PluginError e = loadError("mismatch", PluginErrorKind::NameMismatch);
    EXPECT_TRUE(contains(e.what(), "plugin file " + (kPlugins / "penumbra-mismatch.so").string() +
                                       " declares the name 'other', not 'mismatch': rename the file to penumbra-other.so"));
    // The name it declares is not registered either.
    loadError("other", PluginErrorKind::FileMissing);
    expectStillWorks();
}

TEST_F(Registry, DuplicateNameTheFirstOnThePathWins)
{
    EXPECT_STREQ(registry.load("dup").info->version, "1.0");
    const auto discovery = registry.scanAll();
    std::vector<std::string> duplicates;
    for (const PluginError& e : discovery.errors) {
        if (e.kind() != PluginErrorKind::DuplicateName) continue;
        duplicates.push_back(e.what());
        EXPECT_EQ(e.file(), kShadowedPlugins / "penumbra-dup.so");
    }
    ASSERT_EQ(duplicates.size(), 1u);
    EXPECT_TRUE(contains(duplicates[0], "plugin 'dup' (" + (kShadowedPlugins / "penumbra-dup.so").string() +
                                            "): duplicate plugin name: " + (kPlugins / "penumbra-dup.so").string() +
                                            " was loaded first for the name 'dup' and wins"));
    EXPECT_STREQ(registry.load("dup").info->version, "1.0");

    // The other order: the other file wins.
    PluginRegistry reversed({kShadowedPlugins, kPlugins});
    EXPECT_STREQ(reversed.load("dup").info->version, "2.0");
    expectStillWorks();
}

TEST(PluginRegistry, ScanAllListsEveryFileOnceWithItsKind)
{
    // A folder given twice is searched once.
    PluginRegistry registry({kPlugins, kShadowedPlugins, kPlugins / "." });
    EXPECT_EQ(registry.searchPath().size(), 2u);
    const auto discovery = registry.scanAll();
    std::vector<std::string> names;
    for (const plugin::PluginMetadata* p : discovery.plugins) names.push_back(p->name());
    EXPECT_EQ(names, (std::vector<std::string>{"dup", "testgood", "throws"}));

    std::map<std::string, std::string> kinds;
    for (const PluginError& e : discovery.errors) {
        kinds[e.file().parent_path().filename().string() + "/" + e.file().filename().string()] =
            plugin::pluginErrorKindName(e.kind());
    }
    const std::map<std::string, std::string> expected = {
        {"plugins/penumbra-abi.so", "abi-mismatch"},          {"plugins/penumbra-badinfo.so", "invalid-info"},
        {"plugins/penumbra-garbage.so", "not-a-library"},     {"plugins/penumbra-mismatch.so", "name-mismatch"},
        {"plugins/penumbra-nodep.so", "dependency-missing"},  {"plugins/penumbra-noentry.so", "entry-missing"},
        {"plugins-shadowed/penumbra-dup.so", "duplicate-name"},
    };
    EXPECT_EQ(kinds, expected);
    // Discovering again finds the same (loaded plugins are not loaded twice).
    const auto again = registry.scanAll();
    EXPECT_EQ(again.plugins, discovery.plugins);
    EXPECT_EQ(again.errors.size(), discovery.errors.size());
}

TEST(PluginRegistry, DefaultSearchPathFollowsTheEnvironmentThenTheBuildTree)
{
    {
        const ScopedEnv env("PENUMBRA_PLUGIN_PATH",
                            kShadowedPlugins.string() + "::/no/such/folder:" + kPlugins.string() + ":" + kShadowedPlugins.string());
        const std::vector<fs::path> path = plugin::defaultPluginSearchPath();
        ASSERT_GE(path.size(), 2u);
        EXPECT_EQ(path[0], kShadowedPlugins);
        EXPECT_EQ(path[1], kPlugins);
        for (const fs::path& dir : path) EXPECT_TRUE(fs::is_directory(dir)) << dir;
        PluginRegistry registry;
        EXPECT_STREQ(registry.load("dup").info->version, "2.0");
    }
    const ScopedEnv unset("PENUMBRA_PLUGIN_PATH", "");
    for (const fs::path& dir : plugin::defaultPluginSearchPath()) {
        EXPECT_NE(dir, kPlugins) << "the test plugins are on no default path";
        EXPECT_NE(dir, kShadowedPlugins);
    }
}

// The engine library the tests link is the build tree's: after the environment it
// searches the build tree's plugins/ alone, never <its folder>/penumbra/plugins, where an
// installed copy keeps its own (.ci/out-of-tree.sh checks an installed engine: its own
// plugins, from its prefix, and no duplicate names).
TEST(PluginRegistry, TheBuildTreesEngineSearchesTheBuildTreesPluginsAlone)
{
    const ScopedEnv unset("PENUMBRA_PLUGIN_PATH", "");
    const fs::path installedLayout = penumbra::test::engineLibraryDir() / "penumbra";
    struct RemoveIfCreated {
        fs::path dir;
        bool created;
        ~RemoveIfCreated()
        {
            std::error_code ec;
            if (created) fs::remove_all(dir, ec);
        }
    } cleanup{installedLayout, !fs::exists(installedLayout)};
    fs::create_directories(installedLayout / "plugins");
    EXPECT_EQ(plugin::defaultPluginSearchPath(), std::vector<fs::path>{penumbra::test::buildPluginDir()});
}

// --- the dynamic section, and files for another machine ------------------------------

namespace {

std::vector<char> readBytes(const fs::path& file)
{
    std::ifstream in(file, std::ios::binary);
    return std::vector<char>(std::istreambuf_iterator<char>(in), {});
}

// The file offset of dynamic entry `tag`'s value in an ELF image; 0 when it has none.
size_t dynamicValueOffset(const std::vector<char>& elf, int64_t tag)
{
    ElfW(Ehdr) header;
    std::memcpy(&header, elf.data(), sizeof header);
    for (size_t i = 0; i < header.e_phnum; ++i) {
        ElfW(Phdr) p;
        std::memcpy(&p, elf.data() + header.e_phoff + i * sizeof p, sizeof p);
        if (p.p_type != PT_DYNAMIC) continue;
        for (size_t at = p.p_offset; at + sizeof(ElfW(Dyn)) <= p.p_offset + p.p_filesz; at += sizeof(ElfW(Dyn))) {
            ElfW(Dyn) d;
            std::memcpy(&d, elf.data() + at, sizeof d);
            if (d.d_tag == tag) return at + offsetof(ElfW(Dyn), d_un);
        }
    }
    return 0;
}

} // namespace

// Bit flips in the dynamic section made the loader read string and symbol tables, or call
// finalisers, outside the mapped file (SIGSEGV, and a crash at exit after the PNG was
// written); a file for another machine or byte order went to dlopen. Each is refused
// before dlopen, by name.
TEST(LibraryFile, DamagedDynamicSectionsAndForeignFilesAreNotLibraries)
{
    const test::ScratchFolder dir("dynamic");
    const std::vector<char> good = readBytes(kPlugins / "penumbra-testgood.so");
    ASSERT_GT(good.size(), 4096u);
    std::map<std::string, std::string> expected;  // file -> what its message says
    const auto write = [&](const std::string& name, const std::vector<char>& bytes, const std::string& what) {
        std::ofstream(dir.path / name, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
        expected[name] = what;
    };
    const auto withDynamic = [&](int64_t tag, uint64_t value) {
        const size_t at = dynamicValueOffset(good, tag);
        EXPECT_NE(at, 0u) << "the fixture has no dynamic entry " << tag;
        std::vector<char> copy = good;
        std::memcpy(copy.data() + at, &value, sizeof value);
        return copy;
    };
    const uint64_t beyond = uint64_t(good.size()) * 64;  // inside no segment
    write("strtab.so", withDynamic(DT_STRTAB, beyond), "its dynamic section's string table (DT_STRTAB, DT_STRSZ)");
    write("strsz.so", withDynamic(DT_STRSZ, good.size()), "string table (DT_STRTAB, DT_STRSZ)");
    write("symtab.so", withDynamic(DT_SYMTAB, beyond), "its dynamic section's symbol table (DT_SYMTAB)");
    write("fini.so", withDynamic(DT_FINI_ARRAY, beyond), "finaliser array (DT_FINI_ARRAY, DT_FINI_ARRAYSZ)");
    write("finisz.so", withDynamic(DT_FINI_ARRAYSZ, good.size()), "finaliser array (DT_FINI_ARRAY, DT_FINI_ARRAYSZ)");
    write("rela.so", withDynamic(DT_RELA, beyond), "relocations (DT_RELA, DT_RELASZ)");
    write("needed.so", withDynamic(DT_NEEDED, uint64_t(1) << 40), "a needed library's name (DT_NEEDED)");
    std::vector<char> copy = good;
    const uint16_t aarch64 = EM_AARCH64;
    std::memcpy(copy.data() + offsetof(ElfW(Ehdr), e_machine), &aarch64, sizeof aarch64);
    write("machine.so", copy, "it is built for another architecture (AArch64), this engine runs on x86-64");
    copy = good;
    copy[EI_DATA] = ELFDATA2MSB;
    write("bigendian.so", copy, "it is a big-endian ELF file, this engine is little-endian");
    copy = good;
    copy[EI_CLASS] = ELFCLASS32;
    write("class32.so", copy, "it is a 32-bit ELF file, this engine is 64-bit");

    for (const auto& [name, what] : expected) {
        SCOPED_TRACE(name);
        try {
            plugin::checkSharedLibraryFile(dir.path / name, name);
            ADD_FAILURE() << "accepted";
        } catch (const PluginError& e) {
            EXPECT_EQ(e.kind(), PluginErrorKind::NotALibrary) << e.what();
            EXPECT_TRUE(contains(e.what(), name + ": not a shared library: "));
            EXPECT_TRUE(contains(e.what(), what));
        }
    }
    // The undamaged file passes, and so does every plugin the build made.
    EXPECT_NO_THROW(plugin::checkSharedLibraryFile(kPlugins / "penumbra-testgood.so", "testgood"));
    for (const fs::directory_entry& f : fs::directory_iterator(penumbra::test::buildPluginDir())) {
        if (f.path().extension() != ".so") continue;
        EXPECT_NO_THROW(plugin::checkSharedLibraryFile(f.path(), "built")) << f.path();
    }
}

// --- scanning in a process of its own ------------------------------------------------

namespace {

plugin::ScanSettings scanSettings(const fs::path& cacheFile, std::chrono::milliseconds timeout = std::chrono::seconds(30))
{
    plugin::ScanSettings settings;
    settings.cacheFile = cacheFile;
    settings.timeout = timeout;
    return settings;
}

PluginError pluginErrorOf(const std::function<void()>& fn)
{
    try {
        fn();
    } catch (const PluginError& e) {
        return e;
    }
    ADD_FAILURE() << "no PluginError";
    return PluginError(PluginErrorKind::FileMissing, "");
}

} // namespace

// A plugin that kills the process loading it (SIGSEGV in its entry point or in a static
// constructor) or hangs there: the scanner dies or is stopped, the engine's process lives,
// and the report names the plugin and the signal. A render that uses it (load) never
// dlopens it here.
TEST(PluginScanner, APluginThatCrashesOrHangsKillsOnlyTheScanner)
{
    const test::ScratchFolder dir("scan_crash");
    const fs::path crashing = penumbra::test::crashingTestPluginDir();
    PluginRegistry registry({crashing}, scanSettings(dir.path / "cache.json"));
    const PluginError crashes = pluginErrorOf([&] { registry.scan("crashes"); });
    EXPECT_EQ(crashes.kind(), PluginErrorKind::ScanFailed) << crashes.what();
    EXPECT_EQ(crashes.file(), crashing / "penumbra-crashes.so");
    // A scanner built with AddressSanitizer (the sanitizer build's, like this test) reports
    // the SIGSEGV and aborts (abort_on_error): the signal it dies of is then SIGABRT.
#ifdef __SANITIZE_ADDRESS__
    const std::string died = "the plugin scanner died of SIGABRT (Aborted)";
#else
    const std::string died = "the plugin scanner died of SIGSEGV (Segmentation fault)";
#endif
    EXPECT_TRUE(contains(crashes.what(), "plugin 'crashes' (" + (crashing / "penumbra-crashes.so").string() + "): " + died +
                                             " while loading it"))
        << crashes.what();
    const PluginError early = pluginErrorOf([&] { registry.load("crashes-early"); });
    EXPECT_EQ(early.kind(), PluginErrorKind::ScanFailed) << early.what();
    EXPECT_TRUE(contains(early.what(), "plugin 'crashes-early' (")) << early.what();
    EXPECT_TRUE(contains(early.what(), died)) << early.what();
    const PluginError again = pluginErrorOf([&] { registry.load("crashes"); });
    EXPECT_EQ(std::string(again.what()), crashes.what()) << "a load by name reports the scan";
    // Nothing failed is cached: a rebuilt plugin is scanned again.
    EXPECT_FALSE(fs::exists(dir.path / "cache.json"));

    PluginRegistry impatient({crashing}, scanSettings(dir.path / "cache.json", std::chrono::milliseconds(1500)));
    const PluginError hangs = pluginErrorOf([&] { impatient.scan("hangs"); });
    EXPECT_EQ(hangs.kind(), PluginErrorKind::ScanFailed) << hangs.what();
    EXPECT_TRUE(contains(hangs.what(), "plugin 'hangs' (")) << hangs.what();
    EXPECT_TRUE(contains(hangs.what(), "the plugin scanner did not finish loading it within 1.5 s and was stopped"));
}

// The second scan of an unchanged file comes from the cache (a registry whose scanner
// cannot even start still lists it); a file whose size or modification time changed is
// scanned again; a cache that cannot be read is ignored and rewritten.
TEST(PluginScanner, ScansAreCachedByFileIdentity)
{
    const test::ScratchFolder dir("scan_cache");
    fs::create_directories(dir.path / "plugins");
    const fs::path copy = dir.path / "plugins" / "penumbra-testgood.so";
    fs::copy_file(kPlugins / "penumbra-testgood.so", copy);
    const fs::path cacheFile = dir.path / "cache" / "scan.json";
    {
        PluginRegistry registry({dir.path / "plugins"}, scanSettings(cacheFile));
        const plugin::PluginMetadata& good = registry.scan("testgood");
        EXPECT_EQ(good.version(), "1.2.0");
        EXPECT_EQ(good.defaultParams().toJson(),
                  json::parse(R"({"enabled": true, "kernel": 5, "fill": 0.5, "bias": 0.01, "mode": "clear"})"));
    }
    ASSERT_TRUE(fs::exists(cacheFile));
    const json cached = json::parse(readBytes(cacheFile));
    ASSERT_EQ(cached["entries"].size(), 1u);
    EXPECT_EQ(cached["entries"][0]["file"]["path"], fs::canonical(copy).string());

    plugin::ScanSettings noScanner = scanSettings(cacheFile);
    noScanner.scanner = dir.path / "no-such-scanner";
    {
        PluginRegistry registry({dir.path / "plugins"}, noScanner);
        const plugin::PluginMetadata& good = registry.scan("testgood");
        EXPECT_EQ(good.summary(), "test plugin: clears V_l to a constant");
        EXPECT_EQ(good.file(), copy);
        EXPECT_EQ(good.params().size(), 5u);
    }
    // A new modification time: scanned again, with the scanner that cannot start.
    fs::last_write_time(copy, fs::last_write_time(copy) + std::chrono::seconds(5));
    {
        PluginRegistry registry({dir.path / "plugins"}, noScanner);
        const PluginError e = pluginErrorOf([&] { registry.scan("testgood"); });
        EXPECT_EQ(e.kind(), PluginErrorKind::ScanFailed);
        EXPECT_TRUE(contains(e.what(), "the plugin scanner " + noScanner.scanner.string() + " cannot be started"));
    }
    // A damaged cache is ignored (a warning) and replaced by a good one.
    std::ofstream(cacheFile, std::ios::trunc) << "{\"format\": 1, \"entries\": [";
    {
        PluginRegistry registry({dir.path / "plugins"}, scanSettings(cacheFile));
        EXPECT_EQ(registry.scan("testgood").version(), "1.2.0");
    }
    EXPECT_EQ(json::parse(readBytes(cacheFile))["entries"].size(), 1u);
}

// What the scanner hands over is read back as strictly as an entry's info is checked.
TEST(PluginMetadata, JsonRoundTripsAndDamagedDescriptionsAreInvalidInfo)
{
    const PenumbraPluginInfo info{PENUMBRA_PLUGIN_ABI_VERSION, "x", "1", "s", kSpecs, std::size(kSpecs), &createNothing, nullptr};
    const plugin::PluginMetadata metadata(info, "/p/penumbra-x.so", "/p/x");
    const json doc = metadata.toJson();
    const plugin::PluginMetadata back = plugin::PluginMetadata::fromJson(doc, "/p/penumbra-x.so");
    EXPECT_EQ(back.toJson(), doc);
    EXPECT_EQ(back.defaultParams().toJson(), specValues().toJson());
    const ParamSpec odd[] = {{"taps", ParamType::Int, 3, 1, 7, "", "d", nullptr, 0, true}};
    const PenumbraPluginInfo oddInfo{PENUMBRA_PLUGIN_ABI_VERSION, "x", "1", "s", odd, 1, &createNothing, nullptr};
    const json oddDoc = plugin::PluginMetadata(oddInfo, "/p/penumbra-x.so", "/p/x").toJson();
    EXPECT_TRUE(plugin::PluginMetadata::fromJson(oddDoc, "/p/penumbra-x.so").defaultParams().specs().at(0).odd);
    for (const auto& [change, what] : std::vector<std::pair<std::function<void(json&)>, std::string>>{
             {[](json& d) { d.erase("name"); }, "'name' is not a string"},
             {[](json& d) { d["params"][1]["type"] = "complex"; }, "unknown parameter type 'complex'"},
             {[](json& d) { d["params"][1]["min"] = 9; }, "needs min <= default <= max"},
             {[](json& d) { d["params"][3]["default"] = "other"; }, "an enum's default is a choice index"},
         }) {
        json damaged = doc;
        change(damaged);
        const PluginError e = pluginErrorOf([&] { plugin::PluginMetadata::fromJson(damaged, "/p/penumbra-x.so"); });
        EXPECT_EQ(e.kind(), PluginErrorKind::InvalidInfo);
        EXPECT_TRUE(contains(e.what(), what));
    }
}

// --- parameters from config to plugin ------------------------------------------------

namespace {

config::RenderConfig writeAndLoad(const fs::path& file, const std::string& text)
{
    std::ofstream(file) << text;
    return config::loadConfig(file);
}

const char* const kTwoLights = R"({
  "camera": {"position": [0, 5, 10], "target": [0, 0, 0]},
  "lights": [
    {"type": "point", "position": [0, 4, 0], "shadow": {"technique": "testgood", "kernel": 9, "fill": 0.25,
                                                         "mode": "unshadowed", "enabled": false}},
    {"type": "point", "position": [2, 4, 0], "shadow": {"technique": "hard"}},
    {"type": "point", "position": [4, 4, 0], "shadow": {"technique": "testgood"}}
  ]})";

class Configs : public test::WithScratchFolder<Registry> {};

} // namespace

TEST_F(Configs, ResolveParamsAppliesTheConfigOnTopOfTheDefaults)
{
    const config::RenderConfig cfg = writeAndLoad(dir / "two.json", kTwoLights);
    const plugin::LoadedPlugin& good = registry.load("testgood");
    EXPECT_EQ(plugin::resolveParams(good, cfg.lights[0].shadow).toJson(),
              json::parse(R"({"enabled": false, "kernel": 9, "fill": 0.25, "bias": 0.01, "mode": "unshadowed"})"));
    EXPECT_EQ(plugin::resolveParams(good, cfg.lights[2].shadow).toJson(), good.defaultParams().toJson());
    EXPECT_THROW(plugin::resolveParams(good, cfg.lights[1].shadow), Error) << "light 1 uses another technique";
}

TEST_F(Configs, BadValuesNameTheFileAndJsonPath)
{
    const plugin::LoadedPlugin& good = registry.load("testgood");
    auto errorFor = [&](const std::string& shadow) {
        const config::RenderConfig cfg = writeAndLoad(dir / "bad.json", R"({"camera": {"position": [0, 5, 10], "target": [0, 0, 0]},
            "lights": [{"type": "point", "position": [0, 4, 0]}, {"type": "point", "position": [0, 4, 0], "shadow": )" + shadow + "}]}");
        return configErrorOf([&] { plugin::resolveParams(good, cfg.lights[1].shadow); });
    };
    const std::string file = (dir / "bad.json").string();
    EXPECT_TRUE(contains(errorFor(R"({"technique": "testgood", "kernel": 4.5})"),
                         file + ": /lights/1/shadow/kernel: must be an integer in [1, 15] (plugin testgood, parameter "
                                "kernel: a kernel width, unused), got 4.5"));
    EXPECT_TRUE(contains(errorFor(R"({"technique": "testgood", "kernal": 4})"),
                         file + ": /lights/1/shadow/kernal: plugin 'testgood' has no parameter 'kernal'; did you mean "
                                "'kernel'?"));
    EXPECT_TRUE(contains(errorFor(R"({"technique": "testgood", "mode": "soft"})"),
                         file + ": /lights/1/shadow/mode: must be one of \"clear\", \"unshadowed\""));
    EXPECT_TRUE(contains(errorFor(R"({"technique": "testgood", "bias": -2})"),
                         file + ": /lights/1/shadow/bias: must be a number in [-1, 1]"));
    EXPECT_TRUE(contains(errorFor(R"({"technique": "testgood", "enabled": "yes"})"),
                         file + ": /lights/1/shadow/enabled: must be true or false"));
}

TEST_F(Configs, ResolveParamsCanCollectEveryBadValue)
{
    const config::RenderConfig cfg = writeAndLoad(dir / "bad.json", R"({"camera": {"position": [0, 5, 10], "target": [0, 0, 0]},
        "lights": [{"type": "point", "position": [0, 4, 0],
                    "shadow": {"technique": "testgood", "kernel": 0, "fill": 0.75, "mode": 1}}]})");
    std::vector<std::string> errors;
    const ParamValues values = plugin::resolveParams(registry.load("testgood"), cfg.lights[0].shadow, &errors);
    ASSERT_EQ(errors.size(), 2u);
    EXPECT_TRUE(contains(errors[0], "/lights/0/shadow/kernel: must be an integer in [1, 15]"));
    EXPECT_TRUE(contains(errors[1], "/lights/0/shadow/mode: must be one of"));
    EXPECT_EQ(values.getInt("kernel"), 5) << "a bad value keeps its default";
    EXPECT_FLOAT_EQ(values.getFloat("fill"), 0.75f) << "good values still apply";
}

TEST_F(Configs, BadValuesInAnIncludedFileNameThatFile)
{
    std::ofstream(dir / "base.json") << R"({"camera": {"position": [0, 5, 10], "target": [0, 0, 0]}, "lights": [{"type": "point", "position": [0, 4, 0],
        "shadow": {"technique": "testgood", "fill": 3}}]})";
    const config::RenderConfig cfg = writeAndLoad(dir / "top.json", R"({"include": "base.json", "frames": 2})");
    const std::string message = configErrorOf([&] { plugin::resolveParams(registry.load("testgood"), cfg.lights[0].shadow); });
    EXPECT_TRUE(contains(message, (dir / "base.json").string() + ": /lights/0/shadow/fill: must be a number in [0, 1]"));
}

// --- --set overrides -----------------------------------------------------------------

TEST(ParamOverrides, ValuesAreJsonWhenTheyParseElseText)
{
    const std::vector<std::pair<std::string, json>> cases = {
        {"t.a=5", 5},           {"t.a=0.5", 0.5},        {"t.a=true", true},  {"t.a=pcf", "pcf"},
        {"t.a=\"5\"", "5"},      {"t.a=", ""},            {"t.a=[1,2]", json::array({1, 2})},
        {"t.a=a=b", "a=b"},      {"t.a=nan", "nan"},
    };
    for (const auto& [setting, value] : cases) {
        const config::ParamOverride o = config::parseParamOverride(setting);
        EXPECT_EQ(o.technique, "t");
        EXPECT_EQ(o.param, "a");
        EXPECT_EQ(o.value, value) << setting;
        EXPECT_EQ(o.where, "--set t.a");
    }
    const config::ParamOverride dotted = config::parseParamOverride("hard.pcf.kernel=3");
    EXPECT_EQ(dotted.technique, "hard");
    EXPECT_EQ(dotted.param, "pcf.kernel") << "the technique ends at the first dot; the plugin refuses the name";
}

TEST(ParamOverrides, WrongSyntaxSaysWhatIsExpected)
{
    for (const char* setting : {"t=5", ".a=5", "t.=5", "ta5", "=5", ""}) {
        const std::string message = configErrorOf([&] { config::parseParamOverride(setting); });
        EXPECT_TRUE(contains(message, fmt::format("--set '{}': expected technique.parameter=value, e.g. --set "
                                                  "hard.pcf_kernel=5",
                                                  setting)));
    }
}

TEST_F(Configs, OverridesApplyToEveryLightOfTheTechniqueAndWin)
{
    config::RenderConfig cfg = writeAndLoad(dir / "two.json", kTwoLights);
    config::applyParamOverrides(cfg, config::parseParamOverrides({"testgood.kernel=11", "testgood.mode=clear",
                                                                  "testgood.kernel=12"}));
    const plugin::LoadedPlugin& good = registry.load("testgood");
    EXPECT_EQ(plugin::resolveParams(good, cfg.lights[0].shadow).toJson(),
              json::parse(R"({"enabled": false, "kernel": 12, "fill": 0.25, "bias": 0.01, "mode": "clear"})"));
    EXPECT_EQ(plugin::resolveParams(good, cfg.lights[2].shadow).toJson(),
              json::parse(R"({"enabled": true, "kernel": 12, "fill": 0.5, "bias": 0.01, "mode": "clear"})"));
    EXPECT_TRUE(cfg.lights[1].shadow.params.empty()) << "the hard light is untouched";

    config::applyParamOverrides(cfg, config::parseParamOverrides({"testgood.kernel=4.5"}));
    EXPECT_TRUE(contains(configErrorOf([&] { plugin::resolveParams(good, cfg.lights[0].shadow); }),
                         "--set testgood.kernel: must be an integer in [1, 15] (plugin testgood, parameter kernel: a "
                         "kernel width, unused), got 4.5"));
}

TEST_F(Configs, OverrideOfATechniqueNoLightUsesIsAnError)
{
    config::RenderConfig cfg = writeAndLoad(dir / "two.json", kTwoLights);
    EXPECT_TRUE(contains(configErrorOf([&] { config::applyParamOverrides(cfg, config::parseParamOverrides({"testgod.kernel=3"})); }),
                         "--set testgod.kernel: no light of " + (dir / "two.json").string() +
                             " uses technique 'testgod' (its lights use: testgood, hard; did you mean 'testgood'?)"));
}

// --- techniques ----------------------------------------------------------------------

namespace {

// What penumbra-testgood.so's factory last received, through its test hook.
json receivedByTestGood()
{
    void* handle = dlopen((kPlugins / "penumbra-testgood.so").c_str(), RTLD_NOW | RTLD_NOLOAD);
    if (!handle) return "not loaded";
    auto received = reinterpret_cast<const char* (*)()>(dlsym(handle, "penumbra_testgood_received"));
    const std::string text = received ? received() : "";
    dlclose(handle);
    return text.empty() ? json() : json::parse(text);
}

// Everything a technique's factory gets, for a small scene.
class Techniques : public test::GpuTest {
protected:
    void SetUp() override
    {
        GpuTest::SetUp();
        scene = scene::generateScene("box-grid", {{"rows", "2"}, {"columns", "2"}});
        sceneGpu = std::make_unique<render::SceneGpu>(*context, scene);
        casters = std::make_unique<render::Casters>(*sceneGpu);
        shaders = std::make_unique<gpu::ShaderCompiler>(std::vector<fs::path>{gpu::engineShaderDir()});
    }
    void TearDown() override
    {
        casters.reset();
        sceneGpu.reset();
        GpuTest::TearDown();
    }

    std::unique_ptr<plugin::Technique> create(const plugin::LoadedPlugin& plugin, const ParamValues& params,
                                              uint32_t lightIndex = 0)
    {
        const plugin::TechniqueSetup setup{*context,   *shaders, *casters, scene, params, light, scene.bounds(),
                                           lightIndex, 64,       32,       fmt::format("light{}.{}.", lightIndex, plugin.name())};
        return registry.create(plugin, setup, fmt::format("light {}", lightIndex));
    }

    PluginRegistry registry{{kPlugins}};
    scene::Scene scene;
    scene::Light light;
    std::unique_ptr<render::SceneGpu> sceneGpu;
    std::unique_ptr<render::Casters> casters;
    std::unique_ptr<gpu::ShaderCompiler> shaders;
};

} // namespace

// plugin::DebugViewPass compiles its shader on the pass's first run: a debug view nobody
// requests costs nothing, not even its compile (here of a shader that does not exist).
TEST_F(Techniques, ADebugViewPassCompilesItsShaderOnlyWhenAnImageIsRequested)
{
    const ParamValues params;
    const plugin::TechniqueSetup setup{*context, *shaders, *casters, scene, params, light, scene.bounds(),
                                       0,        64,       32,       "light0.mine."};
    plugin::DebugViewPass debugViews(setup, plugin::computePipelineDesc(setup, "debug_views", "no_such_debug.comp"));
    plugin::LightPassIo io;
    io.prefix = setup.prefix;
    graph::RenderGraph graph;
    constexpr plugin::DebugImage kImages[] = {{"sizes", "sizesOut"}};
    debugViews.addOverTexels(graph, io, io.local("debug_views"), kImages, 8, 8, [](auto&&...) {});
    graph::GraphExecutor executor(*context);
    executor.execute(graph);
    ASSERT_EQ(executor.compiled()->culled.size(), 1u);
    EXPECT_EQ(executor.compiled()->culled[0].name, "light0.mine.debug_views");

    graph.markOutput("light0.mine.sizes");
    const std::string error = test::errorOf([&] { executor.execute(graph); });
    EXPECT_NE(error.find("pass 'light0.mine.debug_views'"), std::string::npos) << error;
    EXPECT_NE(error.find("no_such_debug.comp"), std::string::npos) << error;
}

TEST_F(Techniques, ConfigParametersReachThePlugin)
{
    const test::ScratchFolder dir("plugin_reach");
    config::RenderConfig cfg = writeAndLoad(dir.path / "two.json", kTwoLights);
    config::applyParamOverrides(cfg, config::parseParamOverrides({"testgood.bias=-0.5"}));

    const plugin::LoadedPlugin& good = registry.load("testgood");
    const ParamValues params = plugin::resolveParams(good, cfg.lights[0].shadow);
    const std::unique_ptr<plugin::Technique> technique = create(good, params, 3);
    ASSERT_TRUE(technique);
    EXPECT_EQ(receivedByTestGood(), json::parse(R"({"enabled": false, "kernel": 9, "fill": 0.25, "bias": -0.5,
        "mode": "unshadowed", "mode_index": 1, "light": 3})"));
}

TEST_F(Techniques, TheGoodTechniqueWritesTheVisibilityImage)
{
    const plugin::LoadedPlugin& good = registry.load("testgood");
    const ParamValues params = good.defaultParams();
    const std::unique_ptr<plugin::Technique> technique = create(good, params);
    graph::RenderGraph g;
    plugin::LightPassIo io;
    io.prefix = "light0.testgood.";
    io.visibility = "light0.visibility";
    g.declareImage({io.visibility, 64, 32, VK_FORMAT_R32_SFLOAT});
    g.markOutput(io.visibility);
    technique->registerPasses(g, io);
    const auto compiled = g.compile();
    ASSERT_EQ(compiled->passes.size(), 1u);
    EXPECT_EQ(compiled->passes[0].name, "light0.testgood.fill");
    ASSERT_EQ(compiled->passes[0].uses.size(), 1u);
    EXPECT_TRUE(compiled->passes[0].uses[0].writes);
    EXPECT_EQ(compiled->resources[compiled->passes[0].uses[0].resource].name, io.visibility);
    EXPECT_TRUE(g.executeFn(0));
}

TEST_F(Techniques, FactoryFailuresAreRegistrationFailed)
{
    const plugin::LoadedPlugin& throws = registry.load("throws");
    const std::vector<std::pair<std::string, std::string>> cases = {
        {"throw", "plugin 'throws' (light 2): exception during registration: shader throws/visibility.comp: not found"},
        {"throw_int", "plugin 'throws' (light 2): exception during registration (not a std::exception)"},
        {"return_null", "plugin 'throws' (light 2): the plugin's factory returned no technique"},
    };
    for (const auto& [behaviour, expected] : cases) {
        ParamValues params = throws.defaultParams();
        params.set("behaviour", behaviour, "test");
        try {
            create(throws, params, 2);
            ADD_FAILURE() << behaviour << ": created";
        } catch (const PluginError& e) {
            EXPECT_EQ(e.kind(), PluginErrorKind::RegistrationFailed);
            EXPECT_TRUE(contains(e.what(), expected));
            EXPECT_EQ(e.file(), kPlugins / "penumbra-throws.so");
        }
        // The registry and the good plugin still work.
        const plugin::LoadedPlugin& good = registry.load("testgood");
        EXPECT_TRUE(create(good, good.defaultParams()));
    }
}

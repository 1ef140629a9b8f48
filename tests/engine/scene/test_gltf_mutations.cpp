// Systematic single mutations of the hand-made files: every number replaced by an
// extreme, every key removed, every value given another type, every GLB header byte
// overwritten. Each variant must load or be refused with an AssetError — never another
// exception or a crash (the test-asan workflow runs this under ASan and UBSan).
#include "ScratchFolder.h"
#include "TestConfigs.h"

#include "penumbra/core/Error.h"
#include "penumbra/scene/GltfLoader.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <fstream>
#include <functional>

using namespace penumbra;
using test::gltfFile;
using namespace penumbra::scene;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {


struct Tally {
    size_t loaded = 0;
    size_t refused = 0;
};

class GltfMutations : public test::ScratchFolderTest {
protected:
    void SetUp() override
    {
        test::ScratchFolderTest::SetUp();
        // Thousands of variants: their warnings are not the point here.
        level = spdlog::get_level();
        spdlog::set_level(spdlog::level::off);
    }
    void TearDown() override
    {
        spdlog::set_level(level);
        test::ScratchFolderTest::TearDown();
    }

    void loadVariant(const fs::path& path, const std::string& what)
    {
        GltfLoadReport report;
        try {
            loadGltf(path, report);
            ++tally.loaded;
        } catch (const AssetError& e) {
            ++tally.refused;
            EXPECT_EQ(std::string(e.what()).rfind(path.string() + ": ", 0), 0u) << what << ": " << e.what();
        } catch (const std::exception& e) {
            ADD_FAILURE() << what << ": not an AssetError: " << e.what();
        }
    }

    void loadJson(const json& doc, const std::string& what)
    {
        const fs::path path = dir / "variant.gltf";
        std::ofstream(path) << doc.dump();
        loadVariant(path, what);
    }

    // Calls `visit(variant, description)` for each single mutation of `doc`.
    void mutateJson(const json& doc, const std::string& name)
    {
        std::function<void(const json::json_pointer&)> walk = [&](const json::json_pointer& at) {
            const json& value = doc[at];
            const std::string where = name + " " + at.to_string();
            auto variant = [&](const json& replacement, const std::string& what) {
                json copy = doc;
                copy[at] = replacement;
                loadJson(copy, where + " = " + what);
            };
            if (value.is_object()) {
                for (const auto& item : value.items()) {
                    json copy = doc;
                    copy[at].erase(item.key());
                    loadJson(copy, where + " without " + item.key());
                    walk(at / item.key());
                }
                variant(json::array(), "[]");
            } else if (value.is_array()) {
                for (size_t i = 0; i < value.size(); ++i) walk(at / i);
                variant(json::array(), "[]");
                variant(json::object(), "{}");
            } else if (value.is_number()) {
                for (const json& extreme : {json(-1), json(0), json(3), json(255), json(65536), json(4294967295u),
                                            json(9223372036854775807LL), json(1e300), json(-1e-300)}) {
                    variant(extreme, extreme.dump());
                }
                variant("7", "\"7\"");
            } else if (value.is_string()) {
                const std::string& s = value.get_ref<const std::string&>();
                // A data URI cut in half: bad base64 or too few bytes.
                if (s.rfind("data:", 0) == 0) variant(s.substr(0, s.size() / 2), "half its data URI");
                variant("", "\"\"");
                variant(7, "7");
            }
        };
        walk(json::json_pointer());
    }

    Tally tally;
    spdlog::level::level_enum level = spdlog::level::info;
};

} // namespace

TEST_F(GltfMutations, EveryJsonVariantLoadsOrIsRefused)
{
    for (const char* name : {"quad.gltf", "textured.gltf", "hierarchy.gltf", "modes.gltf", "interleaved_sparse.gltf"}) {
        std::ifstream in(gltfFile(name));
        mutateJson(json::parse(in), name);
    }
    fmt::print("JSON variants: {} loaded, {} refused\n", tally.loaded, tally.refused);
    EXPECT_GT(tally.loaded, 0u);
    EXPECT_GT(tally.refused, 0u);
}

TEST_F(GltfMutations, EveryGlbHeaderByteAndTruncation)
{
    std::ifstream in(gltfFile("quad.glb"), std::ios::binary);
    const std::string original((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const fs::path path = dir / "variant.glb";
    auto load = [&](const std::string& bytes, const std::string& what) {
        std::ofstream(path, std::ios::binary) << bytes;
        loadVariant(path, what);
    };
    // 12-byte header, 8-byte JSON chunk header; the BIN chunk header follows the JSON.
    const size_t binHeader = 20 + size_t(uint8_t(original[12])) + 256 * size_t(uint8_t(original[13]));
    std::vector<size_t> positions;
    for (size_t i = 0; i < 20; ++i) positions.push_back(i);
    for (size_t i = binHeader; i < binHeader + 8; ++i) positions.push_back(i);
    for (size_t i : positions) {
        for (char byte : {'\x00', '\x01', '\x7f', '\xff'}) {
            std::string bytes = original;
            bytes[i] = byte;
            load(bytes, fmt::format("byte {} = {}", i, int(uint8_t(byte))));
        }
    }
    for (size_t length = 0; length < original.size(); length += 7) load(original.substr(0, length), fmt::format("first {} bytes", length));
    fmt::print("GLB variants: {} loaded, {} refused\n", tally.loaded, tally.refused);
    EXPECT_GT(tally.refused, 0u);
}

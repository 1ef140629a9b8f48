// Every glTF file of Debian's assimp-testmodels (valid files, and deliberately broken
// ones: out-of-range indices, recursive nodes, a missing .bin, infinities, wrong types,
// glTF 1.0): each must load, with at least one triangle or a stated reason, or be
// refused with a penumbra::Error whose message names the file and says what is wrong.
// A crash or any other exception fails the test. Prints a summary.
#include "penumbra/core/Error.h"
#include "penumbra/scene/GltfLoader.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <map>

using namespace penumbra;
using namespace penumbra::scene;
namespace fs = std::filesystem;

namespace {

const fs::path kModels = "/usr/share/assimp/models";

struct Outcome {
    bool loaded = false;
    std::string message;  // the error, or the "no triangles" reason
    size_t triangles = 0;
    GltfLoadReport report;
};

Outcome loadOne(const fs::path& file)
{
    Outcome outcome;
    try {
        const Scene scene = loadGltf(file, outcome.report);
        outcome.loaded = true;
        outcome.triangles = scene.triangleCount();
        // What the repair promises: finite geometry, indices in range, unit normals.
        for (const Mesh& mesh : scene.meshes) {
            EXPECT_FALSE(mesh.indices.empty()) << file;
            EXPECT_LT(*std::max_element(mesh.indices.begin(), mesh.indices.end()), mesh.vertices.size()) << file;
            for (const Vertex& v : mesh.vertices) {
                EXPECT_TRUE(std::isfinite(v.position.x) && std::isfinite(v.position.y) && std::isfinite(v.position.z)) << file;
                EXPECT_NEAR(glm::length(v.normal), 1.0f, 1e-3f) << file << " mesh " << mesh.name;
            }
        }
    } catch (const Error& e) {
        outcome.message = e.what();
    }
    return outcome;
}

// The part of an error message after the file name, with indices and numbers left in.
std::string reasonOf(const std::string& message, const fs::path& file)
{
    const std::string prefix = file.string() + ": ";
    return message.rfind(prefix, 0) == 0 ? message.substr(prefix.size()) : message;
}

std::vector<fs::path> modelFiles()
{
    std::vector<fs::path> files;
    for (const char* folder : {"glTF2", "glTF"}) {
        if (!fs::is_directory(kModels / folder)) continue;
        for (const auto& entry : fs::recursive_directory_iterator(kModels / folder)) {
            const std::string ext = entry.path().extension().string();
            if (entry.is_regular_file() && (ext == ".gltf" || ext == ".glb")) files.push_back(entry.path());
        }
    }
    std::sort(files.begin(), files.end());
    return files;
}

} // namespace

TEST(AssimpGltfModels, EachLoadsOrIsRefusedWithAClearMessage)
{
    const std::vector<fs::path> files = modelFiles();
    if (files.empty()) GTEST_SKIP() << "install assimp-testmodels (.ci/install-deps.sh) for these files";

    std::map<std::string, Outcome> outcomes;
    size_t loaded = 0, refused = 0;
    std::map<std::string, int> reasons;
    for (const fs::path& file : files) {
        SCOPED_TRACE(file.string());
        Outcome outcome = loadOne(file);
        if (outcome.loaded) {
            ++loaded;
            if (outcome.triangles == 0) {
                // A stated reason: the loader's own "no triangles: ..." warning.
                auto it = std::find_if(outcome.report.warnings.begin(), outcome.report.warnings.end(),
                                       [](const std::string& w) { return w.find("no triangles: ") != std::string::npos; });
                ASSERT_NE(it, outcome.report.warnings.end()) << file << " loaded empty without a reason";
                outcome.message = *it;
            }
        } else {
            ++refused;
            // Informative: "file: what", the what at least a few words long.
            EXPECT_EQ(outcome.message.rfind(file.string() + ": ", 0), 0u) << outcome.message;
            const std::string reason = reasonOf(outcome.message, file);
            EXPECT_GE(reason.size(), 20u) << outcome.message;
            ++reasons[reason];
        }
        outcomes[fs::relative(file, kModels).string()] = std::move(outcome);
    }

    fmt::print("assimp-testmodels: {} glTF files, {} loaded, {} refused\n", files.size(), loaded, refused);
    fmt::print("distinct reasons for refusal:\n");
    for (const auto& [reason, count] : reasons) fmt::print("  {} x {}\n", count, reason);
    for (const auto& [name, outcome] : outcomes) {
        if (outcome.loaded) {
            fmt::print("  loaded  {}: {} triangles{}\n", name, outcome.triangles,
                       outcome.triangles ? "" : " (" + outcome.message.substr(outcome.message.find("no triangles")) + ")");
        } else {
            fmt::print("  refused {}: {}\n", name, reasonOf(outcome.message, kModels / name));
        }
    }

    // What the files are known to hold.
    auto expectLoaded = [&](const std::string& name, size_t triangles) {
        ASSERT_TRUE(outcomes.count(name)) << name;
        EXPECT_TRUE(outcomes[name].loaded) << name << ": " << outcomes[name].message;
        EXPECT_EQ(outcomes[name].triangles, triangles) << name;
    };
    auto expectRefused = [&](const std::string& name, const std::string& text) {
        ASSERT_TRUE(outcomes.count(name)) << name;
        EXPECT_FALSE(outcomes[name].loaded) << name;
        EXPECT_NE(outcomes[name].message.find(text), std::string::npos) << outcomes[name].message;
    };
    expectLoaded("glTF2/BoxTextured-glTF/BoxTextured.gltf", 12);
    expectLoaded("glTF2/BoxTextured-glTF-Binary/BoxTextured.glb", 12);
    expectLoaded("glTF2/BoxTextured-glTF-Embedded/BoxTextured.gltf", 12);
    expectLoaded("glTF2/BoxBadNormals-glTF-Binary/BoxBadNormals.glb", 12);
    expectLoaded("glTF2/glTF-Asset-Generator/Mesh_PrimitiveMode/Mesh_PrimitiveMode_00.gltf", 0);  // points only
    expectLoaded("glTF2/BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb", 0);  // every triangle has an infinite corner
    EXPECT_NE(outcomes["glTF2/BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb"].message.find("no triangles"),
              std::string::npos);
    expectRefused("glTF2/draco/2CylinderEngine.gltf", "required extension KHR_draco_mesh_compression is not supported");
    expectRefused("glTF2/MissingBin/BoxTextured.gltf", "buffer file 'BoxTextured0.bin' not found");
    expectRefused("glTF2/RecursiveNodes/RecursiveNodes.gltf", "/nodes/0: nodes form a cycle");
    expectRefused("glTF2/IndexOutOfRange/IndexOutOfRange.gltf", "is out of range of 24 vertices");
    expectRefused("glTF/TwoBoxes/TwoBoxes.gltf", "glTF 1.0 is not supported");
    expectRefused("glTF/BoxTextured-glTF-Binary/BoxTextured.glb", "glTF 1.0 is not supported");
}

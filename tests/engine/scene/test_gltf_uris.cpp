// glTF buffer and image URIs that reach outside the model (issue 43): traversal written
// plainly or percent-encoded, absolute paths, schemes, NULs, links out of the folder, and
// files that are not regular (a FIFO blocked the load forever). Each is refused naming
// the JSON pointer and the URI, before the file is opened, and no message quotes a byte of
// a file outside the model; legitimate relative names (a subfolder, an escaped space, a
// '+') still load, and an allowed root lets a model read a folder beside it.
#include "ErrorText.h"
#include "ScratchFolder.h"
#include "TestConfigs.h"

#include "penumbra/core/Error.h"
#include "penumbra/io/Png.h"
#include "penumbra/scene/GltfLoader.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/stat.h>

#include <fstream>

using namespace penumbra;
using namespace penumbra::scene;
namespace fs = std::filesystem;

namespace {

// What a secret file holds: no message may ever contain it.
constexpr std::string_view kSecret = "SECRET-root:x:0:0:";

// A model folder (model/) with quad_external.gltf's JSON (its buffer an external
// quad.bin), and beside it a folder (outside/) holding a copy of that buffer and a
// secret file of the buffer's size.
class GltfUris : public test::ScratchFolderTest {
protected:
    void SetUp() override
    {
        test::ScratchFolderTest::SetUp();
        model = dir / "model";
        outside = dir / "outside";
        fs::create_directories(model / "sub");
        fs::create_directories(outside);
        std::ifstream in(test::gltfFile("quad_external.gltf"));
        doc = nlohmann::json::parse(in);
        std::string secret(kSecret);
        secret.resize(fs::file_size(test::gltfFile("quad.bin")), '#');
        std::ofstream(outside / "secret.bin", std::ios::binary) << secret;
        fs::copy_file(test::gltfFile("quad.bin"), outside / "quad.bin");
    }

    // The model with buffer 0's URI set to `uri`.
    fs::path withBufferUri(const std::string& uri)
    {
        doc["buffers"][0]["uri"] = uri;
        const fs::path path = model / "m.gltf";
        std::ofstream(path) << doc.dump(1);
        return path;
    }

    // The model with a base colour texture whose image has URI `uri`.
    fs::path withImageUri(const std::string& uri)
    {
        doc["images"] = {{{"uri", uri}}};
        doc["textures"] = {{{"source", 0}}};
        doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {{"index", 0}};
        return withBufferUri("quad.bin");
    }

    void addBuffer(const fs::path& at) { fs::copy_file(test::gltfFile("quad.bin"), at); }

    // The message of the error loading `path` gives ("(no error)" when it loads).
    static std::string refusalOf(const fs::path& path, const GltfLoadOptions& options = {})
    {
        return test::errorOf([&] {
            GltfLoadReport report;
            loadGltf(path, report, options);
        });
    }

    static size_t trianglesOf(const fs::path& path, const GltfLoadOptions& options = {})
    {
        GltfLoadReport report;
        return loadGltf(path, report, options).triangleCount();
    }

    fs::path model, outside;
    nlohmann::json doc;
};

bool has(const std::string& text, std::string_view part) { return text.find(part) != std::string::npos; }

} // namespace

TEST_F(GltfUris, TraversalAbsolutePathsSchemesAndControlCharactersAreRefusedByName)
{
    // A link inside the model's folder to a file outside it, and one to a folder outside.
    fs::create_symlink(outside / "secret.bin", model / "link.bin");
    fs::create_symlink(outside, model / "linked");
    const std::string secretPath = (outside / "secret.bin").string();
    struct Case {
        std::string uri;
        std::string_view why;
    };
    const std::vector<Case> cases{
        {"../outside/secret.bin", "outside the model's folder"},
        {"%2E%2E/outside/secret.bin", "outside the model's folder"},
        {"%2e%2e%2foutside%2fsecret.bin", "outside the model's folder"},
        {"..%2Foutside%2Fsecret.bin", "outside the model's folder"},
        {"sub/../../outside/secret.bin", "outside the model's folder"},
        {"link.bin", "outside the model's folder"},
        {"linked/secret.bin", "outside the model's folder"},
        {secretPath, "is an absolute path"},
        {"/etc/passwd", "is an absolute path"},
        {"%2Fetc%2Fpasswd", "is an absolute path"},
        {"//localhost/etc/passwd", "is an absolute path"},
        {"file:///etc/passwd", "is a file: URI"},
        {"FILE:" + secretPath, "is a file: URI"},
        {"http://example.com/quad.bin", "is a http: URI"},
        {"data:text/plain,abc", "is a data: URI tinygltf cannot decode"},
        {"quad.bin%00.png", "decodes to a NUL or control character (%00"},
        {std::string("quad.bin\0x", 10), "holds a NUL or control character"},
        {"quad%0A.bin", "decodes to a NUL or control character (%0A"},
        {"quad%2.bin", "malformed percent escape at character 5"},
        {"quad.bin%", "malformed percent escape"},
        {"quad%G0.bin", "malformed percent escape"},
        {"quad.bin?x=1", "has a query or fragment"},
        {"quad.bin#part", "has a query or fragment"},
        {"", "is empty"},
    };
    addBuffer(model / "quad.bin");
    for (const Case& c : cases) {
        SCOPED_TRACE(c.uri);
        const std::string what = refusalOf(withBufferUri(c.uri));
        EXPECT_TRUE(has(what, "m.gltf: /buffers/0/uri: \"")) << what;
        EXPECT_TRUE(has(what, c.why)) << what;
        EXPECT_FALSE(has(what, kSecret)) << what;
    }
    // Images alike, even one no material uses: refused before any file is opened.
    for (const Case& c : std::vector<Case>{cases[0], cases[1], cases[3], cases[5], cases[8], cases[11], cases[15]}) {
        SCOPED_TRACE(c.uri);
        doc["images"] = {{{"uri", "quad.bin"}}, {{"uri", c.uri}}};
        const std::string what = refusalOf(withBufferUri("quad.bin"));
        EXPECT_TRUE(has(what, "m.gltf: /images/1/uri: \"")) << what;
        EXPECT_TRUE(has(what, c.why)) << what;
        EXPECT_FALSE(has(what, kSecret)) << what;
    }
    // The URI is echoed shortened.
    const std::string what = refusalOf(withBufferUri("../" + std::string(100000, 'x') + ".bin"));
    EXPECT_TRUE(has(what, "characters)")) << what.substr(0, 300);
    EXPECT_LT(what.size(), 1000u);
}

TEST_F(GltfUris, AnAllowedRootLetsTheModelReadOutsideItsFolder)
{
    fs::create_symlink(outside / "quad.bin", model / "link.bin");
    GltfLoadOptions options;
    options.allowedRoots = {outside};
    EXPECT_EQ(trianglesOf(withBufferUri("../outside/quad.bin"), options), 2u);
    EXPECT_EQ(trianglesOf(withBufferUri("%2E%2E/outside/quad.bin"), options), 2u);
    EXPECT_EQ(trianglesOf(withBufferUri("link.bin"), options), 2u);
    // A root allows what is under it, not what is beside it.
    options.allowedRoots = {outside / "sub"};
    fs::create_directories(outside / "sub");
    const std::string what = refusalOf(withBufferUri("../outside/quad.bin"), options);
    EXPECT_TRUE(has(what, "outside the model's folder")) << what;
    EXPECT_TRUE(has(what, "and the allowed roots")) << what;
    // A relative root is taken from the working folder.
    const fs::path working = fs::current_path();
    fs::current_path(dir);
    options.allowedRoots = {"outside"};
    EXPECT_EQ(trianglesOf(withBufferUri("../outside/quad.bin"), options), 2u);
    fs::current_path(working);
}

TEST_F(GltfUris, RelativeNamesAndEscapesStillLoad)
{
    // RFC 3986: "%20" is a space, '+' is itself (tinygltf's own decoding makes it a space).
    addBuffer(model / "sub" / "quad.bin");
    addBuffer(model / "a b.bin");
    addBuffer(model / "a+b.bin");
    addBuffer(model / "%41.bin");
    for (const char* uri : {"sub/quad.bin", "./sub/quad.bin", "sub/../sub/quad.bin", "a%20b.bin", "a+b.bin", "%2541.bin",
                            "su%62/quad.bin"}) {
        SCOPED_TRACE(uri);
        EXPECT_EQ(trianglesOf(withBufferUri(uri)), 2u);
    }
    // Two URIs that name two files but that tinygltf would take for one ("a b.bin"): the
    // second is refused rather than read as the first.
    doc["buffers"][1] = {{"byteLength", 140}, {"uri", "a%20b.bin"}};
    const std::string what = refusalOf(withBufferUri("a+b.bin"));
    EXPECT_TRUE(has(what, "m.gltf: /buffers/1/uri: \"a%20b.bin\": tinygltf reads it as it reads \"a+b.bin\"")) << what;
}

TEST_F(GltfUris, OnlyRegularFilesAreReadAsBuffersAndImages)
{
    // A FIFO blocked the load forever; a device or a folder would be read without end or
    // fail obscurely. Each is refused by type, naming the pointer and the URI.
    ASSERT_EQ(::mkfifo((model / "pipe.bin").c_str(), 0600), 0);
    std::string what = refusalOf(withBufferUri("pipe.bin"));
    EXPECT_TRUE(has(what, "m.gltf: /buffers/0/uri: buffer file 'pipe.bin' is a FIFO (named pipe), expected a glTF buffer"))
        << what;
    what = refusalOf(withBufferUri("sub"));
    EXPECT_TRUE(has(what, "buffer file 'sub' is a directory")) << what;
    fs::create_symlink("/dev/zero", model / "zero.bin");
    GltfLoadOptions allowDev;
    allowDev.allowedRoots = {"/dev"};
    what = refusalOf(withBufferUri("zero.bin"), allowDev);
    EXPECT_TRUE(has(what, "buffer file 'zero.bin' is a character device")) << what;
    // A missing buffer says where it was looked for.
    what = refusalOf(withBufferUri("none.bin"));
    EXPECT_TRUE(has(what, "m.gltf: /buffers/0/uri: buffer file 'none.bin' not found (looked in ")) << what;

    addBuffer(model / "quad.bin");
    ASSERT_EQ(::mkfifo((model / "pipe.png").c_str(), 0600), 0);
    what = refusalOf(withImageUri("pipe.png"));
    EXPECT_TRUE(has(what, "m.gltf: /images/0: texture file 'pipe.png' is a FIFO (named pipe), expected a glTF image"))
        << what;
    // A real image beside it loads.
    io::writePng(model / "checker.png", 2, 2, std::vector<uint8_t>(16, 200));
    GltfLoadReport report;
    const Scene scene = loadGltf(withImageUri("checker.png"), report);
    ASSERT_EQ(scene.textures.size(), 1u);
    EXPECT_EQ(scene.textures[0].width, 2u);
}

#include "ScratchFolder.h"

#include "penumbra/core/Error.h"
#include "penumbra/io/Png.h"

#include <gtest/gtest.h>
#define STB_IMAGE_IMPLEMENTATION
#include <stb/stb_image.h>

#include <fstream>

using namespace penumbra;
namespace fs = std::filesystem;

namespace {

// Each test's files in a scratch folder of its own (`dir`).
class Png : public test::ScratchFolderTest {};

} // namespace

TEST_F(Png, WritesAndReadsBack)
{
    const fs::path file = dir / "rgba.png";
    std::vector<uint8_t> rgba = {255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 10, 20, 30, 255};
    io::writePng(file, 2, 2, rgba);
    int w = 0, h = 0, n = 0;
    unsigned char* data = stbi_load(file.c_str(), &w, &h, &n, 4);
    ASSERT_NE(data, nullptr);
    EXPECT_EQ(w, 2);
    EXPECT_EQ(h, 2);
    EXPECT_TRUE(std::equal(rgba.begin(), rgba.end(), data));
    stbi_image_free(data);
    // Nothing but the PNG is left beside it (no temporary file).
    size_t files = 0;
    for ([[maybe_unused]] const auto& e : fs::directory_iterator(file.parent_path())) ++files;
    EXPECT_EQ(files, 1u);
}

TEST_F(Png, MissingFolderIsNamed)
{
    try {
        io::writePng("/nonexistent-dir/out.png", 1, 1, {0, 0, 0, 255});
        FAIL() << "expected Error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("output folder '/nonexistent-dir' does not exist"), std::string::npos);
    }
}

TEST_F(Png, SizeMismatchIsAnError)
{
    EXPECT_THROW(io::writePng(dir / "x.png", 2, 2, {0, 0, 0, 255}), Error);
    EXPECT_FALSE(fs::exists(dir / "x.png"));
}

TEST_F(Png, DirectoryAsOutputIsAnError)
{
    EXPECT_THROW(io::checkWritable(fs::temp_directory_path()), Error);
}

TEST_F(Png, JpgNamesGetJpegBytes)
{
    // A flat colour: JPEG's 8x8 blocks hold it within a few levels.
    std::vector<uint8_t> rgba;
    for (int i = 0; i < 16 * 16; ++i) rgba.insert(rgba.end(), {200, 100, 50, 255});
    for (const char* name : {"out.jpg", "out.JPEG"}) {
        SCOPED_TRACE(name);
        const fs::path file = dir / name;
        io::writeImage(file, 16, 16, rgba);
        std::ifstream in(file, std::ios::binary);
        unsigned char magic[3] = {};
        in.read(reinterpret_cast<char*>(magic), 3);
        EXPECT_EQ(magic[0], 0xFF);  // SOI and the first marker: a JPEG, not a PNG under another name
        EXPECT_EQ(magic[1], 0xD8);
        EXPECT_EQ(magic[2], 0xFF);
        int w = 0, h = 0, n = 0;
        unsigned char* data = stbi_load(file.c_str(), &w, &h, &n, 4);
        ASSERT_NE(data, nullptr);
        EXPECT_EQ(w, 16);
        EXPECT_EQ(h, 16);
        EXPECT_EQ(n, 3);
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(int(data[c]), int(rgba[size_t(c)]), 4) << "channel " << c;
        stbi_image_free(data);
    }
    io::writeImage(dir / "out.PNG", 16, 16, rgba);
    int w = 0, h = 0, n = 0;
    unsigned char* data = stbi_load((dir / "out.PNG").c_str(), &w, &h, &n, 4);
    ASSERT_NE(data, nullptr);
    EXPECT_EQ(n, 4);  // a PNG keeps the alpha channel
    stbi_image_free(data);
}

TEST_F(Png, OtherImageNamesAreRefusedBeforeAnythingIsWritten)
{
    for (const char* name : {"out.bmp", "out", "out.png.txt", "f{frame:04}.tiff"}) {
        SCOPED_TRACE(name);
        try {
            io::writeImage(dir / name, 1, 1, {0, 0, 0, 255});
            ADD_FAILURE() << "accepted";
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find(".png or .jpg"), std::string::npos) << e.what();
        }
        EXPECT_FALSE(fs::exists(dir / name));
    }
    EXPECT_EQ(io::imageFormatFor("f{frame:04}.jpg"), io::ImageFormat::Jpeg);
}

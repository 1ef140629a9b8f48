// The visibility EXR (apps/penumbra/VisibilityExr.h; issue 43 item 10): what the writer
// writes reads back bit for bit, ImageMagick sees the first light's V (the Y channel), and
// two files compare channel by channel, refusing files that differ in size or channels.
// From images made here, without a device; compiled into the unit tests.
#include "ErrorText.h"
#include "ScratchFolder.h"

#include "VisibilityExr.h"

#include "penumbra/core/Error.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>

using namespace penumbra;
namespace fs = std::filesystem;

namespace {

constexpr uint32_t kWidth = 8, kHeight = 4;

std::vector<config::LightConfig> lights(std::initializer_list<const char*> names)
{
    std::vector<config::LightConfig> out;
    for (const char* name : names) {
        config::LightConfig light;
        light.name = name;
        out.push_back(light);
    }
    return out;
}

// V rising along each row from `start`, in steps of 1/16.
std::vector<float> ramp(float start)
{
    std::vector<float> v(kWidth * kHeight);
    for (size_t i = 0; i < v.size(); ++i) v[i] = start + float(i % kWidth) / 16.0f;
    return v;
}

const app::ExrImage::Channel* channel(const app::ExrImage& image, const std::string& name)
{
    for (const app::ExrImage::Channel& c : image.channels)
        if (c.name == name) return &c;
    return nullptr;
}

bool sameBits(const std::vector<float>& a, const std::vector<float>& b)
{
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

class VisibilityExr : public test::ScratchFolderTest {};

TEST_F(VisibilityExr, ReadsBackWhatWasWrittenWithTheFirstLightAsY)
{
    // Values no visibility should hold are kept as they are: they are what a user looks for.
    std::vector<float> sun = ramp(0.25f), lamp = ramp(0.0f);
    sun[3] = std::numeric_limits<float>::quiet_NaN();
    lamp[5] = -0.5f;
    lamp[6] = 1.75f;
    app::writeVisibilityExr(dir / "v.exr", kWidth, kHeight, lights({"sun", "lamp"}), {sun, lamp});

    const app::ExrImage image = app::readExr(dir / "v.exr");
    EXPECT_EQ(image.width, kWidth);
    EXPECT_EQ(image.height, kHeight);
    ASSERT_EQ(image.channels.size(), 3u);
    ASSERT_NE(channel(image, "sun.V"), nullptr);
    ASSERT_NE(channel(image, "lamp.V"), nullptr);
    ASSERT_NE(channel(image, "Y"), nullptr);
    EXPECT_TRUE(sameBits(channel(image, "sun.V")->values, sun));
    EXPECT_TRUE(sameBits(channel(image, "lamp.V")->values, lamp));
    EXPECT_TRUE(sameBits(channel(image, "Y")->values, sun)) << "Y is the first light's V";
}

TEST_F(VisibilityExr, ImageMagickSeesTheFirstLightsV)
{
    if (::access("/usr/bin/convert", X_OK) != 0 || std::system("/usr/bin/convert -list format 2>/dev/null | grep -q ' EXR '") != 0) {
        GTEST_SKIP() << "needs ImageMagick with its OpenEXR coder (apt-get install imagemagick libmagickcore-6.q16-6-extra)";
    }
    const std::vector<float> sun = ramp(0.25f);
    app::writeVisibilityExr(dir / "v.exr", kWidth, kHeight, lights({"sun", "lamp"}), {sun, ramp(0.0f)});
    const fs::path out = dir / "mean.txt";
    ASSERT_EQ(std::system(fmt::format("/usr/bin/convert '{}' -format '%[fx:mean]' info: > '{}' 2>/dev/null", (dir / "v.exr").string(),
                                      out.string())
                              .c_str()),
              0);
    double mean = 0.0;
    for (float v : sun) mean += v;
    mean /= double(sun.size());
    // The mean over the colour channels of a grey image: V's mean, to 16-bit quantisation.
    EXPECT_NEAR(std::stod(test::readFile(out)), mean, 1e-3) << "ImageMagick read: " << test::readFile(out);
}

TEST_F(VisibilityExr, ComparesChannelByChannel)
{
    const auto l = lights({"sun", "lamp"});
    app::writeVisibilityExr(dir / "ref.exr", kWidth, kHeight, l, {ramp(0.25f), ramp(0.0f)});
    // The test's lamp is 0.2 too bright in a quarter of its pixels (the first row):
    // RMSE = sqrt(0.25 * 0.2²) = 0.1, MAE 0.05, max 0.2.
    std::vector<float> lamp = ramp(0.0f);
    for (uint32_t x = 0; x < kWidth; ++x) lamp[x] += 0.2f;
    app::writeVisibilityExr(dir / "test.exr", kWidth, kHeight, l, {ramp(0.25f), lamp});

    const app::ExrImage test = app::readExr(dir / "test.exr"), reference = app::readExr(dir / "ref.exr");
    const std::vector<app::ExrChannelComparison> same = app::compareExrChannels(reference, dir / "ref.exr", reference, dir / "ref.exr");
    ASSERT_EQ(same.size(), 3u);
    for (const app::ExrChannelComparison& c : same) {
        EXPECT_EQ(c.visibility.all.rmse, 0.0) << c.channel;
        EXPECT_EQ(c.visibility.all.pixels, kWidth * kHeight) << "every pixel is compared";
    }
    for (const app::ExrChannelComparison& c : app::compareExrChannels(test, dir / "test.exr", reference, dir / "ref.exr")) {
        SCOPED_TRACE(c.channel);
        if (c.channel == "lamp.V") {
            EXPECT_NEAR(c.visibility.all.rmse, 0.1, 1e-6);
            EXPECT_NEAR(c.visibility.all.mae, 0.05, 1e-6);
            EXPECT_NEAR(c.visibility.all.maxAbsError, 0.2, 1e-6);
            EXPECT_NEAR(c.visibility.all.percentAbove(0), 25.0, 1e-9) << "|dV| > 0.05";
        } else {
            EXPECT_EQ(c.visibility.all.rmse, 0.0);
        }
    }
}

TEST_F(VisibilityExr, RefusesFilesThatDoNotMatchNamingBoth)
{
    app::writeVisibilityExr(dir / "a.exr", kWidth, kHeight, lights({"sun"}), {ramp(0.0f)});
    app::writeVisibilityExr(dir / "lamp.exr", kWidth, kHeight, lights({"lamp"}), {ramp(0.0f)});
    std::vector<float> small(4, 1.0f);
    app::writeVisibilityExr(dir / "small.exr", 2, 2, lights({"sun"}), {small});
    const app::ExrImage a = app::readExr(dir / "a.exr");

    const std::string sizes = test::errorOf([&] { app::compareExrChannels(a, dir / "a.exr", app::readExr(dir / "small.exr"), dir / "small.exr"); });
    EXPECT_NE(sizes.find("a.exr is 8x4 and"), std::string::npos) << sizes;
    EXPECT_NE(sizes.find("small.exr is 2x2"), std::string::npos) << sizes;

    const std::string channels = test::errorOf([&] { app::compareExrChannels(a, dir / "a.exr", app::readExr(dir / "lamp.exr"), dir / "lamp.exr"); });
    EXPECT_NE(channels.find("hold different channels"), std::string::npos) << channels;
    EXPECT_NE(channels.find("only in " + (dir / "a.exr").string() + ": 'sun.V'"), std::string::npos) << channels;
    EXPECT_NE(channels.find("only in " + (dir / "lamp.exr").string() + ": 'lamp.V'"), std::string::npos) << channels;
}

TEST_F(VisibilityExr, ReadingAFileThatIsNoExrNamesIt)
{
    std::ofstream(dir / "text.exr") << "not an image";
    EXPECT_NE(test::errorOf([&] { app::readExr(dir / "text.exr"); }).find("text.exr: not a readable OpenEXR image"), std::string::npos);
    // A file cut short: an error, never a crash or values made up.
    app::writeVisibilityExr(dir / "whole.exr", kWidth, kHeight, lights({"sun"}), {ramp(0.0f)});
    const std::string bytes = test::readFile(dir / "whole.exr");
    std::ofstream(dir / "cut.exr", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
    EXPECT_NE(test::errorOf([&] { app::readExr(dir / "cut.exr"); }).find("cut.exr"), std::string::npos);
    // A data window of 100000² pixels in a file of a few hundred bytes: refused before
    // anything is allocated for it (kMaxExrSide).
    std::string huge = bytes;
    const std::string window = std::string("dataWindow") + '\0' + "box2i" + '\0';
    const size_t at = huge.find(window);
    ASSERT_NE(at, std::string::npos);
    const int32_t corners[4] = {0, 0, 99999, 99999};
    std::memcpy(huge.data() + at + window.size() + 4, corners, sizeof(corners));  // after the attribute's size
    std::ofstream(dir / "huge.exr", std::ios::binary) << huge;
    const std::string tooBig = test::errorOf([&] { app::readExr(dir / "huge.exr"); });
    EXPECT_NE(tooBig.find("huge.exr: not a readable OpenEXR image"), std::string::npos) << tooBig;
    EXPECT_NE(tooBig.find("exceeds the maximum"), std::string::npos) << tooBig;
    EXPECT_NE(test::errorOf([&] { app::readExr(dir / "missing.exr"); }).find("missing.exr"), std::string::npos);
    EXPECT_NE(test::errorOf([&] { app::readExr(dir); }).find("expected an OpenEXR file"), std::string::npos);
}

} // namespace

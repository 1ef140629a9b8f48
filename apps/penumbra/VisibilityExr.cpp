#include "VisibilityExr.h"

#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"
#include "penumbra/io/ReadFile.h"
#include "penumbra/io/StagedFile.h"

#include <fmt/format.h>

#include <OpenEXR/Iex.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>

#include <algorithm>
#include <cstring>
#include <exception>
#include <set>

namespace penumbra::app {
namespace {

// The bytes of a file already read (io::RegularFile), as OpenEXR reads a file: the file is
// opened and checked once, and a FIFO or device never reaches the library.
class MemoryStream : public Imf::IStream {
public:
    MemoryStream(const std::string& name, const std::vector<unsigned char>& bytes) : Imf::IStream(name.c_str()), bytes_(bytes) {}

    bool read(char c[], int n) override
    {
        if (n < 0 || uint64_t(n) > bytes_.size() - pos_) throw Iex::InputExc("unexpected end of file");
        std::memcpy(c, bytes_.data() + pos_, size_t(n));
        pos_ += uint64_t(n);
        return pos_ < bytes_.size();
    }
    uint64_t tellg() override { return pos_; }
    void seekg(uint64_t pos) override { pos_ = std::min<uint64_t>(pos, bytes_.size()); }

private:
    const std::vector<unsigned char>& bytes_;
    uint64_t pos_ = 0;
};

std::string channelList(const std::vector<std::string>& names)
{
    std::string list;
    for (const std::string& name : names) list += (list.empty() ? "'" : ", '") + core::shortText(name) + "'";
    return list.empty() ? "none" : list;
}

} // namespace

std::string visibilityChannel(const std::string& lightName) { return lightName + ".V"; }

void writeVisibilityExr(const std::filesystem::path& path, uint32_t width, uint32_t height,
                        const std::vector<config::LightConfig>& lights, const std::vector<std::vector<float>>& visibility)
{
    if (width == 0 || height == 0 || lights.size() != visibility.size() || visibility.empty()) {
        throw Error(fmt::format("{}: {} light(s) for {} visibility image(s) of {}x{}", path.string(), lights.size(),
                                visibility.size(), width, height));
    }
    for (size_t l = 0; l < visibility.size(); ++l) {
        if (visibility[l].size() != size_t(width) * height) {
            throw Error(fmt::format("{}: light '{}': {} values for a {}x{} image", path.string(), lights[l].name,
                                    visibility[l].size(), width, height));
        }
    }
    io::StagedFile file(path);
    try {
        Imf::Header header{int(width), int(height)};
        header.compression() = Imf::ZIP_COMPRESSION;
        Imf::FrameBuffer frame;
        const auto addChannel = [&](const std::string& channel, const std::vector<float>& values) {
            header.channels().insert(channel, Imf::Channel(Imf::FLOAT));
            // Imf reads through a non-const pointer but never writes through it here.
            char* base = reinterpret_cast<char*>(const_cast<float*>(values.data()));
            frame.insert(channel, Imf::Slice(Imf::FLOAT, base, sizeof(float), sizeof(float) * width));
        };
        for (size_t l = 0; l < visibility.size(); ++l) addChannel(visibilityChannel(lights[l].name), visibility[l]);
        addChannel(kFirstLightLumaChannel, visibility.front());
        Imf::OutputFile out(file.tempPath().c_str(), header);
        out.setFrameBuffer(frame);
        out.writePixels(int(height));
    } catch (const std::exception& e) {
        throw Error(fmt::format("{}: cannot write the OpenEXR file: {}", path.string(), e.what()));
    }
    file.commit();
}

ExrImage readExr(const std::filesystem::path& path)
{
    const std::vector<unsigned char> bytes = io::readRegularFile(path, kMaxExrFileBytes, "an OpenEXR file");
    const std::string name = core::shortText(path.string());
    try {
        // A damaged header's data window sizes the tables OpenEXR allocates on opening;
        // beyond kMaxExrSide it refuses the file instead.
        Imf::Header::setMaxImageSize(int(kMaxExrSide), int(kMaxExrSide));
        Imf::Header::setMaxTileSize(int(kMaxExrSide), int(kMaxExrSide));
        MemoryStream stream(path.string(), bytes);
        Imf::InputFile file(stream);
        const Imath::Box2i window = file.header().dataWindow();
        const int64_t width = int64_t(window.max.x) - window.min.x + 1, height = int64_t(window.max.y) - window.min.y + 1;
        size_t channels = 0;
        for (auto c = file.header().channels().begin(); c != file.header().channels().end(); ++c) ++channels;
        // Pixels first: with at most 2^28 of them, times the channels cannot overflow.
        const uint64_t pixels = width > 0 && height > 0 ? uint64_t(width) * uint64_t(height) : 0;
        if (pixels == 0) throw Error(fmt::format("{}: an empty data window ({}x{} pixels)", name, width, height));
        if (pixels > kMaxExrValues || pixels * channels > kMaxExrValues) {
            throw Error(fmt::format("{}: {}x{} pixels of {} channel(s): more than the {} values an OpenEXR file may hold here",
                                    name, width, height, channels, kMaxExrValues));
        }
        ExrImage image;
        image.width = uint32_t(width);
        image.height = uint32_t(height);
        Imf::FrameBuffer frame;
        for (auto c = file.header().channels().begin(); c != file.header().channels().end(); ++c) {
            image.channels.push_back({c.name(), std::vector<float>(size_t(width) * size_t(height))});
        }
        for (ExrImage::Channel& channel : image.channels) {
            // The window's first pixel at values[0], wherever the window starts.
            frame.insert(channel.name, Imf::Slice::Make(Imf::FLOAT, channel.values.data(), window, sizeof(float),
                                                        sizeof(float) * size_t(width)));
        }
        file.setFrameBuffer(frame);
        file.readPixels(window.min.y, window.max.y);
        return image;
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        throw Error(fmt::format("{}: not a readable OpenEXR image: {}", name, core::shortText(e.what())));
    }
}

std::vector<ExrChannelComparison> compareExrChannels(const ExrImage& test, const std::filesystem::path& testPath,
                                                     const ExrImage& reference, const std::filesystem::path& referencePath)
{
    const std::string testName = core::shortText(testPath.string()), referenceName = core::shortText(referencePath.string());
    if (test.width != reference.width || test.height != reference.height) {
        throw Error(fmt::format("{} is {}x{} and {} is {}x{}: only images of one size can be compared", testName, test.width,
                                test.height, referenceName, reference.width, reference.height));
    }
    std::set<std::string> testNames, referenceNames;
    for (const ExrImage::Channel& c : test.channels) testNames.insert(c.name);
    for (const ExrImage::Channel& c : reference.channels) referenceNames.insert(c.name);
    if (testNames != referenceNames) {
        std::vector<std::string> onlyTest, onlyReference;
        std::set_difference(testNames.begin(), testNames.end(), referenceNames.begin(), referenceNames.end(), std::back_inserter(onlyTest));
        std::set_difference(referenceNames.begin(), referenceNames.end(), testNames.begin(), testNames.end(),
                            std::back_inserter(onlyReference));
        throw Error(fmt::format("{} and {} hold different channels: only in {}: {}; only in {}: {}", testName, referenceName,
                                testName, channelList(onlyTest), referenceName, channelList(onlyReference)));
    }
    std::vector<ExrChannelComparison> comparisons;
    for (const ExrImage::Channel& t : test.channels) {
        const auto r = std::find_if(reference.channels.begin(), reference.channels.end(),
                                    [&](const ExrImage::Channel& c) { return c.name == t.name; });
        comparisons.push_back({t.name, metrics::compareVisibility({test.width, test.height, t.values},
                                                                  {reference.width, reference.height, r->values})});
    }
    return comparisons;
}

} // namespace penumbra::app

#include "VisibilityExr.h"

#include "penumbra/core/Error.h"
#include "penumbra/io/StagedFile.h"

#include <fmt/format.h>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfOutputFile.h>

#include <exception>

namespace penumbra::app {

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
        for (size_t l = 0; l < visibility.size(); ++l) {
            const std::string channel = visibilityChannel(lights[l].name);
            header.channels().insert(channel, Imf::Channel(Imf::FLOAT));
            // Imf reads through a non-const pointer but never writes through it here.
            char* base = reinterpret_cast<char*>(const_cast<float*>(visibility[l].data()));
            frame.insert(channel, Imf::Slice(Imf::FLOAT, base, sizeof(float), sizeof(float) * width));
        }
        Imf::OutputFile out(file.tempPath().c_str(), header);
        out.setFrameBuffer(frame);
        out.writePixels(int(height));
    } catch (const std::exception& e) {
        throw Error(fmt::format("{}: cannot write the OpenEXR file: {}", path.string(), e.what()));
    }
    file.commit();
}

} // namespace penumbra::app

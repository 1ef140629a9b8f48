#include "ExrFile.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <gtest/gtest.h>

namespace penumbra::test {

Exr readExr(const std::filesystem::path& path)
{
    Imf::InputFile file(path.c_str());
    const Imath::Box2i window = file.header().dataWindow();
    Exr exr;
    exr.width = window.max.x - window.min.x + 1;
    exr.height = window.max.y - window.min.y + 1;
    Imf::FrameBuffer frame;
    for (auto c = file.header().channels().begin(); c != file.header().channels().end(); ++c) {
        EXPECT_EQ(c.channel().type, Imf::FLOAT) << c.name();
        std::vector<float>& values = exr.channels[c.name()];
        values.resize(size_t(exr.width) * exr.height);
        frame.insert(c.name(), Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(values.data()), sizeof(float),
                                          sizeof(float) * size_t(exr.width)));
    }
    file.setFrameBuffer(frame);
    file.readPixels(window.min.y, window.max.y);
    return exr;
}

void writeExr(const std::filesystem::path& path, const Exr& exr)
{
    Imf::Header header(exr.width, exr.height);
    header.compression() = Imf::NO_COMPRESSION;
    Imf::FrameBuffer frame;
    for (const auto& [name, values] : exr.channels) {
        header.channels().insert(name, Imf::Channel(Imf::FLOAT));
        char* base = reinterpret_cast<char*>(const_cast<float*>(values.data()));
        frame.insert(name, Imf::Slice(Imf::FLOAT, base, sizeof(float), sizeof(float) * size_t(exr.width)));
    }
    Imf::OutputFile file(path.c_str(), header);
    file.setFrameBuffer(frame);
    file.writePixels(exr.height);
}

} // namespace penumbra::test

#include "scene/gltf/Images.h"

#include "scene/gltf/Document.h"

#include <fmt/format.h>
#include <stb/stb_image.h>

#include <cstring>
#include <vector>

namespace penumbra::scene::gltf {
namespace {

// stb_image gives 16-bit PNGs 16 bits per channel; the scene keeps RGBA8.
void narrowTo8Bits(tinygltf::Image& image)
{
    std::vector<unsigned char> narrow(image.image.size() / 2);
    for (size_t i = 0; i < narrow.size(); ++i) {
        uint16_t v;
        std::memcpy(&v, &image.image[2 * i], sizeof v);
        narrow[i] = static_cast<unsigned char>((uint32_t(v) * 255u + 32767u) / 65535u);
    }
    image.image.swap(narrow);
    image.bits = 8;
    image.pixel_type = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE;
}

bool decodeImage(tinygltf::Image* image, const int index, std::string* /*err*/, std::string* warn, int requiredWidth,
                 int requiredHeight, const unsigned char* bytes, int size, void* user)
{
    ImageDecoder& decoder = *static_cast<ImageDecoder*>(user);
    auto refuse = [&](std::string why) {
        decoder.failures[index] = std::move(why);
        image->image.clear();
        return true;  // the parse goes on; a material that uses the image fails the load
    };
    if (image->bufferView >= 0) {
        // tinygltf hands over the view's bytes without checking them against the buffer.
        const tinygltf::BufferView& view = decoder.model->bufferViews.at(size_t(image->bufferView));
        const size_t bufferBytes = decoder.model->buffers.at(size_t(view.buffer)).data.size();
        if (view.byteOffset > bufferBytes || view.byteLength > bufferBytes - view.byteOffset) {
            return refuse(fmt::format("buffer view {} (byteOffset {} + byteLength {}) exceeds buffer {} ({} bytes)",
                                      image->bufferView, view.byteOffset, view.byteLength, view.buffer, bufferBytes));
        }
    }
    int width = 0, height = 0, channels = 0;
    if (!stbi_info_from_memory(bytes, size, &width, &height, &channels)) {
        return refuse(fmt::format("not an image stb_image can decode ({}){}", stbi_failure_reason(),
                                  image->mimeType.empty() ? "" : fmt::format(", mimeType {}", image->mimeType)));
    }
    const uint64_t texels = uint64_t(width) * uint64_t(height);
    if (texels > decoder.maxImageTexels) {
        return refuse(fmt::format("{}×{} texels exceed the limit of {} per image", width, height, decoder.maxImageTexels));
    }
    if (texels > decoder.texelsLeft) {
        return refuse(fmt::format("{}×{} texels exceed the {} left of the limit for all the file's images", width, height,
                                  decoder.texelsLeft));
    }
    decoder.texelsLeft -= texels;
    // No option block: tinygltf's default expands every image to 4 channels.
    std::string decodeError;
    if (!tinygltf::LoadImageData(image, index, &decodeError, warn, requiredWidth, requiredHeight, bytes, size, nullptr)) {
        return refuse(oneLine(decodeError));
    }
    if (image->bits == 16) narrowTo8Bits(*image);
    return true;
}

} // namespace

void ImageDecoder::install(tinygltf::TinyGLTF& loader) { loader.SetImageLoader(decodeImage, this); }

} // namespace penumbra::scene::gltf

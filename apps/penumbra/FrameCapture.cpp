#include "FrameCapture.h"

namespace penumbra::app {

FrameImages captureFrame(const frame::FrameRenderer& renderer)
{
    FrameImages images;
    images.width = renderer.width();
    images.height = renderer.height();
    images.color = renderer.readColor();
    images.positions = renderer.readPositions();
    for (size_t i = 0; i < renderer.lightCount(); ++i) {
        images.visibility.push_back(renderer.readVisibility(i));
        images.techniques.push_back(renderer.techniqueName(i));
    }
    return images;
}

} // namespace penumbra::app

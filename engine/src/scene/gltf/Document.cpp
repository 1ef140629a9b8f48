#include "scene/gltf/Document.h"

#include "penumbra/core/Error.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

namespace penumbra::scene::gltf {
namespace {

std::string message(const std::string& file, std::string_view element, std::string_view what)
{
    return element.empty() ? fmt::format("{}: {}", file, what) : fmt::format("{}: {}: {}", file, element, what);
}

} // namespace

std::string oneLine(std::string text)
{
    while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
    for (size_t at = text.find('\n'); at != std::string::npos; at = text.find('\n', at)) text.replace(at, 1, "; ");
    return text;
}

void Document::fail(std::string_view element, std::string_view what) const
{
    throw AssetError(message(file, element, what));
}

void Document::warn(std::string_view element, std::string_view what) const
{
    report.warnings.push_back(message(file, element, what));
    spdlog::warn("{}", report.warnings.back());
}

void Document::note(std::string_view element, std::string_view what) const
{
    report.notes.push_back(message(file, element, what));
    spdlog::info("{}", report.notes.back());
}

} // namespace penumbra::scene::gltf

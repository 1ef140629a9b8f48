#pragma once
// Where the engine and its plugins keep what they may recompute (the plugin scan, SPIR-V,
// reference images): the XDG base directory spec's user cache folder.
#include <filesystem>

namespace penumbra::io {

// $XDG_CACHE_HOME/penumbra, else $HOME/.cache/penumbra; a relative XDG_CACHE_HOME or HOME
// is invalid under the spec and ignored. Empty (nothing is cached) when neither is known.
std::filesystem::path userCacheFolder();

} // namespace penumbra::io

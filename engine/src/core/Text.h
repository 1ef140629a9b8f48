#pragma once
// Text helpers for messages: "did you mean" suggestions for misspelt names (public, for the
// apps too: penumbra/core/ClosestMatch.h), what kind of file a path names.
#include "penumbra/core/ClosestMatch.h"

#include <filesystem>

namespace penumbra::core {

// What a file that is not a regular one is, for "<path>: is a FIFO (named pipe), expected
// ...": "a directory", "a FIFO (named pipe)", "a socket", "a block device", ...
const char* fileTypeName(std::filesystem::file_type type);

} // namespace penumbra::core

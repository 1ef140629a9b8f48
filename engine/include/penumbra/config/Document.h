#pragma once
// A config file as JSON, with its includes merged, and for each value the file it came
// from: what config/Config.h reads a RenderConfig from, and config/Sweep.h expands.
#include "penumbra/core/ShortText.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <string_view>

namespace penumbra::config {

// A config file with its includes resolved: the merged document, and for each JSON
// path the file its value came from (for messages).
struct ConfigDocument {
    std::filesystem::path file;
    nlohmann::json json;
    std::map<std::string, std::string> origin;  // JSON pointer -> file name
    std::string fileFor(const std::string& pointer) const;
};

// Objects and arrays nest at most this deep in a config file (the shipped configs nest 5
// levels). Checked while the file is parsed, before anything walks the value
// recursively: a hostile file nested 40,000 levels deep overflowed the stack and took
// memory quadratic in its depth. Sweep paths address at most this many levels too.
inline constexpr int kMaxConfigNesting = 64;

// A config file (and each file it includes) is at most this big: the shipped ones are a
// few KB, and the JSON library holds a file in about ten times its size.
inline constexpr uintmax_t kMaxConfigBytes = uintmax_t(64) << 20;

// A config loads at most this many files, itself and every include (an include of an
// include counts too), and at most kMaxConfigBytes in all: six files each including the
// next 40 times would load 40^5 files. The shipped configs load one or two.
inline constexpr size_t kMaxConfigFiles = 100;

// Reads `file` and its includes: `"include": "base.json"` or a list, paths relative to
// the including file, merged in order with RFC 7386 merge-patch semantics (objects merge
// key by key, everything else - arrays too - is replaced, null removes a key), then the
// including file on top. Include cycles and missing files are errors naming the chain.
// Every error is a ConfigError naming the file and, where the JSON is at fault, the JSON
// path: malformed JSON (with line and column), a number beyond a double's range, nesting
// beyond kMaxConfigNesting, a file name the file system refuses (too long: shown
// shortened), a file that is not a regular one (a FIFO, a device) or is beyond
// kMaxConfigBytes, more than kMaxConfigFiles files or kMaxConfigBytes in all (naming the
// include chain).
ConfigDocument loadDocument(const std::filesystem::path& file);

// A path for a message, shortened (core::shortText).
inline std::string displayPath(const std::filesystem::path& path) { return core::shortText(path.string()); }

} // namespace penumbra::config

#pragma once
// A config file as JSON, with its includes merged, and for each value the file it came
// from: what config/Config.h reads a RenderConfig from, and config/Sweep.h expands.
#include <nlohmann/json.hpp>

#include <filesystem>
#include <map>
#include <string>

namespace penumbra::config {

// A config file with its includes resolved: the merged document, and for each JSON
// path the file its value came from (for messages).
struct ConfigDocument {
    std::filesystem::path file;
    nlohmann::json json;
    std::map<std::string, std::string> origin;  // JSON pointer -> file name
    std::string fileFor(const std::string& pointer) const;
};

// Reads `file` and its includes: `"include": "base.json"` or a list, paths relative to
// the including file, merged in order with RFC 7386 merge-patch semantics (objects merge
// key by key, everything else - arrays too - is replaced, null removes a key), then the
// including file on top. Include cycles and missing files are errors naming the chain.
ConfigDocument loadDocument(const std::filesystem::path& file);

} // namespace penumbra::config

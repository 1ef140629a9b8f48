#pragma once
// Parsing a config file's text into JSON in time linear in its size, with the nesting
// limit (kMaxConfigNesting) checked as each object or array opens and the JSON pointer of
// the value being read kept, so that every error names the file and the path.
//
// A SAX handler of its own builds the value: nlohmann's parser with a callback (the
// obvious way to watch the events) scans an object's parent for discarded values each
// time the object closes, which made a file of 200,000 empty objects take 14 s.
#include <nlohmann/json.hpp>

#include <cstddef>
#include <filesystem>
#include <istream>

namespace penumbra::config {

// How much work a parse did, for tests that bound it by the input's size: `events` SAX
// events, `steps` container operations (each event does a bounded number).
struct ConfigJsonWork {
    size_t events = 0;
    size_t steps = 0;
};

// The JSON in `in`, read from `file` (for messages). Throws ConfigError "file: what" for
// malformed JSON (with line and column), "file: /pointer: what" for nesting deeper than
// kMaxConfigNesting or a number beyond a double's range.
nlohmann::json parseConfigJson(std::istream& in, const std::filesystem::path& file, ConfigJsonWork* work = nullptr);

} // namespace penumbra::config

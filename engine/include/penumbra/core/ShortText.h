#pragma once
// Values that messages echo, shortened: a message names what was wrong and where, and a
// 1 MB value (a string in a config, a command-line argument) must not become 1 MB of
// stderr. Every error that quotes a value the user gave goes through these.
#include <nlohmann/json.hpp>

#include <cstddef>
#include <string>
#include <string_view>

namespace penumbra::core {

// Text (or a JSON value's text) up to this many characters is shown whole.
inline constexpr size_t kShownChars = 160;

// `text` (a path, a JSON pointer, a name, an argument) for a message: whole up to
// kShownChars characters, else its start and end around "…" with its length in
// characters. Cuts fall between UTF-8 characters, never inside one.
std::string shortText(std::string_view text);

// `value` as JSON text for a message (compact, as nlohmann::json::dump() writes it), at
// most about kShownChars characters: a long string as its start and end around "…" with
// its length, an array or object as its first elements then "…" with its element count
// ("[1,2,3,…] (1000000 elements)"). Only the part shown is ever serialised, so a huge
// value costs no more than a small one. Non-finite numbers (a program can build them, JSON
// cannot hold them) read "nan", "inf"; bytes that are not UTF-8 are shown as U+FFFD
// rather than failing.
std::string shortJson(const nlohmann::json& value);

} // namespace penumbra::core

#include "Script.h"

#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"
#include "penumbra/io/ReadFile.h"

#include <fmt/format.h>

#include <cstdint>

namespace penumbra::viewer {

std::vector<ScriptCommand> parseScript(const std::string& text, const std::string& source, bool semicolons)
{
    std::vector<ScriptCommand> commands;
    int line = 1, commandIndex = 1;
    ScriptCommand current;
    std::string word;
    bool inWord = false, quoted = false, comment = false;
    auto where = [&] { return semicolons ? fmt::format("{} {}", source, commandIndex) : fmt::format("{}:{}", source, line); };
    auto endWord = [&] {
        if (inWord) current.words.push_back(word);
        word.clear();
        inWord = false;
    };
    auto endCommand = [&] {
        endWord();
        if (!current.words.empty()) {
            current.where = where();
            commands.push_back(std::move(current));
            ++commandIndex;
        }
        current = {};
    };
    for (char c : text) {
        if (c == '\n') {
            if (quoted) throw Error(fmt::format("{}: a \" is not closed on its line", where()));
            comment = false;
            endCommand();
            ++line;
            continue;
        }
        if (comment) continue;
        if (quoted) {
            if (c == '"') {
                quoted = false;
            } else {
                word += c;
            }
            continue;
        }
        if (c == '"') {
            quoted = true;
            inWord = true;
        } else if (c == '#' && !inWord) {
            comment = true;
        } else if (c == ';' && semicolons) {
            endCommand();
        } else if (c == ' ' || c == '\t' || c == '\r') {
            endWord();
        } else {
            word += c;
            inWord = true;
        }
    }
    if (quoted) throw Error(fmt::format("{}: a \" is not closed", where()));
    endCommand();
    return commands;
}

std::vector<ScriptCommand> readScript(const std::filesystem::path& file)
{
    // A script is a few lines of commands; a FIFO or a device would block or never end.
    constexpr uint64_t kMaxScriptBytes = uint64_t(16) << 20;
    std::string text;
    try {
        text = io::readRegularTextFile(file, kMaxScriptBytes, "a viewer script");
    } catch (const io::FileReadError& e) {
        throw Error(fmt::format("{}: {}", core::shortText(file.string()), e.reason()));
    }
    return parseScript(text, file.string(), false);
}

} // namespace penumbra::viewer

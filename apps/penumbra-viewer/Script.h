#pragma once
// Viewer scripts: what `penumbra-viewer --script FILE` and `--exec "..."` run, one command
// per line (or per `;` in --exec), words split at blanks, "double quotes" around a word
// with blanks, `#` to the end of the line a comment. Viewer.cpp runs them between frames
// through the command table (CommandTable.h, ViewerCommands.cpp), which docs/viewer.md lists.
#include <filesystem>
#include <string>
#include <vector>

namespace penumbra::viewer {

struct ScriptCommand {
    std::string where;               // "scene.script:3" or "--exec 2": for messages
    std::vector<std::string> words;  // the command and its arguments
};

// Throws Error naming the file (unreadable) or the line (an unterminated quote).
std::vector<ScriptCommand> readScript(const std::filesystem::path& file);
// `text`'s commands, lines and `;` separating them; `source` names them ("--exec").
std::vector<ScriptCommand> parseScript(const std::string& text, const std::string& source, bool semicolons);

} // namespace penumbra::viewer

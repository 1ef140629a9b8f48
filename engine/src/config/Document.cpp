#include "penumbra/config/Document.h"

#include "penumbra/core/Error.h"
#include "penumbra/io/ReadFile.h"

#include "config/ConfigJson.h"

#include <fmt/format.h>

#include <algorithm>
#include <sstream>
#include <vector>

using nlohmann::json;
namespace fs = std::filesystem;

namespace penumbra::config {
namespace {

// Records, for every JSON path in `value` down through its objects, that it came from
// `file`. Arrays are not entered: merging replaces an array whole, so all of it comes
// from one file, and the origins stay as many as the objects' keys however long the
// arrays (400,000 animation keys) are.
void recordOrigin(const json& value, const std::string& pointer, const std::string& file,
                  std::map<std::string, std::string>& origin)
{
    origin[pointer] = file;
    if (!value.is_object()) return;
    for (auto it = value.begin(); it != value.end(); ++it) recordOrigin(*it, pointer + "/" + it.key(), file, origin);
}

// `file`'s JSON; `includedAt` ("a.json: /include/0: ", empty for the config itself)
// starts the message of a file that cannot be read.
json readJson(const fs::path& file, const std::string& includedAt)
{
    // A FIFO would block the read forever, a device (/dev/zero, /dev/stdin) read without
    // end or wait for a terminal, /proc/self/mem fail to read: only a regular file (or a
    // link to one) of bounded size is read.
    std::string text;
    try {
        text = io::readRegularTextFile(file, kMaxConfigBytes, "a JSON config file");
    } catch (const io::FileReadError& e) {
        throw ConfigError(fmt::format("{}{}: {}", includedAt, displayPath(file),
                                      e.problem() == io::FileReadProblem::NotFound ? "config file not found" : e.reason()));
    }
    std::istringstream in(std::move(text));
    return parseConfigJson(in, file);
}

// `path` made absolute and normal, for include-cycle checks; a ConfigError when the file
// system refuses it (a name too long), naming `where`.
fs::path canonicalFor(const fs::path& path, const std::string& where)
{
    std::error_code ec;
    fs::path canonical = fs::weakly_canonical(path, ec);
    if (ec) throw ConfigError(fmt::format("{}cannot resolve {}: {}", where, displayPath(path), ec.message()));
    return canonical;
}

// The files a config has loaded so far with its includes, and the include chain that
// leads to the one being loaded.
struct IncludeWalk {
    std::vector<fs::path> chain;  // canonical paths, the config first
    size_t files = 0;
    uintmax_t bytes = 0;

    std::string chainText() const
    {
        std::string text;
        for (const fs::path& p : chain) text += (text.empty() ? "" : " -> ") + displayPath(p.filename());
        return text;
    }

    // Counts `file` (included at `at`, empty for the config itself) against the limits on
    // the files and bytes one config loads: a few files each including the next many
    // times would otherwise load exponentially many.
    void count(const fs::path& file, const std::string& at)
    {
        if (++files > kMaxConfigFiles) {
            throw ConfigError(fmt::format("{}{} would be file {} of this config; a config loads at most {} files with "
                                          "its includes (include chain: {})",
                                          at, displayPath(file), files, kMaxConfigFiles, chainText()));
        }
        std::error_code ec;
        // A file that is not a regular one, or is beyond the limit alone, is refused by
        // readJson, which says so.
        if (const uintmax_t size = fs::file_size(file, ec); !ec && size <= kMaxConfigBytes) bytes += size;
        if (bytes > kMaxConfigBytes) {
            throw ConfigError(fmt::format("{}{}: the config and its includes come to {} bytes with this file; they hold "
                                          "at most {} MiB together (include chain: {})",
                                          at, displayPath(file), bytes, kMaxConfigBytes >> 20, chainText()));
        }
    }
};

ConfigDocument loadWithIncludes(const fs::path& file, IncludeWalk& walk, const std::string& includedAt)
{
    std::vector<fs::path>& chain = walk.chain;
    const fs::path canonical = canonicalFor(file, includedAt);
    walk.count(file, includedAt);
    ConfigDocument doc;
    doc.file = file;
    json own = readJson(file, includedAt);
    if (!own.is_object()) throw ConfigError(fmt::format("{}: /: must be an object, got {}", file.string(), own.type_name()));
    chain.push_back(canonical);
    doc.json = json::object();
    if (auto it = own.find("include"); it != own.end()) {
        std::vector<std::string> includes;
        if (it->is_string()) {
            includes.push_back(it->get<std::string>());
        } else if (it->is_array() && std::all_of(it->begin(), it->end(), [](const json& e) { return e.is_string(); })) {
            for (const json& e : *it) includes.push_back(e.get<std::string>());
        } else {
            throw ConfigError(fmt::format("{}: /include: must be a file name or an array of file names, got {}",
                                          displayPath(file), core::shortJson(*it)));
        }
        for (size_t i = 0; i < includes.size(); ++i) {
            fs::path path = includes[i];
            if (path.is_relative()) path = file.parent_path() / path;
            const std::string at = fmt::format("{}: /include{}: ", displayPath(file), it->is_string() ? "" : fmt::format("/{}", i));
            if (std::find(chain.begin(), chain.end(), canonicalFor(path, at)) != chain.end()) {
                std::string cycle;
                for (const fs::path& p : chain) cycle += displayPath(p.filename()) + " -> ";
                throw ConfigError(fmt::format("{}: /include/{}: include cycle: {}{}", displayPath(file), i, cycle,
                                              displayPath(path.filename())));
            }
            std::error_code ec;
            if (!fs::exists(path, ec)) {
                throw ConfigError(fmt::format("{}included file {}: {}", at, ec ? "cannot be opened" : "not found",
                                              ec ? fmt::format("{}: {}", displayPath(path), ec.message()) : displayPath(path)));
            }
            ConfigDocument included = loadWithIncludes(path, walk, at);
            doc.json.merge_patch(included.json);
            for (auto& [pointer, origin] : included.origin) doc.origin[pointer] = origin;
        }
        own.erase("include");
    }
    chain.pop_back();
    doc.json.merge_patch(own);
    recordOrigin(own, "", file.string(), doc.origin);
    return doc;
}

} // namespace

std::string ConfigDocument::fileFor(const std::string& pointer) const
{
    // The nearest recorded ancestor: a key that is missing was missing in the file that
    // holds its parent object.
    std::string p = pointer;
    while (true) {
        if (auto it = origin.find(p); it != origin.end()) return it->second;
        if (p.empty()) return file.string();
        p = p.substr(0, p.rfind('/'));
    }
}

ConfigDocument loadDocument(const fs::path& file)
{
    IncludeWalk walk;
    return loadWithIncludes(file, walk, "");
}

} // namespace penumbra::config

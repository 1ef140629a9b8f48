#include "penumbra/config/Document.h"

#include "penumbra/core/Error.h"

#include <fmt/format.h>

#include <algorithm>
#include <fstream>
#include <vector>

using nlohmann::json;
namespace fs = std::filesystem;

namespace penumbra::config {
namespace {

// Records, for every JSON path in `value`, that it came from `file`.
void recordOrigin(const json& value, const std::string& pointer, const std::string& file,
                  std::map<std::string, std::string>& origin)
{
    origin[pointer] = file;
    if (value.is_object()) {
        for (auto it = value.begin(); it != value.end(); ++it) recordOrigin(*it, pointer + "/" + it.key(), file, origin);
    } else if (value.is_array()) {
        for (size_t i = 0; i < value.size(); ++i) recordOrigin(value[i], fmt::format("{}/{}", pointer, i), file, origin);
    }
}

json readJson(const fs::path& file)
{
    std::error_code ec;
    if (!fs::exists(file, ec)) throw ConfigError(fmt::format("{}: config file not found", file.string()));
    if (fs::is_directory(file, ec)) throw ConfigError(fmt::format("{}: is a directory, expected a JSON config file", file.string()));
    std::ifstream in(file, std::ios::binary);
    if (!in) throw ConfigError(fmt::format("{}: cannot open config file for reading", file.string()));
    try {
        return json::parse(in);
    } catch (const json::parse_error& e) {
        // nlohmann's message carries line and column: "parse error at line 3, column 5: ...".
        std::string what = e.what();
        if (auto pos = what.find("parse error"); pos != std::string::npos) what = what.substr(pos);
        throw ConfigError(fmt::format("{}: malformed JSON: {}", file.string(), what));
    }
}

ConfigDocument loadWithIncludes(const fs::path& file, std::vector<fs::path>& chain)
{
    const fs::path canonical = fs::weakly_canonical(file);
    ConfigDocument doc;
    doc.file = file;
    json own = readJson(file);
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
                                          file.string(), it->dump()));
        }
        for (size_t i = 0; i < includes.size(); ++i) {
            fs::path path = includes[i];
            if (path.is_relative()) path = file.parent_path() / path;
            if (std::find(chain.begin(), chain.end(), fs::weakly_canonical(path)) != chain.end()) {
                std::string cycle;
                for (const fs::path& p : chain) cycle += p.filename().string() + " -> ";
                throw ConfigError(fmt::format("{}: /include/{}: include cycle: {}{}", file.string(), i, cycle,
                                              path.filename().string()));
            }
            std::error_code ec;
            if (!fs::exists(path, ec)) {
                throw ConfigError(fmt::format("{}: /include{}: included file not found: {}", file.string(),
                                              it->is_string() ? "" : fmt::format("/{}", i), path.string()));
            }
            ConfigDocument included = loadWithIncludes(path, chain);
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
    std::vector<fs::path> chain;
    return loadWithIncludes(file, chain);
}

} // namespace penumbra::config

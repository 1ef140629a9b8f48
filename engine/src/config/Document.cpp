#include "penumbra/config/Document.h"

#include "penumbra/core/Error.h"

#include "core/Text.h"

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

// Where the parser is in the document, kept from its callback's events so that an error
// names the JSON path it occurred at; and the nesting limit, checked as each object or
// array opens.
class ParsePlace {
public:
    explicit ParsePlace(const fs::path& file) : file_(file) {}

    bool event(nlohmann::json::parse_event_t event, const json& parsed)
    {
        using Event = nlohmann::json::parse_event_t;
        switch (event) {
        case Event::object_start:
        case Event::array_start:
            if (frames_.size() >= size_t(kMaxConfigNesting)) {
                throw ConfigError(fmt::format("{}: {}: nested deeper than {} levels of objects and arrays (a config "
                                              "needs a handful)",
                                              displayPath(file_), pointer(), kMaxConfigNesting));
            }
            frames_.push_back({event == Event::array_start, 0, {}});
            break;
        case Event::key: frames_.back().key = parsed.get<std::string>(); break;
        case Event::object_end:
        case Event::array_end:
            frames_.pop_back();
            advance();
            break;
        case Event::value: advance(); break;
        }
        return true;
    }

    // The JSON pointer of the value being read.
    std::string pointer() const
    {
        std::string out;
        for (const Frame& f : frames_) out += f.array ? fmt::format("/{}", f.next) : "/" + f.key;
        return out.empty() ? "/" : out;
    }

private:
    struct Frame {
        bool array = false;
        size_t next = 0;  // arrays: the index of the element being read
        std::string key;  // objects: the key of the value being read
    };
    void advance()
    {
        if (!frames_.empty() && frames_.back().array) ++frames_.back().next;
    }

    fs::path file_;
    std::vector<Frame> frames_;
};

json readJson(const fs::path& file)
{
    std::error_code ec;
    const bool exists = fs::exists(file, ec);
    if (ec) throw ConfigError(fmt::format("{}: cannot open config file: {}", displayPath(file), ec.message()));
    if (!exists) throw ConfigError(fmt::format("{}: config file not found", displayPath(file)));
    // A FIFO would block the read forever, a device (/dev/zero, /dev/stdin) read without
    // end or wait for a terminal: only a regular file (or a link to one) is read.
    if (const fs::file_type type = fs::status(file, ec).type(); type != fs::file_type::regular)
        throw ConfigError(fmt::format("{}: is {}, expected a JSON config file (a regular file)", displayPath(file),
                                      core::fileTypeName(type)));
    if (const uintmax_t bytes = fs::file_size(file, ec); !ec && bytes > kMaxConfigBytes) {
        throw ConfigError(fmt::format("{}: is {} bytes; a config file holds at most {} MiB (its scene is a glTF file)",
                                      displayPath(file), bytes, kMaxConfigBytes >> 20));
    }
    std::ifstream in(file, std::ios::binary);
    if (!in) throw ConfigError(fmt::format("{}: cannot open config file for reading", displayPath(file)));
    ParsePlace place(file);
    try {
        return json::parse(in, [&place](int, nlohmann::json::parse_event_t event, json& parsed) {
            return place.event(event, parsed);
        });
    } catch (const json::parse_error& e) {
        // nlohmann's message carries line and column: "parse error at line 3, column 5: ...".
        std::string what = e.what();
        if (auto pos = what.find("parse error"); pos != std::string::npos) what = what.substr(pos);
        throw ConfigError(fmt::format("{}: malformed JSON: {}", displayPath(file), what));
    } catch (const json::out_of_range& e) {
        // 406: "number overflow parsing '1e309'": a number no double holds.
        std::string what = e.what();
        if (auto pos = what.find("] "); pos != std::string::npos) what = what.substr(pos + 2);
        throw ConfigError(fmt::format("{}: {}: {} (a number must lie within a double's range, about ±1.8e308)",
                                      displayPath(file), place.pointer(), what));
    } catch (const json::exception& e) {
        throw ConfigError(fmt::format("{}: {}: cannot read the JSON: {}", displayPath(file), place.pointer(), e.what()));
    }
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

ConfigDocument loadWithIncludes(const fs::path& file, std::vector<fs::path>& chain)
{
    const fs::path canonical = canonicalFor(file, "");
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
            const std::string at = fmt::format("{}: /include{}: ", displayPath(file), it->is_string() ? "" : fmt::format("/{}", i));
            if (std::find(chain.begin(), chain.end(), canonicalFor(path, at)) != chain.end()) {
                std::string cycle;
                for (const fs::path& p : chain) cycle += p.filename().string() + " -> ";
                throw ConfigError(fmt::format("{}: /include/{}: include cycle: {}{}", file.string(), i, cycle,
                                              path.filename().string()));
            }
            std::error_code ec;
            if (!fs::exists(path, ec)) {
                throw ConfigError(fmt::format("{}included file {}: {}", at, ec ? "cannot be opened" : "not found",
                                              ec ? fmt::format("{}: {}", displayPath(path), ec.message()) : displayPath(path)));
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

std::string shortText(std::string_view s)
{
    constexpr size_t kWhole = 160, kHead = 80, kTail = 60;
    if (s.size() <= kWhole) return std::string(s);
    return fmt::format("{}…{} ({} characters)", s.substr(0, kHead), s.substr(s.size() - kTail), s.size());
}

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

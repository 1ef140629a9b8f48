#include "scene/gltf/Uri.h"

#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"
#include "penumbra/io/ReadFile.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>

namespace fs = std::filesystem;

namespace penumbra::scene::gltf {
namespace {

bool isControl(unsigned char c) { return c < 0x20 || c == 0x7F; }

int hexValue(char c)
{
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

// RFC 3986 percent-decoding (§2.1): "%2E%2E" is "..", "a%20b" is "a b", '+' is itself.
// `why` says why the URI is refused: a '%' not followed by two hex digits, or a NUL or
// another control character, written or decoded (it would cut the name short or hide
// part of it in a message).
std::string decodePercent(std::string_view uri, std::string& why)
{
    std::string decoded;
    for (size_t i = 0; i < uri.size(); ++i) {
        unsigned char c = static_cast<unsigned char>(uri[i]);
        if (c == '%') {
            const int high = i + 1 < uri.size() ? hexValue(uri[i + 1]) : -1;
            const int low = i + 2 < uri.size() ? hexValue(uri[i + 2]) : -1;
            if (high < 0 || low < 0) {
                why = fmt::format("malformed percent escape at character {} (a '%' must be followed by two hex digits)", i + 1);
                return {};
            }
            c = static_cast<unsigned char>(high * 16 + low);
            if (isControl(c)) {
                why = fmt::format("decodes to a NUL or control character (%{:02X} at character {})", c, i + 1);
                return {};
            }
            i += 2;
        } else if (isControl(c)) {
            why = fmt::format("holds a NUL or control character (at character {})", i + 1);
            return {};
        }
        decoded += char(c);
    }
    return decoded;
}

// The path tinygltf 2.7 asks its file callbacks for (LoadExternalFile after
// dlib::urldecode, joined to the base directory by JoinPath): '+' becomes a space, '%'
// and the two characters after it a byte. Only a key here, never opened.
std::string tinygltfPath(const std::string& baseDir, std::string_view uri)
{
    std::string decoded;
    for (size_t i = 0; i < uri.size(); ++i) {
        if (uri[i] == '+') {
            decoded += ' ';
        } else if (uri[i] == '%' && uri.size() > i + 2) {
            decoded += char(std::max(hexValue(uri[i + 1]), 0) * 16 + std::max(hexValue(uri[i + 2]), 0));
            i += 2;
        } else {
            decoded += uri[i];
        }
    }
    if (baseDir.empty()) return decoded;
    return baseDir.back() == '/' ? baseDir + decoded : baseDir + "/" + decoded;
}

// The URI's scheme ("file", "http", "data"), empty for a relative reference: RFC 3986
// §3.1, a letter then letters, digits, '+', '-' or '.', ended by a ':' that comes before
// any '/' (a relative path whose first segment has a ':' is written "./a:b").
std::string schemeOf(std::string_view uri)
{
    const size_t colon = uri.find(':');
    if (colon == std::string_view::npos || colon == 0 || uri.substr(0, colon).find('/') != std::string_view::npos) return {};
    if (!std::isalpha(static_cast<unsigned char>(uri[0]))) return {};
    std::string scheme;
    for (char c : uri.substr(0, colon)) {
        if (!std::isalnum(static_cast<unsigned char>(c)) && c != '+' && c != '-' && c != '.') return {};
        scheme += char(std::tolower(static_cast<unsigned char>(c)));
    }
    return scheme;
}

// Whether canonical `file` is `root` or lies under it (both canonical).
bool within(const fs::path& file, const fs::path& root)
{
    std::string prefix = root.string();
    const std::string path = file.string();
    if (path == prefix) return true;
    if (prefix.empty() || prefix.back() != '/') prefix += '/';
    return path.rfind(prefix, 0) == 0;
}

fs::path canonicalFolder(const fs::path& folder)
{
    std::error_code ec;
    const fs::path absolute = fs::absolute(folder.empty() ? fs::path(".") : folder, ec);
    fs::path canonical = fs::weakly_canonical(ec ? folder : absolute, ec);
    return ec ? absolute.lexically_normal() : canonical;
}

} // namespace

ExternalFiles::ExternalFiles(const fs::path& modelFile, const std::vector<fs::path>& allowedRoots, uint64_t& bytesLeft,
                             uint64_t maxBytesRead)
    : modelName_(core::shortText(modelFile.string())), baseDir_(modelFile.parent_path().string()),
      modelDir_(canonicalFolder(modelFile.parent_path())), bytesLeft_(bytesLeft), maxBytesRead_(maxBytesRead)
{
    roots_.push_back(modelDir_);
    for (const fs::path& root : allowedRoots) roots_.push_back(canonicalFolder(root));
}

fs::path ExternalFiles::add(const std::string& pointer, const std::string& uri)
{
    if (tinygltf::IsDataURI(uri)) return {};
    const auto refuse = [&](const std::string& why) {
        return AssetError(fmt::format("{}: {}: {}: {}", modelName_, pointer, core::shortJson(uri), why));
    };
    if (uri.empty()) throw refuse("is empty, which would name the model's own file");
    std::string why;
    const std::string decoded = decodePercent(uri, why);
    if (!why.empty()) throw refuse(why);
    if (const std::string scheme = schemeOf(uri); scheme == "data") {
        // Never a file. An image's (image/webp, say) is left to tinygltf, which keeps the
        // image without pixels: only a material that uses it fails the load.
        if (pointer.rfind("/images/", 0) == 0) return {};
        throw refuse("is a data: URI tinygltf cannot decode (base64 of application/octet-stream or "
                     "application/gltf-buffer)");
    } else if (!scheme.empty()) {
        throw refuse(fmt::format("is a {}: URI; a glTF file names its files by paths relative to its folder (or "
                                 "embeds them as data: URIs)",
                                 core::shortText(scheme)));
    }
    if (uri.find_first_of("?#") != std::string::npos) {
        throw refuse("has a query or fragment ('?', '#'); in a file name these characters are written %3F and %23");
    }
    if (decoded.front() == '/') throw refuse("is an absolute path; a glTF file names its files relative to its folder");
    std::error_code ec;
    const fs::path path = fs::weakly_canonical(modelDir_ / decoded, ec);
    if (ec) throw refuse(fmt::format("cannot be resolved: {}", ec.message()));
    if (std::none_of(roots_.begin(), roots_.end(), [&](const fs::path& root) { return within(path, root); })) {
        throw refuse(fmt::format("names {}, outside the model's folder {}{}; name its folder as an allowed root to read it "
                                 "(\"scene\": {{\"allowed_roots\": [...]}} in a config, --allow-root on the command line)",
                                 core::shortText(path.string()), core::shortText(modelDir_.string()),
                                 roots_.size() > 1 ? " and the allowed roots" : ""));
    }
    const std::string key = tinygltfPath(baseDir_, uri);
    const auto [it, added] = byKey_.try_emplace(key, File{pointer, uri, path, {}});
    if (!added && it->second.path != path) {
        throw refuse(fmt::format("tinygltf reads it as it reads {} ({}), which names another file ('+' is a space to "
                                 "tinygltf): rename one of the files",
                                 core::shortJson(it->second.uri), it->second.pointer));
    }
    keyOf_[pointer] = key;
    return path;
}

void ExternalFiles::install(tinygltf::TinyGLTF& loader)
{
    // ExpandFilePath as tinygltf's own (the path unchanged); writing is never asked for.
    loader.SetFsCallbacks({&exists, &tinygltf::ExpandFilePath, &read, &tinygltf::WriteWholeFile, this});
}

bool ExternalFiles::exists(const std::string& key, void* self)
{
    // tinygltf then tries the working folder ("./" + URI): never a file resolved here.
    return static_cast<const ExternalFiles*>(self)->byKey_.count(key) > 0;
}

bool ExternalFiles::read(std::vector<unsigned char>* out, std::string* err, const std::string& key, void* user)
{
    ExternalFiles& self = *static_cast<ExternalFiles*>(user);
    const auto it = self.byKey_.find(key);
    if (it == self.byKey_.end()) {
        if (err) *err += "not a file the model's URIs name";
        return false;
    }
    File& file = it->second;
    const bool buffer = file.pointer.rfind("/buffers/", 0) == 0;
    try {
        const io::RegularFile opened(file.path, self.bytesLeft_, buffer ? "a glTF buffer" : "a glTF image");
        // add() checked the path; a link put in its place (or in a folder on its way)
        // since then would lead the open elsewhere: the descriptor says where it led.
        const fs::path reached = opened.openedPath();
        if (reached.empty() ||
            std::none_of(self.roots_.begin(), self.roots_.end(), [&](const fs::path& root) { return within(reached, root); })) {
            file.failure = fmt::format("{} file '{}' led to {} when opened, outside the model's folder and the allowed "
                                       "roots (a link changed since the URI was checked)",
                                       buffer ? "buffer" : "texture", core::shortText(file.uri),
                                       reached.empty() ? std::string("a file /proc/self/fd cannot name")
                                                       : core::shortText(reached.string()));
            if (err) *err += file.failure;
            return false;
        }
        *out = opened.readAll();
        self.bytesLeft_ -= out->size();
        return true;
    } catch (const io::FileReadError& e) {
        std::string reason = e.reason();
        if (e.problem() == io::FileReadProblem::NotFound) {
            reason += fmt::format(" (looked in {})", core::shortText(self.modelDir_.string()));
        } else if (e.problem() == io::FileReadProblem::TooBig && self.bytesLeft_ < self.maxBytesRead_) {
            reason += fmt::format(" (what is left of the {} bytes a glTF model may read in all)", self.maxBytesRead_);
        }
        // The URI passed the checks above: no control character to escape.
        file.failure = fmt::format("{} file '{}' {}", buffer ? "buffer" : "texture", core::shortText(file.uri), reason);
        if (err) *err += file.failure;
        return false;
    }
}

std::string ExternalFiles::failure(const std::string& pointer) const
{
    const auto key = keyOf_.find(pointer);
    return key == keyOf_.end() ? std::string() : byKey_.at(key->second).failure;
}

std::string ExternalFiles::firstBufferFailure() const
{
    for (const auto& [pointer, key] : keyOf_) {
        const File& file = byKey_.at(key);
        if (pointer.rfind("/buffers/", 0) == 0 && !file.failure.empty()) return pointer + ": " + file.failure;
    }
    return {};
}

} // namespace penumbra::scene::gltf

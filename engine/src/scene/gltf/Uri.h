#pragma once
// The files a glTF model names by URI (/buffers/i/uri, /images/i/uri), resolved and
// checked before any is opened, and read through tinygltf's file callbacks.
//
// A URI that is not a data: URI tinygltf decodes is an RFC 3986 relative reference:
// percent-decoded first (a malformed escape, or a NUL or other control character raw or
// decoded, refuses it), with no scheme (file:, http:; a buffer's data: URI of another
// media type; an image's is left to tinygltf, which never reads it as a file), query or
// fragment, and no absolute path. It is resolved against the model's folder and
// canonicalised (links resolved), and the file must lie under the model's own folder
// (canonical) or one of the allowed roots (GltfLoadOptions::allowedRoots). A refusal is
// an AssetError "model.gltf: /buffers/0/uri: "../x.bin": why", the URI shortened.
//
// tinygltf decodes a URI its own way before it asks for the file ('+' becomes a space, a
// bad escape a byte), so the path it asks for is only a key to a file resolved here:
// the callbacks read nothing else, and every file through io::RegularFile (a regular
// file, within what is left of GltfLoadOptions::maxBytesRead).
#include <tiny_gltf.h>

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace penumbra::scene::gltf {

class ExternalFiles {
public:
    // `modelFile` as the loader was given it; its folder is where URIs are resolved.
    // `bytesLeft` is what is left of the limit on bytes read per model (of `maxBytesRead`),
    // reduced by every file read.
    ExternalFiles(const std::filesystem::path& modelFile, const std::vector<std::filesystem::path>& allowedRoots,
                  uint64_t& bytesLeft, uint64_t maxBytesRead);

    // Resolves the URI found at JSON pointer `pointer`; a data: URI tinygltf decodes is
    // left to it. Throws AssetError when the URI is refused. Returns the file it names
    // (which may not exist), or an empty path for a data: URI.
    std::filesystem::path add(const std::string& pointer, const std::string& uri);

    // The folder tinygltf takes as its base directory (what it prefixes to URIs).
    const std::string& baseDir() const { return baseDir_; }
    // Installs the file callbacks on `loader`; `this` must outlive the parse.
    void install(tinygltf::TinyGLTF& loader);

    // Why the file of `pointer` could not be read ("buffer file 'a.bin' not found (looked
    // in models)"); empty when it was read or never asked for.
    std::string failure(const std::string& pointer) const;
    // "/buffers/i/uri: <why>" for the buffer that could not be read (tinygltf stops at
    // the first), empty if none.
    std::string firstBufferFailure() const;

private:
    struct File {
        std::string pointer;
        std::string uri;
        std::filesystem::path path;  // canonical
        std::string failure;
    };
    static bool exists(const std::string& key, void* self);
    static bool read(std::vector<unsigned char>* out, std::string* err, const std::string& key, void* self);

    std::string modelName_;
    std::string baseDir_;
    std::filesystem::path modelDir_;
    std::vector<std::filesystem::path> roots_;  // canonical: the model's folder first
    uint64_t& bytesLeft_;
    uint64_t maxBytesRead_;
    std::map<std::string, File> byKey_;       // tinygltf's path for a URI -> the file
    std::map<std::string, std::string> keyOf_;  // JSON pointer -> its key in byKey_
};

} // namespace penumbra::scene::gltf

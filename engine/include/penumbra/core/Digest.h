#pragma once
// A streaming 128-bit XXH3 digest (libxxhash) and a 64-bit checksum: what the engine's and
// the plugins' caches are keyed and checked with. Not cryptographic: it tells apart inputs
// that differ by accident, which is what a cache of derived data needs, at memory speed
// (the reference plugin hashes its G-buffer every frame).
#include <array>
#include <cstddef>
#include <cstdint>
#include <string_view>
#include <type_traits>

struct XXH3_state_s;  // libxxhash's, kept out of this header

namespace penumbra::core {

using Hash128 = std::array<uint64_t, 2>;  // {low, high}

class Digest128 {
public:
    // Throws Error when no memory is left for the hash state.
    Digest128();
    ~Digest128();
    Digest128(const Digest128&) = delete;
    Digest128& operator=(const Digest128&) = delete;

    Digest128& bytes(const void* data, size_t size);
    // Plain values without padding (glm vectors and matrices, numbers, enums): padding
    // bytes would make equal values hash differently.
    template <class T> Digest128& value(const T& v)
    {
        static_assert(std::is_trivially_copyable_v<T>, "hash plain data");
        return bytes(&v, sizeof v);
    }
    // The length, then the characters: "ab"+"c" and "a"+"bc" hash differently.
    Digest128& text(std::string_view s)
    {
        value(uint64_t(s.size()));
        return bytes(s.data(), s.size());
    }
    Hash128 finish() const;

private:
    XXH3_state_s* state_;
};

// XXH3-64 of a block of bytes: the checksum a cache file carries of its content.
uint64_t checksum64(const void* data, size_t size);

} // namespace penumbra::core

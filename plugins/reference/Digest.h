#pragma once
// A streaming 128-bit XXH3 digest (libxxhash): what the cache key and the scene's
// geometry digest are made of. Not cryptographic: it tells apart inputs that differ by
// accident, which is what a cache of derived images needs, at memory speed (the
// G-buffer is hashed every frame).
#include "penumbra/core/Error.h"

#include <xxhash.h>

#include <array>
#include <cstdint>
#include <span>
#include <type_traits>

namespace penumbra::reference {

class Digest128 {
public:
    Digest128() : state_(XXH3_createState())
    {
        if (!state_) throw Error("reference: out of memory for a hash state");
        XXH3_128bits_reset(state_);
    }
    ~Digest128() { XXH3_freeState(state_); }
    Digest128(const Digest128&) = delete;
    Digest128& operator=(const Digest128&) = delete;

    Digest128& bytes(const void* data, size_t size)
    {
        XXH3_128bits_update(state_, data, size);
        return *this;
    }
    // Plain values without padding (glm vectors and matrices, numbers, enums): padding
    // bytes would make equal values hash differently.
    template <class T> Digest128& value(const T& v)
    {
        static_assert(std::is_trivially_copyable_v<T>, "hash plain data");
        return bytes(&v, sizeof v);
    }
    std::array<uint64_t, 2> finish() const
    {
        const XXH128_hash_t h = XXH3_128bits_digest(state_);
        return {h.low64, h.high64};
    }

private:
    XXH3_state_t* state_;
};

} // namespace penumbra::reference

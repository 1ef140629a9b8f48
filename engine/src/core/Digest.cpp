#include "penumbra/core/Digest.h"

#include "penumbra/core/Error.h"

#include <xxhash.h>

namespace penumbra::core {

Digest128::Digest128() : state_(XXH3_createState())
{
    if (!state_) throw Error("out of memory for a hash state");
    XXH3_128bits_reset(state_);
}

Digest128::~Digest128() { XXH3_freeState(state_); }

Digest128& Digest128::bytes(const void* data, size_t size)
{
    XXH3_128bits_update(state_, data, size);
    return *this;
}

Hash128 Digest128::finish() const
{
    const XXH128_hash_t h = XXH3_128bits_digest(state_);
    return {h.low64, h.high64};
}

uint64_t checksum64(const void* data, size_t size) { return XXH3_64bits(data, size); }

} // namespace penumbra::core

#pragma once
// What a command was doing when memory ran out: inPhase("making sweep variant 12 of
// 10000", ...) turns a std::bad_alloc thrown by the step into an OutOfMemory error (exit
// 1) that names the step, the innermost one when steps nest. Outside every phase main()
// says no more than "out of memory": a message claims only what is known.
#include "penumbra/core/Error.h"

#include <new>
#include <string>
#include <utility>

namespace penumbra::app {

class OutOfMemory : public Error {
public:
    using Error::Error;
};

template <class Step> decltype(auto) inPhase(const std::string& what, Step&& step)
{
    try {
        return std::forward<Step>(step)();
    } catch (const std::bad_alloc&) {
        throw OutOfMemory("out of memory while " + what);
    }
}

} // namespace penumbra::app

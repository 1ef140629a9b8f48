#pragma once
// The message of the penumbra::Error a piece of code throws, for tests that check what an
// error says.
#include "penumbra/core/Error.h"

#include <functional>
#include <string>

namespace penumbra::test {

// e.what() of the Error `f` throws; "(no error)" when it throws none.
inline std::string errorOf(const std::function<void()>& f)
{
    try {
        f();
    } catch (const Error& e) {
        return e.what();
    }
    return "(no error)";
}

} // namespace penumbra::test

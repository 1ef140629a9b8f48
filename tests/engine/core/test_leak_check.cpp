// penumbra::checkLeaksBeforeExit (penumbra/core/LeakCheck.h): in AddressSanitizer builds it
// is LeakSanitizer's check, run where it is called; the test mains and the penumbra
// command call it last, so that the check at exit — which can crash on worker threads
// stopping there — never runs.
#include "penumbra/core/LeakCheck.h"

#include <gtest/gtest.h>

#include <cstdlib>

namespace {

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kLeakSanitizer = true;
#else
constexpr bool kLeakSanitizer = false;
#endif

// Many blocks, each unreachable as soon as it is allocated: a stale copy of one pointer in
// a register or a dead stack slot cannot hide them all from the conservative scan.
[[gnu::noinline]] void leakBlocks()
{
    void* (*volatile allocate)(size_t) = std::malloc;
    for (int i = 0; i < 64; ++i) {
        [[maybe_unused]] void* volatile block = allocate(1024);
        block = nullptr;
    }
}

TEST(LeakCheck, ReportsLeaksWhereItIsCalledAndEndsTheProcess)
{
    if (!kLeakSanitizer) GTEST_SKIP() << "a no-op without AddressSanitizer";
    GTEST_FLAG_SET(death_test_style, "threadsafe");
    EXPECT_DEATH(
        {
            leakBlocks();
            penumbra::checkLeaksBeforeExit();
        },
        "LeakSanitizer: detected memory leaks");
}

TEST(LeakCheck, FindsNothingInAProcessThatLeaksNothingAndLeavesNoCheckAtExit)
{
    GTEST_FLAG_SET(death_test_style, "threadsafe");
    // The child leaks after the check: with the check at exit still armed, that leak
    // would end it with LeakSanitizer's failure instead of status 0.
    EXPECT_EXIT(
        {
            penumbra::checkLeaksBeforeExit();
            if (kLeakSanitizer) leakBlocks();
            std::exit(0);
        },
        testing::ExitedWithCode(0), "");
}

} // namespace

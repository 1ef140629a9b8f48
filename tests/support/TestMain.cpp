// The engine-side test groups' main: GoogleTest's, then LeakSanitizer's check while the
// worker threads of Embree's TBB and of the driver are parked (penumbra/core/LeakCheck.h).
#include "penumbra/core/LeakCheck.h"

#include <gtest/gtest.h>

int main(int argc, char** argv)
{
    testing::InitGoogleTest(&argc, argv);
    const int status = RUN_ALL_TESTS();
    penumbra::checkLeaksBeforeExit();
    return status;
}

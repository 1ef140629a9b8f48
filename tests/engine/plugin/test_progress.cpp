// plugin/Progress.h: a long pass's progress reaches the sink installed on the thread that
// runs it, and only that one; without a sink reporting does nothing.
#include "penumbra/plugin/Progress.h"

#include <gtest/gtest.h>

#include <thread>

using namespace penumbra;

TEST(Progress, ReportsReachTheSinkOfTheirThreadOnly)
{
    EXPECT_FALSE(plugin::progressWanted());
    plugin::startProgress();  // no sink: nothing happens
    plugin::reportProgress(1, 2);

    plugin::ProgressSink outer, inner;
    {
        const plugin::ProgressScope scope(outer);
        EXPECT_TRUE(plugin::progressWanted());
        plugin::startProgress();
        plugin::reportProgress(3, 4);
        EXPECT_EQ(outer.passes.load(), 1u);
        EXPECT_DOUBLE_EQ(outer.fraction.load(), 0.75);
        {
            const plugin::ProgressScope nested(inner);
            plugin::startProgress();
            plugin::reportProgress(7, 5);  // clamped
            EXPECT_DOUBLE_EQ(inner.fraction.load(), 1.0);
            plugin::reportProgress(2, 0);  // nothing to do: done
            EXPECT_DOUBLE_EQ(inner.fraction.load(), 1.0);
        }
        // Another thread has no sink: its reports go nowhere.
        std::thread([] {
            EXPECT_FALSE(plugin::progressWanted());
            plugin::startProgress();
            plugin::reportProgress(1, 4);
        }).join();
        EXPECT_EQ(outer.passes.load(), 1u);
        EXPECT_DOUBLE_EQ(outer.fraction.load(), 0.75);
        plugin::startProgress();  // the outer sink is back after the nested scope
        EXPECT_EQ(outer.passes.load(), 2u);
        EXPECT_DOUBLE_EQ(outer.fraction.load(), 0.0);
    }
    EXPECT_EQ(inner.passes.load(), 1u);
    EXPECT_FALSE(plugin::progressWanted());
}

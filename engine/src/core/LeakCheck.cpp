#include "penumbra/core/LeakCheck.h"

#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/lsan_interface.h>
#endif
#if defined(PENUMBRA_LEAK_CHECK_STOPS_TBB)
#include <oneapi/tbb/global_control.h>

#include <new>
#endif

namespace penumbra {

namespace {

#if defined(PENUMBRA_LEAK_CHECK_STOPS_TBB)
// Blocks until TBB's worker threads have exited. A no-op when TBB never started a pool.
// Returns false when TBB refuses (another handle or a parallel region is active): the
// check then runs with the workers parked, as before.
bool stopTbbWorkers()
{
    tbb::task_scheduler_handle handle{tbb::attach{}};
    return tbb::finalize(handle, std::nothrow);
}
#endif

} // namespace

void checkLeaksBeforeExit()
{
#if defined(PENUMBRA_LEAK_CHECK_STOPS_TBB)
    (void)stopTbbWorkers();
#endif
#if defined(__SANITIZE_ADDRESS__)
    __lsan_do_leak_check();
#endif
}

} // namespace penumbra

#pragma once

namespace penumbra {

// In AddressSanitizer builds: LeakSanitizer's check, run now instead of at exit; call it
// last in main, once every object the program owns is gone. LeakSanitizer stops the world
// and walks every live thread's stacks and TLS; on a worker thread of TBB (Embree's BVH
// builders start them) that walk can read a stale dynamic-TLS range and crash its tracer
// ("Tracer caught signal 11 ... LeakSanitizer has encountered a fatal error"): a failed
// run with no leak in it, 1 to 2 runs in 100 of a traced test here. So the check first
// stops TBB's workers (tbb::finalize; engine/CMakeLists.txt links TBB in sanitizer builds
// only), then runs with only the program's own and the driver's parked threads (the crash
// still comes, rarely, in __lsan::ScanRangeForPointers: the sanitizer builds' test
// launcher, tests/sanitizers/rerun-on-tracer-crash.sh, runs such a test once more). Leaks, if
// any, are reported as at exit (and end the process as at exit); after this call there is
// no second check at exit. A no-op in other builds.
void checkLeaksBeforeExit();

} // namespace penumbra

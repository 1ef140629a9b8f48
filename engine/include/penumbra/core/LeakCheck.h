#pragma once

namespace penumbra {

// In AddressSanitizer builds: LeakSanitizer's check, run now instead of at exit; call it
// last in main, once every object the program owns is gone. At exit the check races with
// third-party worker threads that are told to stop there — TBB's, which Embree's BVH
// builders start, stop while the libraries' destructors run — and stopping the world
// while one of them is exiting can crash LeakSanitizer's tracer ("Tracer caught signal
// 11 ... LeakSanitizer has encountered a fatal error", google/sanitizers#1353): a failed
// run with no leak in it. At the end of main those threads are parked. Leaks, if any, are
// reported as at exit (and end the process as at exit); after this call there is no second
// check at exit. A no-op in other builds.
void checkLeaksBeforeExit();

} // namespace penumbra

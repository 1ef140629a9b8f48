// A library that penumbra-nodep.so links and that the loader cannot find at run time: it
// is built into a folder that no RPATH or loader path names (tests/CMakeLists.txt).
extern "C" __attribute__((visibility("default"))) int penumbraTestAbsentValue() { return 7; }

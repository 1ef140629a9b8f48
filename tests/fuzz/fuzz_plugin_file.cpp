// libFuzzer target: the check every plugin file passes before dlopen sees it
// (plugin/LibraryFile.h). The input is the file. The check must refuse any file that
// dlopen would refuse or crash on with PluginError(NotALibrary), never crash, hang or
// read beyond the file itself; a file it passes is not loaded here (dlopen of fuzzed
// ELF files would run their initialisers).
#include "FuzzScratch.h"

#include "penumbra/plugin/LibraryFile.h"
#include "penumbra/plugin/PluginRegistry.h"

#include <cstdlib>

namespace {
penumbra::fuzz::ScratchFolder* scratch = nullptr;
}

extern "C" int LLVMFuzzerInitialize(int*, char***)
{
    scratch = new penumbra::fuzz::ScratchFolder();
    std::atexit([] { delete scratch; });
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
    const std::filesystem::path file = scratch->write("penumbra-fuzzed.so", data, size);
    try {
        penumbra::plugin::checkSharedLibraryFile(file, "fuzzed");
    } catch (const penumbra::plugin::PluginError& e) {
        // Refused: only ever as not-a-library.
        if (e.kind() != penumbra::plugin::PluginErrorKind::NotALibrary) std::abort();
    }
    return 0;
}

#include "SanitizerSupport.h"

#include <dlfcn.h>

#if defined(__SANITIZE_ADDRESS__)
#include <link.h>
#endif

namespace penumbra::gpu {

void pinLoadedLibrariesForLeakReports()
{
#if defined(__SANITIZE_ADDRESS__)
    dl_iterate_phdr(
        [](dl_phdr_info* info, size_t, void*) {
            if (info->dlpi_name && info->dlpi_name[0]) {
                // RTLD_NOLOAD: only take a reference to what is already there.
                dlopen(info->dlpi_name, RTLD_NOW | RTLD_NOLOAD | RTLD_NODELETE);
            }
            return 0;
        },
        nullptr);
#endif
}

int noUnloadDlopenFlag()
{
#if defined(__SANITIZE_ADDRESS__)
    return RTLD_NODELETE;
#else
    return 0;
#endif
}

} // namespace penumbra::gpu

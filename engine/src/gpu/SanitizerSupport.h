#pragma once

namespace penumbra::gpu {

// In AddressSanitizer builds: marks every shared library loaded so far as never to be
// unloaded. The Vulkan loader dlcloses drivers and layers at vkDestroyInstance, and a
// leak inside an unloaded library is reported from "<unknown module>", which no
// suppression can name. Pinned, its leaks carry the library's name and
// tests/sanitizers/lsan.supp can suppress the driver's own leaks (and only those).
// A no-op in other builds.
void pinLoadedLibrariesForLeakReports();

// Extra dlopen flags for libraries the engine loads itself (technique plugins): in
// AddressSanitizer builds RTLD_NODELETE, for the same reason (the plugin registry
// dlcloses its plugins before LeakSanitizer reports at exit); 0 in other builds.
int noUnloadDlopenFlag();

} // namespace penumbra::gpu

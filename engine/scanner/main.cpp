// penumbra-plugin-scanner FILE [LABEL]: loads one plugin file in this process, the way the
// engine would (plugin/PluginLibrary.h: the pre-load check, dlopen, the entry point, the
// ABI version, checkPluginInfo), and prints what it declares as one JSON document on
// stdout: {"plugin": PluginMetadata::toJson()} or {"error": {"kind", "message"}}, exit
// status 0 either way. The engine runs it for every plugin it lists, checks or loads
// (plugin/PluginRegistry.h), so that a damaged or hostile plugin that crashes or hangs the
// loader takes this process down, not the engine's: any other exit is the plugin's doing.
// LABEL names the plugin in messages ("plugin 'hard' (<file>)"; default: the file).
#include "plugin/PluginLibrary.h"

#include "penumbra/plugin/PluginMetadata.h"
#include "penumbra/plugin/PluginRegistry.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <dlfcn.h>
#include <unistd.h>

#include <cstdio>
#include <string>
#include <vector>

namespace {

// Writes all of `text` to stdout and ends the process at once: the plugin's finalisers
// and the sanitizers' exit-time reports must not add to or follow the answer.
[[noreturn]] void answer(const nlohmann::json& doc)
{
    // A damaged file's strings reach the messages (dlerror quotes them): not always UTF-8.
    const std::string text = doc.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
    for (size_t done = 0; done < text.size();) {
        const ssize_t n = write(STDOUT_FILENO, text.data() + done, text.size() - done);
        if (n <= 0) _exit(3);
        done += size_t(n);
    }
    _exit(0);
}

} // namespace

int main(int argc, char** argv)
{
    using namespace penumbra::plugin;
    if (argc < 2 || argc > 3) {
        std::fprintf(stderr, "usage: penumbra-plugin-scanner FILE [LABEL]\n");
        return 2;
    }
    const std::filesystem::path file = argv[1];
    const std::string who = argc == 3 ? argv[2] : file.string();
    std::vector<void*> handles;
    nlohmann::json doc;
    try {
        const PenumbraPluginInfo& info = openPluginLibrary(file, who, handles);
        doc = {{"plugin", PluginMetadata(info, file, pluginShaderDir(info, file)).toJson()}};
    } catch (const PluginError& e) {
        doc = {{"error", {{"kind", pluginErrorKindName(e.kind())}, {"message", e.what()}}}};
    } catch (const std::exception& e) {
        doc = {{"error", {{"kind", pluginErrorKindName(PluginErrorKind::InvalidInfo)},
                          {"message", fmt::format("{}: reading its description failed: {}", who, e.what())}}}};
    }
    // Unloading runs the plugin's finalisers (unless the loader pinned it): a damaged
    // finaliser array crashes here, in the scanner, rather than at the engine's exit.
    for (void* handle : handles) dlclose(handle);
    answer(doc);
}

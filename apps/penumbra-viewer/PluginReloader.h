#pragma once
// Hot reload of rebuilt plugin libraries. dlopen hands back a library already loaded under
// the same path (or from the same file), and a loaded plugin is never unloaded (techniques
// made from it may live on), so a rebuilt plugin cannot be opened again where it lies. When
// a plugin file on the search path changes, this makes a new registry whose search path
// starts with a fresh folder of private copies of every plugin file (each generation its
// own folder, so that each copy is a file no earlier registry opened); the viewer builds
// the frame with it and keeps the old registry alive for what still refers to it. The
// light's config, and so its parameters, stay as they were.
#include "ShaderWatcher.h"  // FileStamps

#include "penumbra/plugin/PluginRegistry.h"

#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace penumbra::viewer {

class PluginReloader {
public:
    // `searchPath`: where the plugins are built or installed (plugin::defaultPluginSearchPath()).
    explicit PluginReloader(std::vector<std::filesystem::path> searchPath);
    // Removes its folders of copies (the libraries stay mapped while loaded).
    ~PluginReloader();
    PluginReloader(const PluginReloader&) = delete;
    PluginReloader& operator=(const PluginReloader&) = delete;

    // True once per change of a plugin file (penumbra-*.so) on the search path: added,
    // rebuilt or removed. `lastChanged()` names them.
    bool changed();
    const std::vector<std::string>& lastChanged() const { return lastChanged_; }

    // A registry that loads every plugin from copies made now. Throws Error naming the
    // file that cannot be copied.
    std::unique_ptr<plugin::PluginRegistry> freshRegistry();

private:
    FileStamps scan() const { return stampFiles(searchPath_, false, isPluginFile); }
    static bool isPluginFile(const std::filesystem::path& file);

    std::vector<std::filesystem::path> searchPath_;
    FileStamps stamps_;
    std::vector<std::string> lastChanged_;
    std::filesystem::path root_;  // this process's folder of generations
    int generation_ = 0;
};

} // namespace penumbra::viewer

#pragma once
// Reading a config's JSON with messages that say where: every error names the file the
// value came from (through includes and sweeps: ConfigDocument::origin) and its JSON
// path. Shared by the parts of a config read in different files (config/Config.cpp,
// Animation.cpp, Sweep.cpp).
#include "penumbra/config/Document.h"

#include <glm/vec3.hpp>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <set>
#include <string>
#include <vector>

namespace penumbra::config {

// Where messages point: the file a JSON path's value came from.
class Locator {
public:
    explicit Locator(const ConfigDocument& document) : document_(document) {}
    // "file: /json/pointer", for values whose checking happens later (plugin parameters).
    std::string where(const std::string& pointer) const;
    // Throws ConfigError "file: /json/pointer: what".
    [[noreturn]] void fail(const std::string& pointer, const std::string& what) const;

private:
    const ConfigDocument& document_;
};

// One JSON object being read: remembers which keys were consumed so that unknown keys
// (typos) are errors, with a suggestion when a known key is close.
class ObjectReader {
public:
    ObjectReader(const nlohmann::json& value, const Locator& locator, std::string pointer);

    [[noreturn]] void fail(const std::string& pointer, const std::string& what) const { locator_.fail(pointer, what); }

    std::string path(const std::string& key) const { return pointer_ + "/" + key; }
    const std::string& pointer() const { return pointer_; }
    const Locator& locator() const { return locator_; }

    // The key's value, or null when absent; either way the key is known from now on.
    const nlohmann::json* find(const std::string& key);
    const nlohmann::json& require(const std::string& key);

    double number(const std::string& key, double fallback, double lo, double hi, bool loOpen = false);
    double checkNumber(const nlohmann::json& v, const std::string& at, double lo, double hi, bool loOpen) const;
    uint32_t integer(const std::string& key, uint32_t fallback, uint32_t lo, uint32_t hi);
    glm::vec3 vec3(const std::string& key, glm::vec3 fallback, bool required = false);
    glm::vec3 checkVec3(const nlohmann::json& v, const std::string& at) const;
    std::string choice(const std::string& key, const std::string& fallback, const std::vector<std::string>& allowed);
    // A non-empty string.
    std::string string(const std::string& key, const std::string& fallback);

    // Unknown keys are errors: a typo must not silently fall back to a default.
    // `context` says for what the keys were expected ("for a point light").
    void finish(const std::string& context = "") const;

private:
    const nlohmann::json& value_;
    const Locator& locator_;
    std::string pointer_;
    std::set<std::string> known_;
};

} // namespace penumbra::config

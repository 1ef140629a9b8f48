#include "config/JsonReader.h"

#include "core/Text.h"
#include "penumbra/core/ShortText.h"
#include "penumbra/core/Error.h"

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>

using nlohmann::json;

namespace penumbra::config {

std::string Locator::where(const std::string& pointer) const
{
    return fmt::format("{}: {}", document_.fileFor(pointer), core::shortText(pointer));
}

void Locator::fail(const std::string& pointer, const std::string& what) const
{
    throw ConfigError(fmt::format("{}: {}: {}", document_.fileFor(pointer), pointer.empty() ? "/" : core::shortText(pointer), what));
}

ObjectReader::ObjectReader(const json& value, const Locator& locator, std::string pointer)
    : value_(value), locator_(locator), pointer_(std::move(pointer))
{
    if (!value_.is_object()) fail(pointer_, fmt::format("must be an object, got {}", value_.type_name()));
}

const json* ObjectReader::find(const std::string& key)
{
    known_.insert(key);
    auto it = value_.find(key);
    return it == value_.end() ? nullptr : &*it;
}

const json& ObjectReader::require(const std::string& key)
{
    const json* v = find(key);
    if (!v) fail(path(key), "is required but missing");
    return *v;
}

double ObjectReader::number(const std::string& key, double fallback, double lo, double hi, bool loOpen)
{
    const json* v = find(key);
    return v ? checkNumber(*v, path(key), lo, hi, loOpen) : fallback;
}

double ObjectReader::checkNumber(const json& v, const std::string& at, double lo, double hi, bool loOpen) const
{
    if (!v.is_number()) fail(at, fmt::format("must be a number, got {}", core::shortJson(v)));
    const double x = v.get<double>();
    const bool below = loOpen ? x <= lo : x < lo;
    if (!std::isfinite(x) || below || x > hi) {
        fail(at, fmt::format("must be in {}{}, {}], got {}", loOpen ? "(" : "[", lo, hi, core::shortJson(v)));
    }
    return x;
}

uint32_t ObjectReader::integer(const std::string& key, uint32_t fallback, uint32_t lo, uint32_t hi)
{
    const json* v = find(key);
    if (!v) return fallback;
    if (!v->is_number_integer()) fail(path(key), fmt::format("must be an integer, got {}", core::shortJson(*v)));
    const int64_t x = v->get<int64_t>();
    if (x < int64_t(lo) || x > int64_t(hi)) {
        fail(path(key), fmt::format("must be an integer in [{}, {}], got {}", lo, hi, x));
    }
    return static_cast<uint32_t>(x);
}

glm::vec3 ObjectReader::vec3(const std::string& key, glm::vec3 fallback, bool required)
{
    const json* v = required ? &require(key) : find(key);
    return v ? checkVec3(*v, path(key)) : fallback;
}

glm::vec3 ObjectReader::checkVec3(const json& v, const std::string& at) const
{
    if (!v.is_array() || v.size() != 3 || !std::all_of(v.begin(), v.end(), [](const json& e) { return e.is_number(); })) {
        fail(at, fmt::format("must be an array of 3 numbers, got {}", core::shortJson(v)));
    }
    glm::vec3 out;
    for (int i = 0; i < 3; ++i) {
        const double x = v[size_t(i)].get<double>();
        if (!std::isfinite(x) || std::abs(x) > 3.0e38) fail(at, fmt::format("must be finite, got {}", core::shortJson(v)));
        out[i] = float(x);
    }
    return out;
}

std::string ObjectReader::choice(const std::string& key, const std::string& fallback, const std::vector<std::string>& allowed)
{
    const json* v = find(key);
    if (!v) return fallback;
    if (!v->is_string()) fail(path(key), fmt::format("must be a string, got {}", core::shortJson(*v)));
    const std::string s = v->get<std::string>();
    if (std::find(allowed.begin(), allowed.end(), s) == allowed.end()) {
        fail(path(key), fmt::format("must be one of {}, got {}", fmt::join(allowed, ", "), core::shortJson(*v)));
    }
    return s;
}

std::string ObjectReader::string(const std::string& key, const std::string& fallback)
{
    const json* v = find(key);
    if (!v) return fallback;
    if (!v->is_string() || v->get<std::string>().empty()) {
        fail(path(key), fmt::format("must be a non-empty string, got {}", core::shortJson(*v)));
    }
    return v->get<std::string>();
}

void ObjectReader::finish(const std::string& context) const
{
    for (auto it = value_.begin(); it != value_.end(); ++it) {
        if (known_.count(it.key())) continue;
        const std::vector<std::string> keys(known_.begin(), known_.end());
        const std::string best = core::closestMatch(it.key(), keys);
        const std::string unknown = context.empty() ? "unknown key" : "unknown key " + context;
        fail(path(it.key()), best.empty() ? fmt::format("{} (expected one of: {})", unknown, fmt::join(keys, ", "))
                                          : fmt::format("{}; did you mean \"{}\"?", unknown, best));
    }
}

} // namespace penumbra::config

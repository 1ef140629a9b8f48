#include "penumbra/config/Sweep.h"

#include "config/JsonReader.h"
#include "penumbra/core/ShortText.h"

#include <fmt/format.h>

#include <algorithm>
#include <cassert>
#include <cctype>
#include <utility>

using nlohmann::json;

namespace penumbra::config {

// One sweep entry: the JSON pointers it sets together and the values it takes.
struct SweepVariants::Axis {
    std::vector<json::json_pointer> paths;
    std::vector<std::string> pathTexts;
    std::vector<json> values;          // per value: one JSON value per path
    std::vector<std::string> labels;   // per value: "labels"[i], or the value as JSON
    bool labelled = false;             // "labels" was given
};

namespace {

using SweepAxis = SweepVariants::Axis;

json::json_pointer readSweepPointer(const json& text, const ObjectReader& r, const std::string& at)
{
    if (!text.is_string()) r.fail(at, "must be a JSON pointer string such as \"/lights/0/shadow/resolution\"");
    const std::string s = text.get<std::string>();
    // Counted before the pointer is built: a path of a million levels took minutes in
    // the pointer's own string handling, and no config nests that deep.
    const auto levels = std::count(s.begin(), s.end(), '/');
    if (levels > kMaxConfigNesting) {
        r.fail(at, fmt::format("a path of {} levels ({} characters); a config nests at most {}", levels, s.size(),
                               kMaxConfigNesting));
    }
    json::json_pointer pointer;
    try {
        pointer = json::json_pointer(s);
    } catch (const json::exception& e) {
        r.fail(at, fmt::format("\"{}\" is not a JSON pointer ({})", core::shortText(s), core::shortText(e.what())));
    }
    if (s.empty() || s.rfind("/sweep", 0) == 0 || s.rfind("/include", 0) == 0) r.fail(at, fmt::format("cannot sweep \"{}\"", core::shortText(s)));
    return pointer;
}

// "path": one pointer, each value sets it; "paths": several pointers set together (a
// scene with its camera), each value an array with one entry per path. "labels" names
// the values for tables and plots.
SweepAxis readSweepAxis(const json& entry, const Locator& locator, const std::string& at)
{
    ObjectReader r(entry, locator, at);
    const json* path = r.find("path");
    const json* paths = r.find("paths");
    const json& values = r.require("values");
    const json* labels = r.find("labels");
    r.finish();
    SweepAxis axis;
    if ((path != nullptr) == (paths != nullptr)) r.fail(at, "give either \"path\" (one JSON pointer) or \"paths\" (several)");
    if (path) {
        axis.paths.push_back(readSweepPointer(*path, r, at + "/path"));
    } else {
        if (!paths->is_array() || paths->empty()) r.fail(at + "/paths", "must be a non-empty array of JSON pointers");
        for (size_t k = 0; k < paths->size(); ++k) {
            axis.paths.push_back(readSweepPointer((*paths)[k], r, fmt::format("{}/paths/{}", at, k)));
        }
    }
    for (const json::json_pointer& p : axis.paths) axis.pathTexts.push_back(p.to_string());
    for (size_t a = 0; a < axis.paths.size(); ++a) {
        for (size_t b = 0; b < axis.paths.size(); ++b) {
            const std::string& outer = axis.pathTexts[a];
            const std::string& inner = axis.pathTexts[b];
            if (a != b && inner.rfind(outer, 0) == 0 && (inner.size() == outer.size() || inner[outer.size()] == '/')) {
                r.fail(fmt::format("{}/paths/{}", at, b), fmt::format("\"{}\" lies inside \"{}\", which the same entry sets",
                                                                      core::shortText(inner), core::shortText(outer)));
            }
        }
    }
    if (!values.is_array() || values.empty()) r.fail(at + "/values", "must be a non-empty array");
    for (size_t i = 0; i < values.size(); ++i) {
        if (paths && (!values[i].is_array() || values[i].size() != axis.paths.size())) {
            r.fail(fmt::format("{}/values/{}", at, i),
                   fmt::format("must be an array of {} values, one per path, got {}", axis.paths.size(), core::shortJson(values[i])));
        }
        axis.values.push_back(values[i]);
    }
    if (labels) {
        if (!labels->is_array() || labels->size() != values.size()) {
            r.fail(at + "/labels", fmt::format("must be an array of {} strings, one per value", values.size()));
        }
        for (size_t i = 0; i < labels->size(); ++i) {
            const json& label = (*labels)[i];
            const std::string where = fmt::format("{}/labels/{}", at, i);
            if (!label.is_string() || label.get<std::string>().empty()) r.fail(where, fmt::format("must be a non-empty string, got {}", core::shortJson(label)));
            if (std::find(axis.labels.begin(), axis.labels.end(), label.get<std::string>()) != axis.labels.end()) {
                r.fail(where, fmt::format("{} labels another value already", core::shortJson(label)));
            }
            axis.labels.push_back(label.get<std::string>());
        }
        axis.labelled = true;
    } else {
        for (const json& v : axis.values) axis.labels.push_back(core::shortJson(v));
    }
    return axis;
}

// Sets `pointer` in `doc` to `value`. The parent must exist (a missing one is a typo far
// more often than an intent) and, when it is an array, hold the element: setting past
// the end would pad the array with nulls.
void setSwept(json& doc, const json::json_pointer& pointer, const json& value, const Locator& locator,
              const std::string& at, const std::string& variant)
{
    const std::string text = pointer.to_string();
    const json::json_pointer parent = pointer.parent_pointer();
    const std::string in = variant.empty() ? "" : fmt::format(" (in the variant {})", core::shortText(variant));
    bool settable = false;
    try {
        // An array index beyond 64 bits makes the lookup throw rather than miss.
        settable = doc.contains(parent) && (doc[parent].is_object() || doc[parent].is_array());
    } catch (const json::exception&) {
        settable = false;
    }
    if (!settable) {
        locator.fail(at, fmt::format("\"{}\": the config has no \"{}\" to set it in{}", core::shortText(text),
                                     core::shortText(parent.to_string()), in));
    }
    if (doc[parent].is_array()) {
        const std::string& index = pointer.back();
        const bool digits = !index.empty() && std::all_of(index.begin(), index.end(), [](unsigned char c) { return std::isdigit(c); });
        if (!digits || index.size() > 9 || std::stoul(index) >= doc[parent].size()) {
            locator.fail(at, fmt::format("\"{}\": \"{}\" has {} elements; a sweep replaces an element, it does not add one{}",
                                         core::shortText(text), core::shortText(parent.to_string()), doc[parent].size(), in));
        }
    }
    doc[pointer] = value;
}

// "<path>+<path>=<label>": how a variant's label shows the value it takes of `axis`.
std::string axisLabel(const SweepAxis& axis, size_t pick)
{
    return fmt::format("{}={}", fmt::join(axis.pathTexts, "+"), axis.labels[pick]);
}

} // namespace

SweepVariants::SweepVariants(const ConfigDocument& document) : document_(document)
{
    const Locator locator(document);
    auto it = document.json.find("sweep");
    if (it == document.json.end()) return;
    const json& sweep = *it;
    if (!sweep.is_array() || sweep.empty()) locator.fail("/sweep", "must be a non-empty array of {\"path\", \"values\"}");
    // The product is checked entry by entry, so that it never overflows and nothing is
    // read past the entry that takes it beyond the limit.
    std::vector<std::string> factors;
    for (size_t i = 0; i < sweep.size(); ++i) {
        const std::string at = fmt::format("/sweep/{}", i);
        axes_.push_back(readSweepAxis(sweep[i], locator, at));
        size_ *= axes_.back().values.size();
        factors.push_back(std::to_string(axes_.back().values.size()));
        if (size_ > kMaxSweepCombinations) {
            locator.fail(at + "/values", fmt::format("the sweep has more than {} combinations: its entries up to this one "
                                                     "make {} = {} variants",
                                                     kMaxSweepCombinations, fmt::join(factors, " x "), size_));
        }
    }
}

SweepVariants::~SweepVariants() = default;

bool SweepVariants::swept() const { return !axes_.empty(); }

std::vector<size_t> SweepVariants::picks(size_t index) const
{
    assert(index < size_);
    // The first entry varies slowest.
    std::vector<size_t> picks(axes_.size());
    for (size_t a = axes_.size(), rest = index; a-- > 0; rest /= axes_[a].values.size()) picks[a] = rest % axes_[a].values.size();
    return picks;
}

std::string SweepVariants::label(size_t index) const
{
    const std::vector<size_t> pick = picks(index);
    std::vector<std::string> label;
    for (size_t a = 0; a < axes_.size(); ++a) label.push_back(axisLabel(axes_[a], pick[a]));
    return fmt::format("{}", fmt::join(label, ", "));
}

SweepVariant SweepVariants::variant(size_t index) const
{
    if (axes_.empty()) return {"", {}, parseConfig(document_)};
    const Locator locator(document_);
    // Entries are applied in order, so a later one may set a value inside one that an
    // earlier entry replaced (a technique's parameter inside a swept "shadow" object).
    const std::vector<size_t> picks = this->picks(index);
    ConfigDocument variant = document_;
    variant.json.erase("sweep");
    SweepVariant out;
    std::vector<std::string> label;
    for (size_t a = 0; a < axes_.size(); ++a) {
        const SweepAxis& axis = axes_[a];
        const size_t pick = picks[a];
        const bool several = axis.paths.size() > 1;
        for (size_t k = 0; k < axis.paths.size(); ++k) {
            const std::string& text = axis.pathTexts[k];
            const std::string at = several ? fmt::format("/sweep/{}/paths/{}", a, k) : fmt::format("/sweep/{}/path", a);
            setSwept(variant.json, axis.paths[k], several ? axis.values[pick][k] : axis.values[pick], locator, at,
                     fmt::format("{}", fmt::join(label, ", ")));
            // The value replaced whatever was there, including where its parts came from.
            for (auto o = variant.origin.lower_bound(text); o != variant.origin.end() && o->first.rfind(text, 0) == 0;) {
                const bool inside = o->first.size() == text.size() || o->first[text.size()] == '/';
                o = inside ? variant.origin.erase(o) : std::next(o);
            }
            variant.origin[text] = several ? fmt::format("{} (/sweep/{}/values/{}/{})", document_.file.string(), a, pick, k)
                                           : fmt::format("{} (/sweep/{}/values/{})", document_.file.string(), a, pick);
        }
        label.push_back(axisLabel(axis, pick));
        out.choices.push_back({axis.pathTexts, pick, axis.labels[pick], axis.labelled});
    }
    out.label = fmt::format("{}", fmt::join(label, ", "));
    out.config = parseConfig(variant);
    return out;
}

} // namespace penumbra::config

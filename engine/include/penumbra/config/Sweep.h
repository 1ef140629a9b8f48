#pragma once
// A parameter sweep: "sweep": [{"path": "/lights/0/shadow/resolution", "values": [512,
// 1024]}, ...] gives the Cartesian product of the listed values (the first entry varies
// slowest); each variant is the document with those paths set. A value replaces what is
// at its path whole, so sweeping an object ("/lights/0/shadow": [{"technique": "hard"},
// {"technique": "pcss", "light_size": 1}]) changes a technique together with its
// parameters, and "/scene" changes the scene. Entries are applied in order: a later one
// may set a value inside an object an earlier one swept. "paths": [...] sets several
// pointers together, each value then an array with one entry per path (a scene with the
// camera that frames it). "labels": [...] names the values for tables and plots. A config
// without a sweep has one variant, itself.
#include "penumbra/config/Document.h"
#include "penumbra/config/RenderConfig.h"

#include <string>
#include <vector>

namespace penumbra::config {

struct SweepChoice {
    std::vector<std::string> paths;  // the entry's JSON pointers
    size_t value = 0;                // index into the entry's "values"
    std::string label;               // its "labels" entry, or the value as JSON (core::shortJson)
    bool labelled = false;           // the label is the entry's own ("labels")
};
struct SweepVariant {
    std::string label;  // "/lights/0/shadow/resolution=512, ..."; empty without a sweep
    std::vector<SweepChoice> choices;  // one per sweep entry, in order; empty without a sweep
    RenderConfig config;
};
// The most variants one sweep may make. Variants are made one at a time (each is a copy
// of the document: 10,000 variants of a 1 MB config took 8 GB when all were kept).
inline constexpr size_t kMaxSweepCombinations = 100000;

// A config's sweep variants, each made when asked for. Construction reads and checks the
// entries, not the variants: ConfigError naming the entry for a malformed one, or for
// entries whose product passes kMaxSweepCombinations (checked entry by entry, before any
// variant is made). `document` must outlive this.
class SweepVariants {
public:
    explicit SweepVariants(const ConfigDocument& document);
    ~SweepVariants();
    SweepVariants(const SweepVariants&) = delete;
    SweepVariants& operator=(const SweepVariants&) = delete;

    // How many variants there are: 1 without a sweep.
    size_t size() const { return size_; }
    // Whether the document has a sweep (a sweep of one value has one variant too).
    bool swept() const;
    // Variant `index` < size(): the document with the entries' values set, parsed. Throws
    // ConfigError naming the entry (and the variant where a path exists in some only).
    SweepVariant variant(size_t index) const;
    // Variant `index`'s label (SweepVariant::label) without making it.
    std::string label(size_t index) const;

    struct Axis;  // one entry, read (Sweep.cpp)

private:
    std::vector<size_t> picks(size_t index) const;  // per entry, the index of its value

    const ConfigDocument& document_;
    std::vector<Axis> axes_;
    size_t size_ = 1;
};

} // namespace penumbra::config

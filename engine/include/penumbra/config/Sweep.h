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
    std::string label;               // its "labels" entry, or the value as JSON
    bool labelled = false;           // the label is the entry's own ("labels")
};
struct SweepVariant {
    std::string label;  // "/lights/0/shadow/resolution=512, ..."; empty without a sweep
    std::vector<SweepChoice> choices;  // one per sweep entry, in order; empty without a sweep
    RenderConfig config;
};
// The most variants one sweep may make: each is a copy of the document.
inline constexpr size_t kMaxSweepCombinations = 100000;

// Throws ConfigError naming the entry (and the variant where a path exists in some only).
std::vector<SweepVariant> expandSweep(const ConfigDocument& document);

// How many variants expandSweep makes (1 without a sweep), without making them: the
// entries are read and checked as expandSweep does (ConfigError for a malformed entry or
// more than kMaxSweepCombinations), the variants' paths and configs are not.
size_t sweepCombinations(const ConfigDocument& document);

} // namespace penumbra::config

#pragma once
// Random acyclic pass graphs for the render graph's tests and benchmarks. The generator
// keeps its own record of every access so that a checker need not trust the compiler.
#include "penumbra/graph/RenderGraph.h"

#include <cstdint>
#include <string>
#include <vector>

namespace penumbra::graphtest {

struct RandomGraph {
    graph::RenderGraph graph;
    std::vector<std::string> passNames;          // declaration order
    std::vector<bool> sideEffect;                // per pass
    std::vector<std::vector<std::string>> reads;  // per pass
    std::vector<std::vector<std::string>> writes; // per pass; each resource has one writer
    std::vector<std::string> marked;
    std::vector<std::string> imported;
};

// `passCount` passes, each writing one or two fresh images or buffers and reading up to
// three earlier ones (mostly recent, sometimes old: long lifetimes) or imported ones.
// About one pass in twenty has a side effect and one resource in twenty is an output.
void buildRandomGraph(RandomGraph& out, uint32_t passCount, uint32_t seed);

} // namespace penumbra::graphtest

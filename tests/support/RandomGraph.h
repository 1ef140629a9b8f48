#pragma once
// Random acyclic pass graphs for the render graph's tests and benchmarks. The generator
// keeps its own record of every access so that a checker need not trust the compiler.
#include "penumbra/graph/RenderGraph.h"

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace penumbra::graphtest {

struct RandomGraph {
    graph::RenderGraph graph;
    std::vector<graph::PassBuilder> passes;      // declaration order, for attaching callbacks
    std::vector<std::string> passNames;          // declaration order
    std::vector<bool> sideEffect;                // per pass
    std::vector<std::vector<std::string>> reads;  // per pass
    std::vector<std::vector<std::string>> writes; // per pass; each resource has one writer
    std::vector<std::string> marked;
    std::vector<std::string> imported;
    std::map<std::string, VkDeviceSize> bufferBytes;  // every buffer, imported ones included
};

struct RandomGraphOptions {
    // Only buffers of 64 B to 4 KiB (imported ones 256 B) and only transfer passes that
    // read with TransferSrc and write with TransferDst: graphs small and simple enough to
    // execute on the device and check against a CPU simulation.
    bool smallTransferBuffers = false;
};

// `passCount` passes, each writing one or two fresh images or buffers and reading up to
// three earlier ones (mostly recent, sometimes old: long lifetimes) or imported ones.
// About one pass in twenty has a side effect and one resource in twenty is an output.
// `out` must stay where it is while `out.passes` is used (the builders point into it).
void buildRandomGraph(RandomGraph& out, uint32_t passCount, uint32_t seed, const RandomGraphOptions& options = {});

} // namespace penumbra::graphtest

#include "penumbra/plugin/Progress.h"

#include <algorithm>

namespace penumbra::plugin {

namespace {
thread_local ProgressSink* tSink = nullptr;
} // namespace

ProgressScope::ProgressScope(ProgressSink& sink) : previous_(tSink) { tSink = &sink; }

ProgressScope::~ProgressScope() { tSink = previous_; }

bool progressWanted() { return tSink != nullptr; }

void startProgress()
{
    if (!tSink) return;
    tSink->fraction.store(0.0);
    tSink->passes.fetch_add(1);
}

void reportProgress(uint64_t done, uint64_t total)
{
    if (!tSink) return;
    tSink->fraction.store(total > 0 ? std::clamp(double(done) / double(total), 0.0, 1.0) : 1.0);
    if (tSink->onReport) tSink->onReport();
}

bool progressCancelled() { return tSink && tSink->cancelled.load(); }

} // namespace penumbra::plugin

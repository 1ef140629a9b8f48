#pragma once
// pareto.svg of `penumbra bench`: error against time, one panel per TradeoffPanel (the
// same scene, light size, ... and light), techniques in colours, every point labelled
// with its sweep choices, the panel's Pareto front as a line through its points.
//
// Hand-written SVG 1.1: a few dozen elements, which a drawing library (cairo) would
// only wrap in another dependency. Per panel an axes frame, ticks and grid, x = the light's shadow
// passes' median ms (TimingSummary::workMs: GPU time, plus CPU time of host passes), on a log scale when the times span a factor of 10 or more and
// all are > 0 (else linear from 0), y = RMSE against the reference, linear from 0. Each
// point carries a <title> with its full variant label and figures, shown as a tooltip
// by browsers.
#include "BenchResults.h"

#include <string>

namespace penumbra::app {

std::string paretoSvg(const BenchRun& run);

} // namespace penumbra::app

#pragma once
// pareto.svg of `penumbra bench`: error against time, one panel per TradeoffPanel (the
// same scene, light size, ... and light), techniques in colours, every point labelled
// with its sweep choices, the panel's Pareto front as a line through its points.
//
// Hand-written SVG 1.1: a few dozen elements, which a drawing library (cairo) would
// only wrap in another dependency. Per panel an axes frame, ticks and grid, x = the light's shadow
// passes' median ms (TimingSummary::workMs: GPU time, plus CPU time of host passes), on a log scale when the times span a factor of 10 or more and
// all are > 0 (else linear from 0), y = RMSE against the reference, linear from 0. Where
// a light was timed over several frames that differ, a bar through its point spans their
// least to most ms (TimingSummary::workMinMs, workMaxMs): how far a median of few frames
// can be trusted. Labels are placed apart (PlotLabels.h). Each point carries a <title>
// with its full variant label and figures, shown as a tooltip by browsers.
//
// Browsers, librsvg (rsvg-convert) and ImageMagick's own renderer draw it alike: styles
// are presentation attributes (ImageMagick ignores a <style> sheet's fonts), a point's
// <title> sits in a group around its disc (ImageMagick drops a shape with a child), and
// all text comes after all shapes (ImageMagick stops drawing at a font it cannot load).
#include "BenchResults.h"

#include <string>

namespace penumbra::app {

std::string paretoSvg(const BenchRun& run);

} // namespace penumbra::app

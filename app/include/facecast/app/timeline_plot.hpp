#pragma once
// A picture of a performance over time: the utterance's viseme events as labelled bars, each
// viseme channel's curve (coarticulation and closure are visible), the expression curves, and
// jawOpen and the blink weight of the rig. CPU-drawn, no GL needed.
#include "facecast/anim/animation.hpp"
#include "facecast/render/image.hpp"
#include "facecast/viseme/utterance.hpp"

namespace facecast::cli {

/// `pixels_per_second` wide (at least 400 px plus labels), a lane of the utterance's viseme
/// events, one lane per viseme channel, one per expression, and jawOpen and the left blink.
/// `performance` must have been built from `utterance`.
render::Image plot_timeline(const viseme::Utterance& utterance,
                            const anim::Performance& performance, int pixels_per_second = 200);

}  // namespace facecast::cli

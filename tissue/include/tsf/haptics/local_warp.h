// The stylus inverse-warped by the local lattice deformation: coupler/local_warp.h holds the
// math (shared with the contact of one tissue instance against another).
#pragma once

#include "tsf/coupler/local_warp.h"

namespace tsf::haptics {

using coupler::inverse_warp;
using coupler::lattice_displacement;
using coupler::LocalWarp;

}  // namespace tsf::haptics

#pragma once
// The driver's check whether a scene already stands (DriverControls):
// before any backend runs, the stress QP (Eq. 4) at the part's own geometry;
// a part whose forces there verify is returned unchanged.
#include "kernels/stress_qp.hpp"

namespace tensegrity {

// The stress QP's options in that check: its interior-point phase first, and
// a give-up a few projected-Newton steps past it far from an equilibrium
// (docs/BACKENDS.md, "The check whether a scene already stands").
StressQpOptions standing_check_qp_options();

}  // namespace tensegrity

// The 2-D spectral equations as models the steppers step: Navier-Stokes (and Charney-Hasegawa-Mima, surface QG) on
// [0, 2pi)^2, pseudo-spectral with FFTW3 and dealiased by the 2/3 rule, so every triad conserves E and Z exactly
// (§III's truncated Euler equations). The model is eci::spectral::flow2d (spectral/flow.hpp); this header keeps the
// Navier-Stokes names of it. Its methods and one budgeted step for loops of one's own: spectral/step.hpp.
// Link eci::spectral.
#pragma once

#include "../spectral/flow.hpp"

namespace eci {

/// The Navier-Stokes names of the spectral flow (params().equation picks the equation; Navier-Stokes by default).
using ns2d_forcing = spectral::forcing_kind;
using ns2d_params = spectral::flow_params;
using ns2d_rates = spectral::flow_rates;
using ns2d_budget = spectral::flow_budget;
using navier_stokes_2d = spectral::flow2d;

}  // namespace eci

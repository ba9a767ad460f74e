// Surface quasi-geostrophy: d theta/dt + u . grad theta = F - D, u = (-d psi/dy, d psi/dx), psi_k = theta_k / |k|.
// E = 1/2 sum |theta_k|^2 / |k| and the variance 1/2 sum |theta_k|^2. theta is not a multiple of lap psi plus psi,
// so the nonlinear term takes the advective form's 5 transforms.
#include <cmath>

#include "eci/spectral/equation.hpp"
#include "eci/spectral/flow.hpp"

namespace eci::spectral {

const equation surface_qg_equation{
    "surface-qg",
    "surface quasi-geostrophic buoyancy theta, psi_k = theta_k / |k|, pseudo-spectral (FFTW); invariants energy, "
    "variance; docs/turbulence.md",
    "buoyancy",
    "theta",
    {"energy", "variance"},
    [](const flow_params&, double kx, double ky) { return 1.0 / std::sqrt(kx * kx + ky * ky); },
    nullptr,
    nonlinear_form::advective,
    [](const flow_params& p) { refuse_wave_parameters(p, "surface-qg"); },
    "docs/turbulence.md",
    "SurfaceQG",
    "Surface quasi-geostrophy: d theta/dt + u . grad theta = forcing - dissipation with psi_k = theta_k / |k|. "
    "Invariants energy 1/2 sum |theta_k|^2 / |k| and variance 1/2 sum |theta_k|^2.",
};

}  // namespace eci::spectral

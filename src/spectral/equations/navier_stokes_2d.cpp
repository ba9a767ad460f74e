// Navier-Stokes (2-D incompressible, vorticity form): d omega/dt + J(psi, omega) = F - D, omega = lap psi.
// E = 1/2 <|u|^2> = 1/2 sum |omega_k|^2 / k^2 and Z = 1/2 <omega^2>; Basdevant's 4 transforms.
#include "eci/spectral/equation.hpp"
#include "eci/spectral/flow.hpp"

namespace eci::spectral {

const equation navier_stokes_2d_equation{
    "navier-stokes-2d",
    "2-D incompressible Navier-Stokes/Euler vorticity on [0,2pi)^2, dealiased pseudo-spectral (FFTW); invariants "
    "energy, enstrophy; docs/turbulence.md",
    "vorticity",
    "omega",
    {"energy", "enstrophy"},
    [](const flow_params&, double kx, double ky) { return -1.0 / (kx * kx + ky * ky); },  // omega_k = -k^2 psi_k
    nullptr,
    nonlinear_form::basdevant,
    [](const flow_params& p) { refuse_wave_parameters(p, "navier-stokes-2d"); },
    "docs/turbulence.md",
    "NavierStokes2D",
    "The 2-D incompressible vorticity equation on [0, 2pi)^2, pseudo-spectral (FFTW), dealiased by the 2/3 rule so "
    "that every triad keeps energy and enstrophy (the paper's section III at scale). Invariants energy, enstrophy "
    "(inviscid, unforced).",
};

}  // namespace eci::spectral

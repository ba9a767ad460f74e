// Charney-Hasegawa-Mima, or equivalent-barotropic quasi-geostrophy on a beta-plane:
//     dq/dt + J(psi, q) + beta d psi/dx = F - D,   q = lap psi - F_d psi   (F_d = 1 / L_d^2 >= 0).
// With F_d = 1 and the beta term it is the Hasegawa-Mima equation of drift waves; with F_d = beta = 0, Navier-Stokes.
// E = 1/2 sum |q_k|^2 / (k^2 + F_d), Z = 1/2 sum |q_k|^2. The beta term is the imaginary linear coefficient
// i beta k_x / (k^2 + F_d): Rossby waves with omega = -beta k_x / (k^2 + F_d), which change neither invariant.
// u . grad q = u . grad lap psi (u . grad psi = 0), so Basdevant's form holds.
#include <cmath>
#include <stdexcept>

#include "eci/spectral/equation.hpp"
#include "eci/spectral/flow.hpp"

namespace eci::spectral {

const equation charney_hasegawa_mima_equation{
    "charney-hasegawa-mima",
    "quasi-geostrophic potential vorticity on a beta-plane (Charney-Hasegawa-Mima; --beta, --deformation F = "
    "1/L_d^2), pseudo-spectral (FFTW); invariants energy, enstrophy; docs/turbulence.md",
    "potential vorticity",
    "q",
    {"energy", "enstrophy"},
    [](const flow_params& p, double kx, double ky) { return -1.0 / (kx * kx + ky * ky + p.deformation); },
    // dq_k/dt = -i beta k_x psi_k = i beta k_x q_k / (k^2 + F_d)
    [](const flow_params& p, double kx, double ky) { return p.beta * kx / (kx * kx + ky * ky + p.deformation); },
    nonlinear_form::basdevant,
    [](const flow_params& p) {
        if (!(std::isfinite(p.beta))) throw std::invalid_argument("beta must be finite");
        if (!(std::isfinite(p.deformation) && p.deformation >= 0.0))
            throw std::invalid_argument("deformation F = 1/L_d^2 must be finite and >= 0");
    },
    "docs/turbulence.md",
    "CharneyHasegawaMima",
    "Quasi-geostrophic potential vorticity on a beta-plane (Charney-Hasegawa-Mima): dq/dt + J(psi, q) + beta "
    "dpsi/dx = forcing - dissipation, q = lap psi - F psi with F = deformation = 1/L_d^2 >= 0. Rossby waves "
    "omega = -beta k_x / (k^2 + F). Invariants energy 1/2 sum |q_k|^2 / (k^2 + F), enstrophy 1/2 sum |q_k|^2.",
};

}  // namespace eci::spectral

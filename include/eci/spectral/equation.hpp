// A spectral equation as a small module: what makes Navier-Stokes, Charney-Hasegawa-Mima and surface QG different,
// on the shared grid and run of flow.hpp. Each is one file in src/spectral/equations/ and one entry in equations().
//
// The equations eci solves are one family: a scalar q advected by the incompressible flow of a streamfunction
// psi that is a linear function of q, plus linear terms and forcing,
//     dq/dt = -u . grad q + L q + F,   u = (-d psi/dy, d psi/dx),   psi_k = a(k) q_k,
// with a(k) real. Every triad of the dealiased nonlinear term then conserves Z = 1/2 sum |q_k|^2 and
// E = 1/2 sum |a(k)| |q_k|^2, and a purely imaginary linear coefficient (a wave such as Rossby's) changes neither.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace eci::spectral {

struct flow_params;

/// How the nonlinear term is computed on the grid (each is written with grid.hpp's primitives in flow.cpp).
enum class nonlinear_form {
    /// Basdevant's 4 transforms (inverse u, v; forward uv, v^2 - u^2): u . grad q = d_x d_y (v^2 - u^2) +
    /// (d_x^2 - d_y^2)(uv) holds when q - lap psi is a multiple of psi (u . grad psi = 0), as for Navier-Stokes and
    /// Charney-Hasegawa-Mima.
    basdevant,
    /// The advective form for any a(k), 5 transforms: inverse u, v, dq/dx, dq/dy; forward u . grad q.
    advective,
};

/// One equation: its names, inversion, dispersion and nonlinear form. Parameters it reads live in flow_params.
struct equation {
    std::string_view name;     ///< the CLI's model name, e.g. "navier-stokes-2d"
    std::string_view title;    ///< one line for `eci list`
    std::string_view field;    ///< the evolved field, e.g. "vorticity" (snapshot names, figure titles)
    std::string_view symbol;   ///< its symbol, e.g. "omega" (the checkpoint's dataset omega_hat, figure labels)
    std::string_view invariant_names[2];  ///< E's and Z's names, e.g. "energy", "enstrophy"
    /// psi_k = inversion(p, kx, ky) q_k for k != 0 (a(k) above).
    double (*inversion)(const flow_params& p, double kx, double ky);
    /// The imaginary part c(k) of the linear coefficient, dq_k/dt = i c(k) q_k (waves); nullptr: none.
    double (*dispersion)(const flow_params& p, double kx, double ky);
    nonlinear_form form;
    /// Throws std::invalid_argument naming a bad parameter of this equation (nullptr: none to check).
    void (*validate)(const flow_params& p);
    /// The docs page of the equation (Python's help names it).
    std::string_view docs;
    /// The Python class (eci.models.<python_class>), e.g. "NavierStokes2D".
    std::string_view python_class;
    /// What the equation is, a few sentences: the Python class's help (before what every flow shares).
    std::string_view summary;
};

/// Every equation, in `eci list` order.
const std::vector<const equation*>& equations();
/// The equation of that name; throws std::invalid_argument listing the names when there is none.
const equation& find_equation(std::string_view name);
/// For an equation's validate: throws std::invalid_argument when beta or the deformation F is set, which
/// `equation` (the name in the message) does not read.
void refuse_wave_parameters(const flow_params& p, std::string_view equation);

// The modules (src/spectral/equations/*.cpp).
extern const equation navier_stokes_2d_equation;
extern const equation charney_hasegawa_mima_equation;
extern const equation surface_qg_equation;

}  // namespace eci::spectral

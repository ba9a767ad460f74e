// The 2-D spectral equations as models the steppers step: Navier-Stokes (and Charney-Hasegawa-Mima, surface QG) on
// [0, 2pi)^2, pseudo-spectral with FFTW3 and dealiased by the 2/3 rule, so every triad conserves E and Z exactly
// (§III's truncated Euler equations). The model is eci::spectral::flow2d (spectral/flow.hpp); this header keeps the
// names of the Navier-Stokes model and adds the stepping with exact budgets. Link eci::spectral.
#pragma once

#include <array>
#include <complex>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "../concepts.hpp"
#include "../integrate.hpp"
#include "../spectral/flow.hpp"
#include "../steppers/conservative_rk.hpp"
#include "../steppers/explicit_rk.hpp"

namespace eci {

/// The Navier-Stokes names of the spectral flow (params().equation picks the equation; Navier-Stokes by default).
using ns2d_forcing = spectral::forcing_kind;
using ns2d_params = spectral::flow_params;
using ns2d_rates = spectral::flow_rates;
using ns2d_budget = spectral::flow_budget;
using navier_stokes_2d = spectral::flow2d;

/// A step abandoned between attempts because `stop()` said so; the state may be part-way through the step.
class step_interrupted : public std::runtime_error {
   public:
    using std::runtime_error::runtime_error;
};

namespace detail {

/// The Butcher tableau of a Runge-Kutta stepper (conventional or conservative): its weights weigh the budget.
template <class St> struct tableau_of;
template <const auto& T, state S> struct tableau_of<explicit_rk<T, S>> {
    static constexpr const auto& value = T;
};
template <const auto& T, state S, sign_rule R> struct tableau_of<conservative_rk<T, S, R>> {
    static constexpr const auto& value = T;
};

template <class St>
void ns2d_attempt(St& stepper, navier_stokes_2d& m, navier_stokes_2d::state_type& x, double t, double dt,
                  int halvings_left, ns2d_budget& b, run_stats& stats, bool (*stop)()) {
    constexpr const auto& T = tableau_of<St>::value;
    static_assert(T.stages <= 16, "the flow records the rates of at most 16 stages");
    m.start_recording();
    const step_result r = stepper.step(m, x, t, dt);
    stats.rhs_evals += T.stages;
    if (r) {
        // Sum w xi changes by exactly dt sum_j b_j sum_k w_k 2 psi_k^(j) S_k^(j) (errata item 9): split S into
        // nonlinear (zero), linear and forcing parts, these are the discrete dissipation and injection.
        const auto rec = m.recorded();
        for (std::size_t j = 0; j < T.stages; ++j) {
            const double w = dt * T.b[j];
            b.energy_injection += w * rec[j].energy_injection;
            b.energy_dissipation += w * rec[j].energy_dissipation;
            b.enstrophy_injection += w * rec[j].enstrophy_injection;
            b.enstrophy_dissipation += w * rec[j].enstrophy_dissipation;
        }
        m.stop_recording();
        return;
    }
    m.stop_recording();
    // Basdevant's form leaves round-off of random sign in components that are exactly zero (a Taylor-Green flow's),
    // where the paper's radicand is then negative at every step size; the advective form's round-off differs (for
    // such symmetric flows its products cancel exactly). Retry the attempt in it once before halving.
    if (m.form() == spectral::nonlinear_form::basdevant) {
        m.set_form(spectral::nonlinear_form::advective);
        try {
            ns2d_attempt(stepper, m, x, t, dt, halvings_left, b, stats, stop);
        } catch (...) {
            m.set_form(spectral::nonlinear_form::basdevant);
            throw;
        }
        m.set_form(spectral::nonlinear_form::basdevant);
        m.count_form_retry();
        return;
    }
    if (halvings_left == 0) throw step_size_underflow(t, r.component, dt);
    // a cascade of halvings can take long: let the caller stop it (Ctrl-C)
    if (stop && stop()) throw step_interrupted("step interrupted while halving");
    ++stats.step_reductions;
    ns2d_attempt(stepper, m, x, t, 0.5 * dt, halvings_left - 1, b, stats, stop);
    ns2d_attempt(stepper, m, x, t + 0.5 * dt, 0.5 * dt, halvings_left - 1, b, stats, stop);
}

}  // namespace detail

/// One step of a Runge-Kutta stepper (conventional or conservative) on the vorticity equation: draws the step's
/// stochastic forcing, steps (halving on a failed step, the forcing held), and adds the step's injection and
/// dissipation, integrated with the stepper's own stage values and weights, to `budget`. Between halvings it
/// throws step_interrupted if `stop` (optional) returns true.
template <class St>
void ns2d_step(St& stepper, navier_stokes_2d& m, navier_stokes_2d::state_type& x, double t, double dt,
               ns2d_budget& budget, run_stats& stats, int max_halvings = 40, bool (*stop)() = nullptr) {
    // A conservative stepper remedies isolated negative radicands exactly when it knows the invariants' weights
    // (issue 9); hand it E's and Z's once.
    if constexpr (requires { stepper.set_quadratic_invariants(m.quadratic_invariant_weights()); }) {
        if (stepper.quadratic_invariants().empty() || stepper.quadratic_invariants().front().size() != m.size())
            stepper.set_quadratic_invariants(m.quadratic_invariant_weights());
    }
    m.draw_forcing(dt);
    detail::ns2d_attempt(stepper, m, x, t, dt, max_halvings, budget, stats, stop);
    ++stats.steps;
}

/// The methods ns2d_step can step the vorticity equation with (Runge-Kutta steppers, whose stages and weights the
/// budget is integrated with), default first: the CLI's and the Python module's one list.
inline const std::vector<std::string>& ns2d_methods() {
    static const std::vector<std::string> names{"c-rk4", "c-pc", "c-rk2", "rk4", "pc", "rk2", "euler"};
    return names;
}

/// Calls fn(stepper) with a default-constructed stepper of the method `name` (one of ns2d_methods()); false if it
/// is not one of them.
template <class Fn>
bool with_ns2d_method(const std::string& name, Fn&& fn) {
    using S = navier_stokes_2d::state_type;
    if (name == "c-pc") return fn(c_pc<S>{}), true;
    if (name == "c-rk2") return fn(c_rk2<S>{}), true;
    if (name == "c-rk4") return fn(c_rk4<S>{}), true;
    if (name == "pc") return fn(pc<S>{}), true;
    if (name == "rk2") return fn(rk2<S>{}), true;
    if (name == "rk4") return fn(rk4<S>{}), true;
    if (name == "euler") return fn(euler<S>{}), true;
    return false;
}

}  // namespace eci

// One budgeted step of a spectral flow for loops of one's own, and the methods that run on the flows: the driver
// and the registry over the model (models/navier_stokes_2d.hpp, which includes neither). Link eci::spectral.
#pragma once

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "../integrate.hpp"
#include "../models/navier_stokes_2d.hpp"
#include "../registry.hpp"

namespace eci {

/// One step of a Runge-Kutta stepper (conventional or conservative) on a flow, as eci::solve takes it: the step's
/// stochastic forcing drawn, a failed attempt retried in the advective form and then halved (the forcing held),
/// and the step's injection and dissipation, integrated with the stepper's own stage values and weights (the
/// flow's step hooks, spectral/flow.hpp), added to `budget`. Between halvings it throws eci::interrupted if `stop`
/// (optional) returns true. For loops of one's own; eci::solve runs the same step.
template <class St>
void ns2d_step(St& stepper, navier_stokes_2d& m, navier_stokes_2d::state_type& x, double t, double dt,
               ns2d_budget& budget, run_stats& stats, int max_halvings = 40, bool (*stop)() = nullptr) {
    // A conservative stepper remedies isolated negative radicands exactly when it knows the invariants' weights;
    // hand it E's and Z's once.
    if constexpr (requires { stepper.set_quadratic_invariants(m.quadratic_invariant_weights()); }) {
        if (stepper.quadratic_invariants().empty() || stepper.quadratic_invariants().front().size() != m.size())
            stepper.set_quadratic_invariants(m.quadratic_invariant_weights());
    }
    run_options opt;
    opt.max_halvings = max_halvings;
    if (stop) opt.stop_between_attempts = stop;
    m.begin_step(dt);
    const detail::held_count<navier_stokes_2d> counted{m, &stats.rhs_evals};
    detail::advance_with_reduction(stepper, counted, x, t, dt, opt, stats);
    ++stats.steps;
    const ns2d_budget& b = m.step_budget();
    budget.energy_injection += b.energy_injection;
    budget.energy_dissipation += b.energy_dissipation;
    budget.enstrophy_injection += b.enstrophy_injection;
    budget.enstrophy_dissipation += b.enstrophy_dissipation;
}

/// The methods that run on the spectral flows, as the registry computes them (the Runge-Kutta engines over the
/// fixed-step tableaux, whose weights integrate the budget), the conservative ones first, higher orders first:
/// the CLI's and the Python module's one list, its first the default.
inline const std::vector<std::string>& ns2d_methods() {
    static const std::vector<std::string> names = [] {
        std::vector<method_info> ms = methods_for<navier_stokes_2d>();
        std::ranges::stable_sort(ms, [](const method_info& a, const method_info& b) {
            return a.conservative != b.conservative ? a.conservative : a.order > b.order;
        });
        std::vector<std::string> out;
        for (const method_info& m : ms) out.emplace_back(m.name);
        return out;
    }();
    return names;
}

}  // namespace eci

// A program of an eci user outside the tree: C-PC on a random 300-mode n-wave system, built with the consumer's
// own default flags. Exits non-zero if energy or enstrophy drift beyond round-off.
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include <eci/eci.hpp>
#include <eci/models/n_wave.hpp>
#include <eci/version.hpp>

int main() {
    const auto model = eci::n_wave<double>::random(300, 4, 7);
    std::vector<double> x = model.random_state(11);
    const double e0 = model.energy(x), z0 = model.enstrophy(x);
    eci::c_pc<std::vector<double>> stepper;
    const std::uint64_t steps = 2000;
    eci::integrate_n_steps(stepper, model, x, 0.0, 1e-3, steps);
    // Each step rounds every psi^2 once: the sums random-walk by about eps sqrt(steps) relative.
    const double bound = 8.0 * std::numeric_limits<double>::epsilon() * std::sqrt(double(steps));
    const double de = std::abs(model.energy(x) - e0) / e0, dz = std::abs(model.enstrophy(x) - z0) / z0;
    std::printf("eci %s: C-PC %llu steps, relative drift E %.2e Z %.2e (bound %.2e)\n", eci::version,
                static_cast<unsigned long long>(steps), de, dz, bound);
    return de <= bound && dz <= bound ? 0 : 1;
}

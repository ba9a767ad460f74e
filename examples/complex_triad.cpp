// Example: a resonant triad of complex wave amplitudes with linear rotation, a' = i w a + M conj(a_p a_q),
// written by the user for std::vector<std::complex<double>>; C-PC keeps energy and enstrophy to round-off.
#include <complex>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <vector>

#include <eci/eci.hpp>

int main() {
    using state = std::vector<std::complex<double>>;
    const double k[3] = {1.0, 2.0, 3.0};  // wavenumbers
    // Coupling proportional to (p^2 - q^2, q^2 - k^2, k^2 - p^2): sum M = 0 and sum k^2 M = 0 (the paper's eqs. 2-3),
    // so E = 1/2 sum |a|^2 and Z = 1/2 sum k^2 |a|^2 are invariant. The rotation i w a changes no |a|.
    const double M[3] = {-5.0 / 8.0, 1.0, -3.0 / 8.0};
    const double w[3] = {0.3, -1.1, 0.7};
    const std::complex<double> i(0.0, 1.0);

    auto triad = [&](const state& a, state& dadt, double /*t*/) {
        dadt[0] = i * w[0] * a[0] + M[0] * std::conj(a[1] * a[2]);
        dadt[1] = i * w[1] * a[1] + M[1] * std::conj(a[2] * a[0]);
        dadt[2] = i * w[2] * a[2] + M[2] * std::conj(a[0] * a[1]);
    };
    auto energy = [](const state& a) { return 0.5 * (std::norm(a[0]) + std::norm(a[1]) + std::norm(a[2])); };
    auto enstrophy = [&](const state& a) {
        return 0.5 * (k[0] * k[0] * std::norm(a[0]) + k[1] * k[1] * std::norm(a[1]) + k[2] * k[2] * std::norm(a[2]));
    };

    const state a0{{1.0, 0.2}, {0.1, -0.5}, {-0.8, 0.6}};
    const double dt = 0.02, t_end = 2000.0;
    const std::uint64_t steps = eci::steps_to_reach(0.0, t_end, dt);
    // Round-off only: a few eps per step, adding up as a random walk (see tests/numeric/test_conservation.cpp).
    const double tolerance = 4.0 * std::numeric_limits<double>::epsilon() * std::sqrt(double(steps));

    auto drift = [&](auto stepper, const char* name) {
        state a = a0;
        double worst = 0.0;
        auto watch = [&](const state& s, double) {  // an odeint-style observer (x, t)
            worst = std::fmax(worst, std::fabs(energy(s) / energy(a0) - 1.0));
            worst = std::fmax(worst, std::fabs(enstrophy(s) / enstrophy(a0) - 1.0));
        };
        const eci::run_stats stats = eci::integrate_to(stepper, triad, a, 0.0, t_end, dt, watch);
        std::printf("%-5s to t = %g in %llu steps: max relative drift of E and Z %.2e (%llu step reductions)\n", name,
                    t_end, static_cast<unsigned long long>(stats.steps), worst,
                    static_cast<unsigned long long>(stats.step_reductions));
        return worst;
    };

    const double c_pc = drift(eci::c_pc<state>{}, "c-pc");
    const double pc = drift(eci::pc<state>{}, "pc");
    std::printf("tolerance (4 eps sqrt(steps)) %.2e\n", tolerance);

    if (!(c_pc <= tolerance)) {
        std::fprintf(stderr, "complex_triad: C-PC drifted beyond round-off\n");
        return 1;
    }
    if (!(pc > tolerance)) {
        std::fprintf(stderr, "complex_triad: PC kept the invariants too; the example shows nothing\n");
        return 1;
    }
    return 0;
}

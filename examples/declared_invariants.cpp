// Example: a user's own spectral system of 3000 modes that declares its quadratic invariants, so that at a large
// step the few modes with a negative radicand are remedied exactly instead of halving the step for all of them.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <eci/eci.hpp>
#include <limits>
#include <vector>

/// Modes on a ring, each triad (i, i+1, i+3) obeying the paper's eqs. (2)-(3), so E = 1/2 sum psi^2 and
/// Z = 1/2 sum k^2 psi^2 are invariant.
struct ring_of_triads {
    std::vector<double> k;  // wavenumbers
    std::vector<double> mk, mp, mq;

    explicit ring_of_triads(std::size_t n) : k(n), mk(n), mp(n), mq(n) {
        for (std::size_t i = 0; i < n; ++i) k[i] = 1.0 + double((i * 7919) % 97) / 10.0;
        for (std::size_t i = 0; i < n; ++i) {
            const double k2 = k[i] * k[i], p2 = k[(i + 1) % n] * k[(i + 1) % n], q2 = k[(i + 3) % n] * k[(i + 3) % n];
            const double s = 1.0 / std::max({std::abs(p2 - q2), std::abs(q2 - k2), std::abs(k2 - p2), 1e-300});
            mk[i] = s * (p2 - q2), mp[i] = s * (q2 - k2), mq[i] = s * (k2 - p2);
        }
    }
    void operator()(const std::vector<double>& x, std::vector<double>& dxdt, double /*t*/) const {
        const std::size_t n = x.size();
        std::fill(dxdt.begin(), dxdt.end(), 0.0);
        for (std::size_t i = 0; i < n; ++i) {
            const std::size_t p = (i + 1) % n, q = (i + 3) % n;
            dxdt[i] += mk[i] * x[p] * x[q];
            dxdt[p] += mp[i] * x[q] * x[i];
            dxdt[q] += mq[i] * x[i] * x[p];
        }
    }
    /// The declaration the remedy needs: E and Z as weights per mode (docs/models.md).
    eci::quadratic_weights quadratic_invariant_weights() const {
        eci::quadratic_weights w(2, std::vector<double>(k.size(), 0.5));
        for (std::size_t i = 0; i < k.size(); ++i) w[1][i] = 0.5 * k[i] * k[i];
        return w;
    }
};

int main() {
    const ring_of_triads f(3000);
    std::vector<double> x0(3000);
    for (std::size_t i = 0; i < x0.size(); ++i) x0[i] = std::sin(0.37 * double(i) + 1.0);
    const auto w = f.quadratic_invariant_weights();
    auto invariant = [](const std::vector<double>& x, const std::vector<double>& wj) {
        double s = 0.0;
        for (std::size_t i = 0; i < x.size(); ++i) s += wj[i] * x[i] * x[i];
        return s;
    };
    const double dt = 0.05;
    const std::uint64_t steps = 200;
    int status = 0;
    for (eci::radicand_policy policy : {eci::radicand_policy::remedy, eci::radicand_policy::halve}) {
        eci::c_pc<std::vector<double>> stepper;
        stepper.remedy.policy = policy;  // remedy is the default; halve is the paper's procedure
        std::vector<double> x = x0;
        const eci::run_stats s = eci::integrate_n_steps(stepper, f, x, 0.0, dt, steps);
        const double de = std::abs(invariant(x, w[0]) / invariant(x0, w[0]) - 1.0);
        const double dz = std::abs(invariant(x, w[1]) / invariant(x0, w[1]) - 1.0);
        std::printf(
            "c-pc, %-6s: %llu steps, %llu halvings, %llu remedied steps (%llu modes), %llu rhs evaluations, "
            "|dE|/E %.1e, |dZ|/Z %.1e\n",
            policy == eci::radicand_policy::remedy ? "remedy" : "halve", static_cast<unsigned long long>(s.steps),
            static_cast<unsigned long long>(s.step_reductions), static_cast<unsigned long long>(s.remedied_steps),
            static_cast<unsigned long long>(s.components_remedied), static_cast<unsigned long long>(s.rhs_evals), de,
            dz);
        // A few roundings per step, a random walk over the steps (plus the plain sums above, ~sqrt(N) eps).
        const double bound = 64.0 * std::numeric_limits<double>::epsilon() * std::sqrt(double(steps));
        if (!(de <= bound && dz <= bound)) status = 1;
        if (policy == eci::radicand_policy::remedy && (s.remedied_steps == 0 || s.step_reductions != 0)) status = 1;
    }
    return status;
}

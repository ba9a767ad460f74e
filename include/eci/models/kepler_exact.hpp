// The exact solution of the Kepler problem (45) for bound orbits, through Kepler's equation solved to
// round-off: the reference for the errors, the order and the orbit's precession measured in the tests.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "kepler.hpp"

namespace eci {

namespace detail {

/// Solve Kepler's equation E - e sin E = M (0 <= e < 1) by Newton's method kept inside the bracket
/// [M - e, M + e] (E - M = e sin E), to full double precision; the bracket makes it converge for every e.
inline double solve_kepler_equation(double M, double e) {
    constexpr double eps = std::numeric_limits<double>::epsilon();
    double lo = M - e, hi = M + e;
    double E = M + 0.85 * e * (std::sin(M) >= 0.0 ? 1.0 : -1.0);  // Danby's starting value
    E = std::clamp(E, lo, hi);
    for (int it = 0; it < 100; ++it) {
        const double f = E - e * std::sin(E) - M;
        (f > 0.0 ? hi : lo) = E;
        double next = E - f / (1.0 - e * std::cos(E));
        if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);  // Newton left the bracket: bisect
        const double tol = 2.0 * eps * std::max(1.0, std::abs(E));
        const bool done = std::abs(next - E) <= tol || hi - lo <= tol;
        E = next;
        if (done) break;
    }
    return E;
}

}  // namespace detail

/// The exact state of a bound Kepler orbit at any time: r = a (1 - e cos E), v_r = n a^2 e sin E / r and
/// theta = theta0 + sgn(ell) (nu(E) - nu(E0)), with nu the true anomaly, unwrapped so theta is continuous.
class kepler_exact {
   public:
    using state_type = kepler::state_type;

    /// Throws std::invalid_argument for an invalid model or state, or an unbound orbit.
    kepler_exact(const kepler& model, const state_type& s0) : theta0_(s0[2]) {
        model.validate();
        model.validate_state(s0);
        const double h = model.hamiltonian(s0);
        a_ = -model.K / (2.0 * h);                               // semi-major axis: H = -K / (2a)
        n_ = std::sqrt(model.K / (model.m * a_ * a_ * a_));       // mean motion
        const auto A = model.runge_lenz(s0);
        e_ = std::min(std::hypot(A[0], A[1]) / model.K, 1.0 - std::numeric_limits<double>::epsilon());  // |A| = K e
        beta_ = e_ / (1.0 + std::sqrt((1.0 - e_) * (1.0 + e_)));
        sense_ = model.ell > 0.0 ? 1.0 : -1.0;
        const double e_sin = s0[0] * s0[1] / (n_ * a_ * a_), e_cos = 1.0 - s0[0] / a_;
        const double E0 = std::atan2(e_sin, e_cos);
        M0_ = E0 - e_sin;
        nu0_ = true_anomaly(E0);
    }

    /// The exact state at time t (the initial state was at t = 0).
    state_type operator()(double t) const {
        constexpr double two_pi = 2.0 * std::numbers::pi;
        const double M = M0_ + n_ * t;
        const double turns = std::round(M / two_pi);
        const double E = detail::solve_kepler_equation(M - two_pi * turns, e_);
        const double r = a_ * (1.0 - e_ * std::cos(E));
        const double vr = n_ * a_ * a_ * e_ * std::sin(E) / r;
        const double theta = theta0_ + sense_ * (true_anomaly(E) + two_pi * turns - nu0_);
        return {r, vr, theta};
    }

    /// The orbital period 2 pi / n.
    double period() const { return 2.0 * std::numbers::pi / n_; }
    /// The semi-major axis a = -K / (2 H).
    double semi_major_axis() const { return a_; }
    /// The eccentricity e = |A| / K.
    double eccentricity() const { return e_; }

   private:
    // nu(E) = E + 2 atan(beta sin E / (1 - beta cos E)): continuous in E, equal to E at every apsis.
    double true_anomaly(double E) const {
        return E + 2.0 * std::atan(beta_ * std::sin(E) / (1.0 - beta_ * std::cos(E)));
    }

    double a_ = 0.0, n_ = 0.0, e_ = 0.0, beta_ = 0.0, sense_ = 1.0, M0_ = 0.0, nu0_ = 0.0, theta0_ = 0.0;
};

}  // namespace eci

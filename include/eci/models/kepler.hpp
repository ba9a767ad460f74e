// The Kepler problem in polar variables, eqs. (43)-(54): the model, its Hamiltonian (46), the Runge-Lenz vector
// (47) as two invariants, the Cartesian position as derived output, the transform (50) behind its C-PC, its
// parameters and the paper's set-ups (Figs. 8, 9).
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

#include "../concepts.hpp"
#include "../detail/format.hpp"
#include "description.hpp"

namespace eci {

/// One particle of mass m in the potential phi = -K / r with angular momentum ell (its sign the sense of
/// rotation), eqs. (45): state (r, v_r, theta). Only bound orbits (H < 0) are accepted.
struct kepler {
    using state_type = std::array<double, 3>;

    double m = 1.0;    ///< mass
    double K = 1.5;    ///< strength of the potential phi = -K / r
    double ell = 1.0;  ///< angular momentum (nonzero; negative for clockwise motion)

    static constexpr std::string_view name = "kepler";  ///< `eci run kepler`
    static constexpr std::string_view description =
        "Kepler problem (45) in polar variables (bound orbits); invariants H (46) and the Runge-Lenz vector (47); "
        "c-pc is eqs. (49)-(54)";
    static constexpr std::array<const char*, 3> component_names{"r", "v_r", "theta"};
    /// --plot's phase-plane panel: the orbit in the plane, x = r cos theta, y = r sin theta.
    static constexpr phase_plane plot_plane{"x", "y", true};

    /// The parameters, with what validate() requires of them.
    static constexpr auto parameters() {
        return std::array<parameter<kepler>, 3>{{
            {"m", "mass", "> 0", member_values<&kepler::m, kepler>},
            {"K", "strength of the potential -K/r", "> 0", member_values<&kepler::K, kepler>},
            {"ell", "angular momentum", "nonzero", member_values<&kepler::ell, kepler>},
        }};
    }
    /// The initial state, one option per component (validate_state() requires r > 0 and a bound orbit).
    static constexpr auto initial_condition() {
        return std::array<state_field, 3>{{{"r", "initial radius", "> 0", 0, 1},
                                           {"v-r", "initial radial velocity", "", 1, 1},
                                           {"theta", "initial angle", "", 2, 1}}};
    }
    /// The paper's set-ups: the orbit r = 1, v_r = theta = 0 with m = 1, K = 3/2, ell = 1 (eccentricity 1/3),
    /// C-PC in 1000 steps of 0.105 (Fig. 9, `eci run kepler`'s default) and PC in 1313 steps of 0.08 (Fig. 8),
    /// which cost the same CPU time.
    static std::array<preset<kepler>, 2> presets() {
        return {{{"fig9", "Fig. 9: C-PC, 1000 steps of 0.105", {}, {1.0, 0.0, 0.0}, "c-pc", 0.105, 105.0},
                 {"fig8", "Fig. 8: PC, 1313 steps of 0.08", {}, {1.0, 0.0, 0.0}, "pc", 0.08, 1313 * 0.08}}};
    }

    /// Throws std::invalid_argument unless m > 0, K > 0, ell != 0, all finite.
    void validate() const {
        detail::require_normal(m, "Kepler m");
        detail::require_normal(K, "Kepler K");
        detail::require_normal(ell, "Kepler ell");
        if (!(m > 0.0)) throw std::invalid_argument("Kepler m must be positive, got " + detail::shortest_text(m));
        if (!(K > 0.0)) throw std::invalid_argument("Kepler K must be positive, got " + detail::shortest_text(K));
        if (ell == 0.0)
            throw std::invalid_argument("Kepler ell must be nonzero (ell = 0 is a radial fall, which the polar "
                                        "formulation cannot integrate)");
    }
    /// Throws std::invalid_argument unless r > 0, the state is finite and the orbit is bound (H < 0).
    void validate_state(const state_type& s) const {
        detail::require_finite(s[0], "Kepler r");
        detail::require_finite(s[1], "Kepler v_r");
        detail::require_finite(s[2], "Kepler theta");
        if (!(s[0] > 0.0)) throw std::invalid_argument("Kepler r must be positive, got " + detail::shortest_text(s[0]));
        // The terms of H, eq. (46), one by one: an overflow in one would make H inf - inf = NaN.
        const double r = s[0];
        detail::require_representable(0.5 * m * s[1] * s[1], "the kinetic energy m v_r^2 / 2", false);
        detail::require_representable(ell * ell / (2.0 * m * r * r), "ell^2 / (2 m r^2) at r = " + detail::shortest_text(r));
        detail::require_representable(K / r, "K / r at r = " + detail::shortest_text(r));
        const double h = hamiltonian(s);
        if (!(h < 0.0))
            throw std::invalid_argument("Kepler orbit is unbound (H = " + detail::shortest_text(h) +
                                        " >= 0); only bound orbits are supported");
        // The orbit runs between the roots of H = ell^2 / (2 m r^2) - K / r; at its pericentre the rates (45b),
        // (45c) and the transform's terms are largest, at its apocentre the smallest: all must be representable.
        const double disc = std::max(0.0, K * K + 2.0 * h * ell * ell / m);
        const double r_min = (ell * ell / m) / (K + std::sqrt(disc)), r_max = (K + std::sqrt(disc)) / (-2.0 * h);
        const std::string where = " on this orbit (r from " + detail::shortest_text(r_min) + " to " +
                                  detail::shortest_text(r_max) + ")";
        detail::require_representable(r_min, "the pericentre" + where);
        detail::require_representable(r_max, "the apocentre" + where);
        detail::require_representable(ell * ell / (m * r_min * r_min * r_min * m), "the largest d v_r/dt" + where);
        detail::require_representable(ell / (m * r_min * r_min), "the largest d theta/dt" + where);
        detail::require_representable(ell / (m * r_max * r_max), "the smallest d theta/dt" + where);
        detail::require_representable(K / (r_max * r_max), "the smallest force K / r^2" + where);
    }

    void operator()(const state_type& s, state_type& dsdt, double /*t*/) const {
        const double r = s[0];
        dsdt[0] = s[1];                                           // eq. (45a)
        dsdt[1] = (ell * ell / (m * r) - K) / (m * r * r);        // eq. (45b), phi' = K / r^2
        dsdt[2] = ell / (m * r * r);                              // eq. (45c)
    }

    /// H, eq. (46); NaN where r <= 0, outside the polar coordinates (a conventional method's large step can take r
    /// through 0: the run then stops there, as on an overflow, instead of going on with a meaningless orbit).
    double hamiltonian(const state_type& s) const {
        if (!(s[0] > 0.0)) return std::numeric_limits<double>::quiet_NaN();
        return 0.5 * m * s[1] * s[1] + ell * ell / (2.0 * m * s[0] * s[0]) - K / s[0];
    }
    /// The Runge-Lenz vector (47), A = v x L + phi r_vec, in the plane: A = a r^ - ell v_r theta^.
    std::array<double, 2> runge_lenz(const state_type& s) const {
        const double a = ell * ell / (m * s[0]) - K, b = -ell * s[1];
        const double c = std::cos(s[2]), sn = std::sin(s[2]);
        return {a * c - b * sn + 0.0, a * sn + b * c + 0.0};  // + 0.0: no "-0" in the output
    }
    /// x component of the Runge-Lenz vector (47).
    double runge_lenz_x(const state_type& s) const { return runge_lenz(s)[0]; }
    /// y component of the Runge-Lenz vector (47).
    double runge_lenz_y(const state_type& s) const { return runge_lenz(s)[1]; }
    /// The angle (in (-pi, pi]) by which the Runge-Lenz vector, the orbit's axis, has turned from `from` to `to`.
    double runge_lenz_turn(const state_type& from, const state_type& to) const {
        const auto a = runge_lenz(from), b = runge_lenz(to);
        return std::atan2(a[0] * b[1] - a[1] * b[0], a[0] * b[0] + a[1] * b[1]);
    }

    /// Figures a run reports at its end (the CLI summary): the turn of the orbit's axis, in degrees.
    std::array<std::pair<const char*, double>, 1> end_of_run_figures(const state_type& x0,
                                                                      const state_type& x) const {
        return {{{"runge_lenz_turn_degrees", runge_lenz_turn(x0, x) * 180.0 / std::numbers::pi}}};
    }

    /// Cartesian x = r cos theta (derived output, for plotting).
    double position_x(const state_type& s) const { return s[0] * std::cos(s[2]); }
    /// Cartesian y = r sin theta (derived output, for plotting).
    double position_y(const state_type& s) const { return s[0] * std::sin(s[2]); }

    /// The invariants by name, in CSV column order.
    static constexpr auto invariants() {
        return std::array<named_invariant<kepler>, 3>{{{"hamiltonian", &kepler::hamiltonian},
                                                       {"runge_lenz_x", &kepler::runge_lenz_x},
                                                       {"runge_lenz_y", &kepler::runge_lenz_y}}};
    }

    /// H (46) and the Runge-Lenz vector (47) as an invariant set (for relaxation and projection; not quadratic).
    struct invariant_set {
        double m, K, ell;
        std::size_t count() const { return 3; }
        double value(const state_type& s, std::size_t i) const {
            const kepler model{m, K, ell};
            return i == 0 ? model.hamiltonian(s) : model.runge_lenz(s)[i - 1];
        }
        void gradient(const state_type& s, std::size_t i, state_type& g) const {
            const double r = s[0];
            if (i == 0) {
                g = {-ell * ell / (m * r * r * r) + K / (r * r), m * s[1], 0.0};
                return;
            }
            // A = (a c - b s, a s + b c), a = ell^2/(m r) - K, b = -ell v_r.
            const double a = ell * ell / (m * r) - K, b = -ell * s[1], ar = -ell * ell / (m * r * r);
            const double c = std::cos(s[2]), sn = std::sin(s[2]);
            if (i == 1)
                g = {ar * c, ell * sn, -a * sn - b * c};
            else
                g = {ar * sn, -ell * c, a * c - b * sn};
        }
    };
    /// H, A_x, A_y.
    invariant_set invariant_functions() const { return {m, K, ell}; }
    /// The three are dependent (|A|^2 = K^2 + 2 H ell^2 / m, ell a parameter): projection and multiple relaxation,
    /// whose linear systems a dependent set makes singular, keep H alone.
    static constexpr std::array<std::size_t, 1> independent_invariants{0};
    /// Output columns computed from the state, printed after the state and before the invariants.
    static constexpr auto derived_columns() {
        return std::array<named_invariant<kepler>, 2>{{{"x", &kepler::position_x}, {"y", &kepler::position_y}}};
    }

    /// The transform (50) extended by the Runge-Lenz vector: xi = (-K/r, m v_r^2/2 + ell^2/(2 m r^2), A_x, A_y),
    /// so H = xi_1 + xi_2 and A = (xi_3, xi_4), all linear; dxi/dt = (K v_r/r^2, -K v_r/r^2, 0, 0).
    /// The inverse is (53a), (53b) with errata item 2 (the new radius), and theta such that A(r, v_r, theta) = A.
    /// The v-projection of that vector equation is (54); (54) alone has a second root (A mirrored about v,
    /// errata item 5) and a double root wherever r equals the semi-major axis (there v is parallel to A),
    /// where Newton on (54) converges only linearly and to sqrt(eps). Newton (Gauss-Newton) on both
    /// projections from the hint's theta has neither problem: it converges cubically to the one root.
    struct transform {
        using state_type = kepler::state_type;
        using xi_type = std::array<double, 4>;
        double m = 1.0, K = 1.5, ell = 1.0;
        int max_iterations = 30;  ///< bound on the Newton iterations for theta

        void to_xi(const state_type& s, xi_type& xi) const {
            const kepler model{m, K, ell};
            const auto A = model.runge_lenz(s);
            xi = {-K / s[0], 0.5 * m * s[1] * s[1] + ell * ell / (2.0 * m * s[0] * s[0]), A[0], A[1]};  // eq. (50)
        }
        /// dxi_1/dt = K v_r / r^2 = -dxi_2/dt (the integrand of eq. (52)); A is constant.
        void xi_rate(const state_type& s, const state_type& /*dsdt*/, xi_type& rate) const {
            const double d = K * s[1] / (s[0] * s[0]);
            rate = {d, -d, 0.0, 0.0};
        }
        /// r, v_r and theta on the branch of the hint; xi_1 >= 0 (errata item 4) or a negative v_r^2 means the
        /// step was too large; a theta solve that does not converge fails the step too.
        step_result from_xi(const xi_type& xi, const state_type& hint, state_type& s, solver_stats& stats) const {
            constexpr double eps = std::numeric_limits<double>::epsilon();
            if (!(xi[0] < 0.0) || !std::isfinite(xi[0])) return step_result::failure(0);
            const double r = -K / xi[0];  // eq. (53a)
            double vr2 = (2.0 * xi[1] - ell * ell / (m * r * r)) / m;  // eq. (53b), errata item 2
            // A radicand negative only by its rounding (a few eps of 2 xi_2 / m) is zero: a turning point, or
            // a circular orbit, where v_r = 0 exactly would otherwise fail at every step size.
            if (vr2 < 0.0 && vr2 >= -4.0 * eps * std::abs(2.0 * xi[1] / m)) vr2 = 0.0;
            if (!(vr2 >= 0.0) || !std::isfinite(vr2)) return step_result::failure(1);
            const double vr = std::copysign(std::sqrt(vr2), hint[1]);
            // The state's A in the rotating frame (r^, theta^); rotate it by theta onto the carried A.
            const double a = ell * ell / (m * r) - K, b = -ell * vr;
            const double ax = xi[2], ay = xi[3];
            const double norm = std::hypot(ax, ay);
            const double scale = K + ell * ell / (m * r) + std::abs(ell * vr);
            double theta = hint[2];
            // A circular orbit (|A| at round-off of its terms) has no axis: theta follows the hint.
            if (norm > std::sqrt(eps) * scale) {
                bool converged = false;
                int it = 0;
                while (!converged && it < max_iterations) {
                    ++it;
                    const double c = std::cos(theta), sn = std::sin(theta);
                    const double sx = a * c - b * sn, sy = a * sn + b * c;
                    // Gauss-Newton on A(theta) - A = 0: the step is the sine of the angle from A(theta) to A
                    // (times |A| / |A(theta)|), so the error e becomes about e - sin e = O(e^3).
                    const double step = (sx * ay - sy * ax) / (sx * sx + sy * sy);
                    if (!(sx * ax + sy * ay > 0.0) && std::abs(step) < 0.5) break;  // at the anti-aligned point
                    theta += step;
                    // A's components carry rounding eps * scale, so the angle is known to eps * scale / |A|.
                    converged = std::abs(step) <= 4.0 * eps * (scale / norm + std::abs(theta));
                }
                stats.record(it);
                if (!converged || !std::isfinite(theta)) return step_result::failure(2);
            }
            s = {r, vr, theta};
            return step_result::success();
        }
    };

    /// The transform (50) for this model's parameters.
    transform linearizing_transform() const { return {m, K, ell}; }
};

}  // namespace eci

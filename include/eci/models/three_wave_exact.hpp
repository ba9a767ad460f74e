// The exact solution of the three-wave model, eq. (1), for any initial condition, in Jacobi elliptic
// functions: the reference against which the integrators of the paper (Figs. 1, 2 and 5) are measured.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <boost/math/special_functions/ellint_1.hpp>
#include <boost/math/special_functions/jacobi_elliptic.hpp>

#include "three_wave.hpp"

namespace eci {

/// Exact solution of eq. (1) through psi0 at t = 0.
///
/// With a_k = psi_k(0)^2, eq. (1) gives psi_k^2 = a_k + M_k u with u' = 2 psi_K psi_P psi_Q, u(0) = 0, so
/// (u')^2 = 4 prod_k (a_k + M_k u), a cubic with roots e_k = -a_k / M_k. If exactly one M_n < 0, the motion
/// has u in [e2, e3], e3 = e_n >= 0 >= e2 = max of the other two roots, and
///   u = e3 - (e3 - e2) sn^2(w t + theta0, m),  m = (e3 - e2) / (e3 - e1),  w^2 = |M_K M_P M_Q| (e3 - e1):
/// mode n goes as sn, the mode owning e2 as cn and the one owning e1 as dn. If two M_k < 0 the model
/// with -M is solved instead, at time -t (psi(-t) solves eq. (1) with -M). M_k = 0 (so P = Q by eq. (3),
/// or cyclically) makes the other two modes rotate rigidly at rate M psi_k. Near the separatrix the error
/// grows like eps / (1 - m), as does the problem's sensitivity to rounding psi0.
class three_wave_exact {
public:
    using state_type = three_wave::state_type;

    /// Solves every degenerate case (fixed point, separatrix m = 1, a zero M_k). Throws std::invalid_argument
    /// if the model fails validate(), psi0 is not finite, or 0 < 1 - m < ~1e-16 (m rounds to 1 off the separatrix).
    three_wave_exact(const three_wave& model, const state_type& psi0) : psi0_(psi0) {
        model.validate();
        for (double v : psi0) detail::require_finite(v, "three-wave initial condition");
        std::array<double, 3> M = model.M, a{};
        int zeros = 0, negative = 0, zero_M = -1;
        for (int i = 0; i < 3; ++i) {
            a[i] = psi0[i] * psi0[i];
            zeros += a[i] == 0.0;
            negative += M[i] < 0.0;
            if (M[i] == 0.0) zero_M = i;
        }
        if (zero_M >= 0) {  // psi_z is constant and the other two rotate (M_i = -M_j by eq. (2))
            const int i = (zero_M + 1) % 3, j = (zero_M + 2) % 3;
            kind_ = M[i] == 0.0 ? kind::fixed : kind::rotation;
            role_ = {i, j, zero_M};
            w_ = M[i] * psi0[zero_M];
            if (w_ != 0.0) period_ = 2.0 * std::acos(-1.0) / std::abs(w_);
            return;
        }
        if (zeros >= 2) return;  // fixed point: u' = 2 psi_K psi_P psi_Q vanishes identically
        if (negative == 2) {     // solve the time-reversed model, which has a single negative M
            sign_t_ = -1.0;
            for (double& m : M) m = -m;
        }
        // Roles: n owns e3 (sn), c owns e2 (cn), d owns e1 (dn). q_k = a_k / |M_k| = |e_k|.
        const int n = M[0] < 0.0 ? 0 : M[1] < 0.0 ? 1 : 2, i = (n + 1) % 3, j = (n + 2) % 3;
        const double qi = a[i] / M[i], qj = a[j] / M[j];
        const int c = qi <= qj ? i : j, d = qi <= qj ? j : i;
        const double Mn = -M[n], e32 = a[n] / Mn + std::min(qi, qj), e31 = a[n] / Mn + std::max(qi, qj);
        kind_ = kind::elliptic;
        role_ = {n, c, d};
        m_ = e32 / e31;  // <= 1 in floating point too
        mc_ = std::abs(qi - qj) / e31;  // 1 - m without cancellation
        if (m_ == 1.0 && mc_ != 0.0)
            throw std::invalid_argument("three_wave_exact: initial condition too close to the separatrix (0 < 1 - m "
                                        "< round-off) for double-precision Jacobi functions");
        k_ = std::sqrt(m_);
        w_ = std::sqrt(Mn * M[c] * M[d] * e31);
        // Signs from eq. (1): psi_d = s_d |.| dn with dn > 0 (psi_d(0) != 0, else a fixed point); psi_c = s_c
        // |.| cn with s_c = sgn psi_c(0), so cn(theta0) >= 0; then dpsi_n/dt = M_n psi_c psi_d forces s_n = -s_c s_d.
        const double s_d = psi0[d] < 0.0 ? -1.0 : 1.0, s_c = psi0[c] < 0.0 ? -1.0 : 1.0, s_n = -s_c * s_d;
        amp_ = {s_n * std::sqrt(Mn * e32), s_c * std::sqrt(M[c] * e32), s_d * std::sqrt(M[d] * e31)};
        // theta0 = F(phi, k), with amplitude phi = atan2(sn, cn) in [-pi/2, pi/2]; F(phi, 1) = asinh(tan phi).
        const double y = s_n * psi0[n] / std::sqrt(Mn), x = std::abs(psi0[c]) / std::sqrt(M[c]);
        if (m_ == 1.0) {  // separatrix: sn = tanh, cn = dn = sech; x > 0 here, else a fixed point
            theta0_ = std::asinh(y / x);
        } else {
            theta0_ = boost::math::ellint_1(k_, std::atan2(y, x));
            four_K_ = 4.0 * boost::math::ellint_1(k_);
            period_ = four_K_ / w_;
        }
    }

    /// psi(t); t may be negative.
    state_type operator()(double t) const {
        state_type psi = psi0_;
        const double s = sign_t_ * t;
        if (kind_ == kind::rotation) {
            const int i = role_[0], j = role_[1];
            const double co = std::cos(w_ * s), si = std::sin(w_ * s);
            psi[i] = psi0_[i] * co + psi0_[j] * si;
            psi[j] = psi0_[j] * co - psi0_[i] * si;
        } else if (kind_ == kind::elliptic) {
            // Reduce modulo the period 4K: Boost's small-k expansion of sn, cn degrades at large arguments.
            double z = w_ * s + theta0_, cn = 0.0;
            if (four_K_ > 0.0) z -= four_K_ * std::round(z / four_K_);
            const double sn = boost::math::jacobi_elliptic(k_, z, &cn, static_cast<double*>(nullptr));
            // dn^2 = 1 - m + m cn^2: Boost's dn loses all accuracy near z = K (mod 2K), this does not.
            psi[role_[0]] = amp_[0] * sn;
            psi[role_[1]] = amp_[1] * cn;
            psi[role_[2]] = amp_[2] * std::sqrt(mc_ + m_ * cn * cn);
        }
        return psi;
    }

    /// The period of the motion: 4 K(m) / w; infinity at a fixed point and on a separatrix.
    double period() const { return period_; }

private:
    enum class kind { fixed, rotation, elliptic };
    kind kind_ = kind::fixed;
    state_type psi0_;
    double sign_t_ = 1.0;  // -1 when the time-reversed model is solved
    std::array<int, 3> role_{};  // elliptic: the sn, cn, dn modes; rotation: i, j and the constant mode
    std::array<double, 3> amp_{};  // signed amplitudes of sn, cn, dn
    double m_ = 0.0, mc_ = 1.0, k_ = 0.0, w_ = 0.0, theta0_ = 0.0, four_K_ = 0.0;
    double period_ = std::numeric_limits<double>::infinity();
};

}  // namespace eci

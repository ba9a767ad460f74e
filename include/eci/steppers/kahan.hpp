// Kahan's unconventional method (Sanz-Serna's ref. [21,22] in the paper): for a quadratic vector field the
// linearly implicit step (I - dt/2 J(x)) (x' - x) = dt f(x), second order, symmetric, one linear solve per step.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <tuple>
#include <type_traits>
#include <utility>

#include "../concepts.hpp"

namespace eci {

namespace detail {

/// Solve M d = b in place (d returned in b) by Gaussian elimination with partial pivoting; false if M is
/// singular to working precision (a zero pivot) or the solution is not finite.
template <std::size_t N>
bool solve_linear(std::array<std::array<double, N>, N> M, std::array<double, N>& b) {
    for (std::size_t c = 0; c < N; ++c) {
        std::size_t p = c;
        for (std::size_t r = c + 1; r < N; ++r)
            if (std::abs(M[r][c]) > std::abs(M[p][c])) p = r;
        if (!(M[p][c] != 0.0)) return false;
        std::swap(M[p], M[c]);
        std::swap(b[p], b[c]);
        for (std::size_t r = c + 1; r < N; ++r) {
            const double l = M[r][c] / M[c][c];
            for (std::size_t j = c; j < N; ++j) M[r][j] -= l * M[c][j];
            b[r] -= l * b[c];
        }
    }
    for (std::size_t c = N; c-- > 0;) {
        double v = b[c];
        for (std::size_t j = c + 1; j < N; ++j) v -= M[c][j] * b[j];
        b[c] = v / M[c][c];
    }
    for (double v : b)
        if (!std::isfinite(v)) return false;
    return true;
}

}  // namespace detail

/// Kahan's method on a fixed-size state S, for a system whose model has `jacobian(x)` returning J as rows (taken
/// from the system passed to step, through model_of). For quadratic f it is exactly Kahan's discretization
/// (x' - x)/dt = the symmetric bilinear form of f at (x, x') plus the average of its linear part; for LV it is
/// symplectic (Sanz-Serna) and keeps a modified H.
template <state S>
class kahan {
   public:
    static constexpr int order = 2;

    template <system<S> F>
        requires has_jacobian<std::remove_cvref_t<decltype(model_of(std::declval<const F&>()))>>
    step_result step(F& f, S& x, double t, double dt) {
        constexpr std::size_t n = std::tuple_size_v<S>;
        S k{};
        f(std::as_const(x), k, t);
        const auto J = model_of(f).jacobian(x);
        std::array<std::array<double, n>, n> M{};
        std::array<double, n> d{};
        for (std::size_t i = 0; i < n; ++i) {
            for (std::size_t j = 0; j < n; ++j) M[i][j] = (i == j ? 1.0 : 0.0) - 0.5 * dt * J[i][j];
            d[i] = dt * k[i];
        }
        if (!detail::solve_linear(M, d)) return step_result::failure(0);
        for (std::size_t i = 0; i < n; ++i)  // a non-finite update fails the step, x untouched
            if (!std::isfinite(x[i] + d[i])) return step_result::failure(i);
        for (std::size_t i = 0; i < n; ++i) x[i] += d[i];
        return step_result::success();
    }
};

}  // namespace eci

// Butcher tableaux as constexpr data. The conventional and the conservative Runge-Kutta engines run any of them.
#pragma once

#include <array>
#include <cstddef>

namespace eci {

/// An explicit Runge-Kutta method: strictly lower-triangular a, weights b, nodes c.
template <std::size_t S>
struct butcher_tableau {
    static constexpr std::size_t stages = S;
    int order;
    std::array<std::array<double, S>, S> a;
    std::array<double, S> b;
    std::array<double, S> c;
};

namespace tableaus {

/// Forward Euler, eq. (7).
inline constexpr butcher_tableau<1> euler{1, {{{0.0}}}, {1.0}, {0.0}};

/// Heun's method, the paper's predictor-corrector, eq. (18).
inline constexpr butcher_tableau<2> heun{2, {{{0.0, 0.0}, {1.0, 0.0}}}, {0.5, 0.5}, {0.0, 1.0}};

/// The explicit midpoint rule (second-order Runge-Kutta).
inline constexpr butcher_tableau<2> midpoint{2, {{{0.0, 0.0}, {0.5, 0.0}}}, {0.0, 1.0}, {0.0, 0.5}};

/// The classical fourth-order Runge-Kutta method.
inline constexpr butcher_tableau<4> rk4{4,
                                        {{{0.0, 0.0, 0.0, 0.0},
                                          {0.5, 0.0, 0.0, 0.0},
                                          {0.0, 0.5, 0.0, 0.0},
                                          {0.0, 0.0, 1.0, 0.0}}},
                                        {1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0},
                                        {0.0, 0.5, 0.5, 1.0}};

}  // namespace tableaus
}  // namespace eci

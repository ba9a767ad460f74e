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

/// An explicit embedded Runge-Kutta pair: weights b (the propagated solution, order `order`) and bhat (the
/// embedded solution, order `embedded_order`) over the same stages; their difference estimates the local error.
template <std::size_t S>
struct embedded_tableau {
    static constexpr std::size_t stages = S;
    int order;           ///< order of the propagated solution (weights b)
    int embedded_order;  ///< order of the embedded solution (weights bhat)
    std::array<std::array<double, S>, S> a;
    std::array<double, S> b;
    std::array<double, S> bhat;
    std::array<double, S> c;
};

/// An embedded pair with a continuous extension: y(t0 + theta h) = y0 + theta (D + (1 - theta)(h k_1 - D +
/// theta (2 D - h (k_1 + k_s) + (1 - theta) h sum_i d_i k_i))), D = y1 - y0, for an FSAL pair (k_s at y1).
template <std::size_t S>
struct dense_embedded_tableau : embedded_tableau<S> {
    std::array<double, S> d;  ///< weights of the quartic term of the continuous extension
};

/// First same as last: the last stage is evaluated at the propagated solution (a's last row is b, c = 1),
/// so a conventional method's last derivative is the next step's first.
template <std::size_t S>
constexpr bool is_fsal(const embedded_tableau<S>& t) {
    if (t.c[S - 1] != 1.0 || t.b[S - 1] != 0.0) return false;
    for (std::size_t j = 0; j < S; ++j)
        if (t.a[S - 1][j] != t.b[j]) return false;
    return true;
}

namespace tableaus {

/// Bogacki & Shampine (1989) 3(2): third-order solution, second-order embedded one, FSAL.
inline constexpr embedded_tableau<4> bogacki_shampine_32{3,
                                                         2,
                                                         {{{0.0, 0.0, 0.0, 0.0},
                                                           {1.0 / 2.0, 0.0, 0.0, 0.0},
                                                           {0.0, 3.0 / 4.0, 0.0, 0.0},
                                                           {2.0 / 9.0, 1.0 / 3.0, 4.0 / 9.0, 0.0}}},
                                                         {2.0 / 9.0, 1.0 / 3.0, 4.0 / 9.0, 0.0},
                                                         {7.0 / 24.0, 1.0 / 4.0, 1.0 / 3.0, 1.0 / 8.0},
                                                         {0.0, 1.0 / 2.0, 3.0 / 4.0, 1.0}};

/// Cash & Karp (1990) 5(4): fifth-order solution, fourth-order embedded one (six stages, no FSAL).
inline constexpr embedded_tableau<6> cash_karp_54{
    5,
    4,
    {{{0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
      {1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0},
      {3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0},
      {3.0 / 10.0, -9.0 / 10.0, 6.0 / 5.0, 0.0, 0.0, 0.0},
      {-11.0 / 54.0, 5.0 / 2.0, -70.0 / 27.0, 35.0 / 27.0, 0.0, 0.0},
      {1631.0 / 55296.0, 175.0 / 512.0, 575.0 / 13824.0, 44275.0 / 110592.0, 253.0 / 4096.0, 0.0}}},
    {37.0 / 378.0, 0.0, 250.0 / 621.0, 125.0 / 594.0, 0.0, 512.0 / 1771.0},
    {2825.0 / 27648.0, 0.0, 18575.0 / 48384.0, 13525.0 / 55296.0, 277.0 / 14336.0, 1.0 / 4.0},
    {0.0, 1.0 / 5.0, 3.0 / 10.0, 3.0 / 5.0, 1.0, 7.0 / 8.0}};

/// Dormand & Prince (1980) 5(4): fifth-order solution, fourth-order embedded one, seven stages with FSAL, and
/// the fourth-order continuous extension of Hairer, Norsett & Wanner (I, section II.6; Shampine 1986).
inline constexpr dense_embedded_tableau<7> dormand_prince_54{{
    5,
    4,
    {{{0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
      {1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
      {3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0, 0.0},
      {44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0, 0.0},
      {19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0, 0.0, 0.0, 0.0},
      {9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0, -5103.0 / 18656.0, 0.0, 0.0},
      {35.0 / 384.0, 0.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0, 0.0}}},
    {35.0 / 384.0, 0.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0, 0.0},
    {5179.0 / 57600.0, 0.0, 7571.0 / 16695.0, 393.0 / 640.0, -92097.0 / 339200.0, 187.0 / 2100.0, 1.0 / 40.0},
    {0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0}},
    {-12715105075.0 / 11282082432.0, 0.0, 87487479700.0 / 32700410799.0, -10690763975.0 / 1880347072.0,
     701980252875.0 / 199316789632.0, -1453857185.0 / 822651844.0, 69997945.0 / 29380423.0}};

/// Fehlberg (1968) 7(8), thirteen stages. Like Boost.Odeint's runge_kutta_fehlberg78 (so the two compare side
/// by side) eci propagates the eighth-order solution and takes the seventh-order one as the embedded estimate.
inline constexpr embedded_tableau<13> fehlberg_78{
    8,
    7,
    {{{0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0},
      {2.0 / 27.0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0},
      {1.0 / 36.0, 1.0 / 12.0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0},
      {1.0 / 24.0, 0, 1.0 / 8.0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0},
      {5.0 / 12.0, 0, -25.0 / 16.0, 25.0 / 16.0, 0, 0, 0, 0, 0, 0, 0, 0, 0},
      {1.0 / 20.0, 0, 0, 1.0 / 4.0, 1.0 / 5.0, 0, 0, 0, 0, 0, 0, 0, 0},
      {-25.0 / 108.0, 0, 0, 125.0 / 108.0, -65.0 / 27.0, 125.0 / 54.0, 0, 0, 0, 0, 0, 0, 0},
      {31.0 / 300.0, 0, 0, 0, 61.0 / 225.0, -2.0 / 9.0, 13.0 / 900.0, 0, 0, 0, 0, 0, 0},
      {2.0, 0, 0, -53.0 / 6.0, 704.0 / 45.0, -107.0 / 9.0, 67.0 / 90.0, 3.0, 0, 0, 0, 0, 0},
      {-91.0 / 108.0, 0, 0, 23.0 / 108.0, -976.0 / 135.0, 311.0 / 54.0, -19.0 / 60.0, 17.0 / 6.0, -1.0 / 12.0, 0, 0,
       0, 0},
      {2383.0 / 4100.0, 0, 0, -341.0 / 164.0, 4496.0 / 1025.0, -301.0 / 82.0, 2133.0 / 4100.0, 45.0 / 82.0,
       45.0 / 164.0, 18.0 / 41.0, 0, 0, 0},
      {3.0 / 205.0, 0, 0, 0, 0, -6.0 / 41.0, -3.0 / 205.0, -3.0 / 41.0, 3.0 / 41.0, 6.0 / 41.0, 0, 0, 0},
      {-1777.0 / 4100.0, 0, 0, -341.0 / 164.0, 4496.0 / 1025.0, -289.0 / 82.0, 2193.0 / 4100.0, 51.0 / 82.0,
       33.0 / 164.0, 12.0 / 41.0, 0, 1.0, 0}}},
    {0, 0, 0, 0, 0, 34.0 / 105.0, 9.0 / 35.0, 9.0 / 35.0, 9.0 / 280.0, 9.0 / 280.0, 0, 41.0 / 840.0, 41.0 / 840.0},
    {41.0 / 840.0, 0, 0, 0, 0, 34.0 / 105.0, 9.0 / 35.0, 9.0 / 35.0, 9.0 / 280.0, 9.0 / 280.0, 41.0 / 840.0, 0, 0},
    {0, 2.0 / 27.0, 1.0 / 9.0, 1.0 / 6.0, 5.0 / 12.0, 1.0 / 2.0, 5.0 / 6.0, 1.0 / 6.0, 2.0 / 3.0, 1.0 / 3.0, 1.0, 0,
     1.0}};

}  // namespace tableaus
}  // namespace eci

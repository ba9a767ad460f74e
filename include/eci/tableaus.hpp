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

/// An FSAL embedded pair with a continuous extension of degree 3 + R (Hairer, Norsett & Wanner I, II.6):
///   y(t0 + theta h) = y0 + theta (F_0 + (1 - theta)(F_1 + theta (F_2 + (1 - theta)(F_3 + theta (F_4 + ...))))),
/// the factors alternating theta and 1 - theta, with F_0 = D = y1 - y0, F_1 = h k_1 - D, F_2 = 2 D - h (k_1 + k_s)
/// (k_s at y1) and F_{3+r} = h sum_i d[r][i] k_i over the S stages and E extra stages. The extra stages are
/// evaluated only for the dense output, after the step: stage S + e at t0 + c_extra[e] h, y0 + h sum_j
/// a_extra[e][j] k_j over the S + e stages before it. DP54: R = 1, E = 0; DP853: R = 4, E = 3.
template <std::size_t S, std::size_t R = 1, std::size_t E = 0>
struct dense_embedded_tableau : embedded_tableau<S> {
    static constexpr std::size_t dense_terms = R;   ///< R
    static constexpr std::size_t extra_stages = E;  ///< E
    std::array<std::array<double, S + E>, R> d;     ///< weights of the terms beyond the cubic
    std::array<std::array<double, S + E>, E> a_extra;  ///< rows of the extra stages
    std::array<double, E> c_extra;                     ///< their nodes
};

/// A dense pair whose error estimate combines two embedded solutions (Dormand-Prince 8(5,3), Hairer's DOP853):
/// with err the difference to bhat's solution (order embedded_order) and err_low to bhat_low's (order low_order),
/// each measured in the RMS norm, the estimate is |err|^2 / sqrt(|err|^2 + low_mix |err_low|^2): for small steps
/// (|err| << |err_low|) O(dt^(2 (embedded_order + 1) - (low_order + 1))), the size of the error of an embedded
/// solution of order 2 embedded_order - low_order (7 for DOP853, the exponent its step control uses), and never
/// larger than |err|.
template <std::size_t S, std::size_t R, std::size_t E>
struct doubly_embedded_tableau : dense_embedded_tableau<S, R, E> {
    int low_order;                  ///< order of the second embedded solution
    std::array<double, S> bhat_low; ///< its weights
    double low_mix;                 ///< the weight of its estimate in the denominator
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
    {{{-12715105075.0 / 11282082432.0, 0.0, 87487479700.0 / 32700410799.0, -10690763975.0 / 1880347072.0,
       701980252875.0 / 199316789632.0, -1453857185.0 / 822651844.0, 69997945.0 / 29380423.0}}},
    {},
    {}};

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

/// Dormand & Prince 8(5,3) (Prince & Dormand 1981; Hairer, Norsett & Wanner I, section II.10, and Hairer's code
/// DOP853, whose coefficients these are): eighth-order solution, embedded solutions of orders 5 and 3 combined into
/// one error estimate (doubly_embedded_tableau), twelve stages and a thirteenth at the new state (FSAL), and a
/// seventh-order continuous extension with three extra stages.
inline constexpr doubly_embedded_tableau<13, 4, 3> dormand_prince_853 = [] {
    doubly_embedded_tableau<13, 4, 3> t{};
    t.order = 8;
    t.embedded_order = 5;
    t.low_order = 3;
    t.low_mix = 0.01;
    t.c = {0.0, 0.526001519587677318785587544488e-01, 0.789002279381515978178381316732e-01,
           0.118350341907227396726757197510, 0.281649658092772603273242802490, 0.333333333333333333333333333333,
           0.25, 0.307692307692307692307692307692, 0.651282051282051282051282051282,
           0.6, 0.857142857142857142857142857142, 1.0, 1.0};
    t.c_extra = {0.1, 0.2, 0.777777777777777777777777777778};
    t.a[1][0] = 5.26001519587677318785587544488e-2;
    t.a[2][0] = 1.97250569845378994544595329183e-2;
    t.a[2][1] = 5.91751709536136983633785987549e-2;
    t.a[3][0] = 2.95875854768068491816892993775e-2;
    t.a[3][2] = 8.87627564304205475450678981324e-2;
    t.a[4][0] = 2.41365134159266685502369798665e-1;
    t.a[4][2] = -8.84549479328286085344864962717e-1;
    t.a[4][3] = 9.24834003261792003115737966543e-1;
    t.a[5][0] = 3.7037037037037037037037037037e-2;
    t.a[5][3] = 1.70828608729473871279604482173e-1;
    t.a[5][4] = 1.25467687566822425016691814123e-1;
    t.a[6][0] = 3.7109375e-2;
    t.a[6][3] = 1.70252211019544039314978060272e-1;
    t.a[6][4] = 6.02165389804559606850219397283e-2;
    t.a[6][5] = -1.7578125e-2;
    t.a[7][0] = 3.70920001185047927108779319836e-2;
    t.a[7][3] = 1.70383925712239993810214054705e-1;
    t.a[7][4] = 1.07262030446373284651809199168e-1;
    t.a[7][5] = -1.53194377486244017527936158236e-2;
    t.a[7][6] = 8.27378916381402288758473766002e-3;
    t.a[8][0] = 6.24110958716075717114429577812e-1;
    t.a[8][3] = -3.36089262944694129406857109825;
    t.a[8][4] = -8.68219346841726006818189891453e-1;
    t.a[8][5] = 2.75920996994467083049415600797e1;
    t.a[8][6] = 2.01540675504778934086186788979e1;
    t.a[8][7] = -4.34898841810699588477366255144e1;
    t.a[9][0] = 4.77662536438264365890433908527e-1;
    t.a[9][3] = -2.48811461997166764192642586468;
    t.a[9][4] = -5.90290826836842996371446475743e-1;
    t.a[9][5] = 2.12300514481811942347288949897e1;
    t.a[9][6] = 1.52792336328824235832596922938e1;
    t.a[9][7] = -3.32882109689848629194453265587e1;
    t.a[9][8] = -2.03312017085086261358222928593e-2;
    t.a[10][0] = -9.3714243008598732571704021658e-1;
    t.a[10][3] = 5.18637242884406370830023853209;
    t.a[10][4] = 1.09143734899672957818500254654;
    t.a[10][5] = -8.14978701074692612513997267357;
    t.a[10][6] = -1.85200656599969598641566180701e1;
    t.a[10][7] = 2.27394870993505042818970056734e1;
    t.a[10][8] = 2.49360555267965238987089396762;
    t.a[10][9] = -3.0467644718982195003823669022;
    t.a[11][0] = 2.27331014751653820792359768449;
    t.a[11][3] = -1.05344954667372501984066689879e1;
    t.a[11][4] = -2.00087205822486249909675718444;
    t.a[11][5] = -1.79589318631187989172765950534e1;
    t.a[11][6] = 2.79488845294199600508499808837e1;
    t.a[11][7] = -2.85899827713502369474065508674;
    t.a[11][8] = -8.87285693353062954433549289258;
    t.a[11][9] = 1.23605671757943030647266201528e1;
    t.a[11][10] = 6.43392746015763530355970484046e-1;
    t.a[12][0] = 5.42937341165687622380535766363e-2;
    t.a[12][5] = 4.45031289275240888144113950566;
    t.a[12][6] = 1.89151789931450038304281599044;
    t.a[12][7] = -5.8012039600105847814672114227;
    t.a[12][8] = 3.1116436695781989440891606237e-1;
    t.a[12][9] = -1.52160949662516078556178806805e-1;
    t.a[12][10] = 2.01365400804030348374776537501e-1;
    t.a[12][11] = 4.47106157277725905176885569043e-2;
    for (std::size_t j = 0; j < 12; ++j) t.b[j] = t.a[12][j];  // the FSAL row is the weights
    // the fifth-order embedded solution: b minus DOP853's error weights (its ER coefficients)
    constexpr std::array<std::size_t, 8> er_stage{0, 5, 6, 7, 8, 9, 10, 11};
    constexpr std::array<double, 8> er{0.1312004499419488073250102996e-1, -0.1225156446376204440720569753e+1,
                                      -0.4957589496572501915214079952, 0.1664377182454986536961530415e+1,
                                      -0.3503288487499736816886487290, 0.3341791187130174790297318841,
                                      0.8192320648511571246570742613e-1, -0.2235530786388629525884427845e-1};
    t.bhat = t.b;
    for (std::size_t m = 0; m < er.size(); ++m) t.bhat[er_stage[m]] = t.b[er_stage[m]] - er[m];
    // the third-order one: DOP853's BHH weights
    t.bhat_low[0] = 0.244094488188976377952755905512;
    t.bhat_low[8] = 0.733846688281611857341361741547;
    t.bhat_low[11] = 0.220588235294117647058823529412e-1;
    t.a_extra[0][0] = 5.61675022830479523392909219681e-2;
    t.a_extra[0][6] = 2.53500210216624811088794765333e-1;
    t.a_extra[0][7] = -2.46239037470802489917441475441e-1;
    t.a_extra[0][8] = -1.24191423263816360469010140626e-1;
    t.a_extra[0][9] = 1.5329179827876569731206322685e-1;
    t.a_extra[0][10] = 8.20105229563468988491666602057e-3;
    t.a_extra[0][11] = 7.56789766054569976138603589584e-3;
    t.a_extra[0][12] = -8.298e-3;
    t.a_extra[1][0] = 3.18346481635021405060768473261e-2;
    t.a_extra[1][5] = 2.83009096723667755288322961402e-2;
    t.a_extra[1][6] = 5.35419883074385676223797384372e-2;
    t.a_extra[1][7] = -5.49237485713909884646569340306e-2;
    t.a_extra[1][10] = -1.08347328697249322858509316994e-4;
    t.a_extra[1][11] = 3.82571090835658412954920192323e-4;
    t.a_extra[1][12] = -3.40465008687404560802977114492e-4;
    t.a_extra[1][13] = 1.41312443674632500278074618366e-1;
    t.a_extra[2][0] = -4.28896301583791923408573538692e-1;
    t.a_extra[2][5] = -4.69762141536116384314449447206;
    t.a_extra[2][6] = 7.68342119606259904184240953878;
    t.a_extra[2][7] = 4.06898981839711007970213554331;
    t.a_extra[2][8] = 3.56727187455281109270669543021e-1;
    t.a_extra[2][12] = -1.39902416515901462129418009734e-3;
    t.a_extra[2][13] = 2.9475147891527723389556272149;
    t.a_extra[2][14] = -9.15095847217987001081870187138;
    t.d[0][0] = -0.84289382761090128651353491142e+1;
    t.d[0][5] = 0.56671495351937776962531783590;
    t.d[0][6] = -0.30689499459498916912797304727e+1;
    t.d[0][7] = 0.23846676565120698287728149680e+1;
    t.d[0][8] = 0.21170345824450282767155149946e+1;
    t.d[0][9] = -0.87139158377797299206789907490;
    t.d[0][10] = 0.22404374302607882758541771650e+1;
    t.d[0][11] = 0.63157877876946881815570249290;
    t.d[0][12] = -0.88990336451333310820698117400e-1;
    t.d[0][13] = 0.18148505520854727256656404962e+2;
    t.d[0][14] = -0.91946323924783554000451984436e+1;
    t.d[0][15] = -0.44360363875948939664310572000e+1;
    t.d[1][0] = 0.10427508642579134603413151009e+2;
    t.d[1][5] = 0.24228349177525818288430175319e+3;
    t.d[1][6] = 0.16520045171727028198505394887e+3;
    t.d[1][7] = -0.37454675472269020279518312152e+3;
    t.d[1][8] = -0.22113666853125306036270938578e+2;
    t.d[1][9] = 0.77334326684722638389603898808e+1;
    t.d[1][10] = -0.30674084731089398182061213626e+2;
    t.d[1][11] = -0.93321305264302278729567221706e+1;
    t.d[1][12] = 0.15697238121770843886131091075e+2;
    t.d[1][13] = -0.31139403219565177677282850411e+2;
    t.d[1][14] = -0.93529243588444783865713862664e+1;
    t.d[1][15] = 0.35816841486394083752465898540e+2;
    t.d[2][0] = 0.19985053242002433820987653617e+2;
    t.d[2][5] = -0.38703730874935176555105901742e+3;
    t.d[2][6] = -0.18917813819516756882830838328e+3;
    t.d[2][7] = 0.52780815920542364900561016686e+3;
    t.d[2][8] = -0.11573902539959630126141871134e+2;
    t.d[2][9] = 0.68812326946963000169666922661e+1;
    t.d[2][10] = -0.10006050966910838403183860980e+1;
    t.d[2][11] = 0.77771377980534432092869265740;
    t.d[2][12] = -0.27782057523535084065932004339e+1;
    t.d[2][13] = -0.60196695231264120758267380846e+2;
    t.d[2][14] = 0.84320405506677161018159903784e+2;
    t.d[2][15] = 0.11992291136182789328035130030e+2;
    t.d[3][0] = -0.25693933462703749003312586129e+2;
    t.d[3][5] = -0.15418974869023643374053993627e+3;
    t.d[3][6] = -0.23152937917604549567536039109e+3;
    t.d[3][7] = 0.35763911791061412378285349910e+3;
    t.d[3][8] = 0.93405324183624310003907691704e+2;
    t.d[3][9] = -0.37458323136451633156875139351e+2;
    t.d[3][10] = 0.10409964950896230045147246184e+3;
    t.d[3][11] = 0.29840293426660503123344363579e+2;
    t.d[3][12] = -0.43533456590011143754432175058e+2;
    t.d[3][13] = 0.96324553959188282948394950600e+2;
    t.d[3][14] = -0.39177261675615439165231486172e+2;
    t.d[3][15] = -0.14972683625798562581422125276e+3;
    return t;
}();

}  // namespace tableaus
}  // namespace eci

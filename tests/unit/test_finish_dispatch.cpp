// The passes that are also compiled for AVX2 and dispatched at run time (C-PC's finish, the compensated C-PC's, the
// conditioned update's common case, and the conventional engine's stage values and update) must round exactly like
// the baseline loop, so that results never depend on the processor.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include <eci/steppers/compensated_c_pc.hpp>
#include <eci/steppers/conservative_rk.hpp>
#include <eci/steppers/explicit_rk.hpp>
#include <eci/tableaus.hpp>

namespace {

std::vector<double> random_values(std::size_t n, unsigned seed, double lo, double hi) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(lo, hi);
    std::vector<double> v(n);
    for (double& x : v) x = u(rng);
    return v;
}

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

// 1001 unknowns: vector body and scalar tail; dt large enough that some radicands are negative.
constexpr std::size_t n = 1001;
constexpr double dt = 0.3;

TEST(FinishDispatch, CpcDispatchedPassRoundsLikeTheInlinedLoop) {
    auto x = random_values(n, 1, -1.0, 1.0);
    const auto k1 = random_values(n, 2, -2.0, 2.0);
    auto o_dispatched = random_values(n, 3, -1.0, 1.0), o_inline = o_dispatched;
    // three radicands of +inf (1e200 * 1e200), one in the vector body, two in the tail, and one of 1e300 (finite)
    for (const std::size_t i : {std::size_t{100}, n - 2, n - 1}) x[i] = 1e200, o_dispatched[i] = o_inline[i] = 1e200;
    x[200] = 1e150, o_dispatched[200] = o_inline[200] = 1e150;
    const eci::detail::radicand_counts dispatched =
        eci::detail::c_pc_finish(o_dispatched.data(), x.data(), k1.data(), dt, n);
    const eci::detail::radicand_counts inlined =
        eci::detail::c_pc_finish_inline(o_inline.data(), x.data(), k1.data(), dt, n);
    EXPECT_GT(inlined.negative, 0.0);  // the data exercise the failure count too
    EXPECT_EQ(inlined.infinite, 3.0);
    EXPECT_EQ(dispatched.negative, inlined.negative);
    EXPECT_EQ(dispatched.infinite, inlined.infinite);
    EXPECT_TRUE(same_bits(o_dispatched, o_inline));
}

TEST(FinishDispatch, CompensatedDispatchedPassRoundsLikeTheInlinedLoop) {
    const auto x = random_values(n, 4, -1.0, 1.0), k1 = random_values(n, 5, -2.0, 2.0);
    const auto r = random_values(n, 6, -1e-17, 1e-17);
    auto p_dispatched = random_values(n, 7, -1.0, 1.0), p_inline = p_dispatched;
    auto k0_dispatched = random_values(n, 8, -2.0, 2.0), k0_inline = k0_dispatched;
    const eci::detail::radicand_counts dispatched = eci::detail::compensated_c_pc_finish(
        p_dispatched.data(), k0_dispatched.data(), x.data(), k1.data(), r.data(), dt, n);
    const eci::detail::radicand_counts inlined = eci::detail::compensated_c_pc_finish_inline(
        p_inline.data(), k0_inline.data(), x.data(), k1.data(), r.data(), dt, n);
    EXPECT_GT(inlined.negative, 0.0);
    EXPECT_EQ(dispatched.negative, inlined.negative);
    EXPECT_EQ(dispatched.infinite, inlined.infinite);
    // NaN payloads of failed unknowns compare by bits as well: both loops produce the same default NaN.
    EXPECT_TRUE(same_bits(p_dispatched, p_inline));
    EXPECT_TRUE(same_bits(k0_dispatched, k0_inline));
}

// The conditioned update's common case for complex modes (condition_block, Per = 2): every version (the reference
// loop, SSE2, AVX2 where the processor has it, the dispatched one) gives the same kinds and the same bits. The data
// hold every kind: negative xi, a zero conventional update, moduli within 2^-46, ill-conditioned (filed) and
// well-conditioned modes; 63 modes leave a tail after the vector bodies.
TEST(FinishDispatch, ConditionedModuliRoundLikeTheReferenceLoop) {
    constexpr std::size_t nb = 63;
    const auto x = random_values(2 * nb, 9, -1.0, 1.0), c = random_values(2 * nb, 10, -1.0, 1.0);
    auto xi = random_values(nb, 11, -0.2, 1.5);
    std::vector<double> c2(nb);
    for (std::size_t b = 0; b < nb; ++b) c2[b] = c[2 * b] * c[2 * b] + c[2 * b + 1] * c[2 * b + 1];
    auto cz = c;
    cz[2 * 5] = cz[2 * 5 + 1] = 0.0, c2[5] = 0.0;       // no phase
    xi[7] = c2[7] * (1.0 + 0x1p-50);                     // moduli within 2^-46
    xi[9] = -0.5;                                        // negative
    xi[11] = 1e-3 * (x[22] * x[22] + x[23] * x[23]);     // ill-conditioned: filed
    struct out {
        std::vector<double> o = std::vector<double>(2 * nb), q = std::vector<double>(nb),
                            x2 = std::vector<double>(nb), ratio = std::vector<double>(nb);
        std::vector<unsigned char> kind = std::vector<unsigned char>(nb);
    };
    const auto run = [&](auto fn) {
        out r;
        fn(r.o.data(), r.q.data(), r.x2.data(), r.ratio.data(), r.kind.data(), x.data(), cz.data(), c2.data(),
           xi.data(), 16.0, nb);
        return r;
    };
    const out ref = run(eci::detail::condition_moduli_inline);
    EXPECT_EQ(ref.kind[5], 2);
    EXPECT_EQ(ref.kind[7], 2);
    EXPECT_EQ(ref.kind[9], 2);
    EXPECT_EQ(ref.kind[11], 1);
    EXPECT_NE(std::count(ref.kind.begin(), ref.kind.end(), 0), 0);
    std::vector<out> versions{run(eci::detail::condition_moduli)};
#if ECI_DETAIL_X86_SIMD
    versions.push_back(run(eci::detail::condition_moduli_sse2));
    if (__builtin_cpu_supports("avx2")) versions.push_back(run(eci::detail::condition_moduli_avx2));
#endif
    for (const out& v : versions) {
        EXPECT_EQ(v.kind, ref.kind);
        EXPECT_TRUE(same_bits(v.x2, ref.x2));
        for (std::size_t b = 0; b < nb; ++b) {
            if (ref.kind[b] == 2) continue;  // (the caller's: o, q and the ratio are not used)
            EXPECT_EQ(std::memcmp(&v.o[2 * b], &ref.o[2 * b], 2 * sizeof(double)), 0) << b;
            EXPECT_EQ(std::memcmp(&v.q[b], &ref.q[b], sizeof(double)), 0) << b;
            EXPECT_EQ(std::memcmp(&v.ratio[b], &ref.ratio[b], sizeof(double)), 0) << b;
        }
    }
}

// The conventional engine's stage values (combine_stages) and update with its finiteness test
// (combine_stages_finite_over), dispatched against their baseline bodies, on RK4's b (four nonzero weights) and
// row 3 of a (one nonzero weight). The data: a vector body and a tail (1001 values), subnormal and huge values, and
// an overflow to infinity and a NaN placed in the tail or the body, which the finiteness test must see in both.
TEST(FinishDispatch, StagePassesRoundLikeTheBaselineLoop) {
    constexpr auto J = std::make_index_sequence<4>{};
    const auto& rk4 = eci::tableaus::rk4;
    static constexpr std::array<double, 4> b = eci::tableaus::rk4.b;
    static constexpr std::array<double, 3> a3{eci::tableaus::rk4.a[3][0], eci::tableaus::rk4.a[3][1],
                                              eci::tableaus::rk4.a[3][2]};
    static_assert(a3[2] != 0.0 && rk4.stages == 4);
    auto x = random_values(n, 12, -1.0, 1.0);
    std::array<std::vector<double>, 4> k;
    for (unsigned j = 0; j < 4; ++j) k[j] = random_values(n, 13 + j, -3.0, 3.0);
    x[3] = 1e-310, k[0][4] = 4e-320, x[17] = 1.79e308;  // subnormal, huge (near the largest double)
    const std::array<const double*, 4> kp{k[0].data(), k[1].data(), k[2].data(), k[3].data()};
    const std::array<const double*, 3> kp3{k[0].data(), k[1].data(), k[2].data()};
    // stage values
    std::vector<double> dispatched(n), body(n);
    eci::detail::combine_stages<a3>(dispatched.data(), x.data(), kp3, dt, n, std::make_index_sequence<3>{});
    eci::detail::combine_stages_body<a3>(body.data(), x.data(), kp3, dt, n, std::make_index_sequence<3>{});
    EXPECT_TRUE(same_bits(dispatched, body));
    // the update over k_3, finite, then with an overflow (x[17] + a huge increment) and a NaN in turn
    for (const int bad : {0, 1, 2}) {
        auto k3_dispatched = k[3], k3_body = k[3];
        if (bad == 1) k3_dispatched[17] = k3_body[17] = 1.7e308;  // in the body: x + dt b_3 k_3 overflows
        if (bad == 2) k3_dispatched[n - 1] = k3_body[n - 1] = std::nan("");  // in the tail
        std::array<const double*, 4> kd = kp, kb = kp;
        kd[3] = k3_dispatched.data(), kb[3] = k3_body.data();
        const bool finite_d = eci::detail::combine_stages_finite_over<b, 3>(k3_dispatched.data(), x.data(), kd, dt,
                                                                            n, J);
        const bool finite_b = eci::detail::combine_finite_over_body<b, 3>(k3_body.data(), x.data(), kb, dt, n, J);
        EXPECT_EQ(finite_b, bad == 0) << bad;
        EXPECT_EQ(finite_d, finite_b) << bad;
        EXPECT_TRUE(same_bits(k3_dispatched, k3_body)) << bad;
    }
#if ECI_DETAIL_X86_SIMD
    if (__builtin_cpu_supports("avx2")) {  // the AVX2 copy itself, whatever the dispatch picks
        std::vector<double> wide(n);
        eci::detail::combine_stages_avx2<a3>(wide.data(), x.data(), kp3, dt, n, std::make_index_sequence<3>{});
        EXPECT_TRUE(same_bits(wide, body));
    }
#endif
}

// The rescale finish's pieces (radicand_remedy), their protected statics made visible here.
struct remedy_pieces : eci::radicand_remedy {
    using radicand_remedy::conditioned_pass;
    using radicand_remedy::defect_gram_block;
    using radicand_remedy::factor_two_base;
    using radicand_remedy::gram_add;
    using radicand_remedy::gram_block;
    using radicand_remedy::h_taylor;
    using radicand_remedy::taylor_limit;
#if ECI_DETAIL_X86_SIMD
    using radicand_remedy::factor_two_avx2;
    static void defect_gram_avx2(conditioned_pass& p, std::size_t e0, const double* c2, const double* xi,
                                 std::size_t nb, std::array<double, 3>& d) {
        defect_gram_block_avx2<true>(p, e0, c2, xi, nb, d);
    }
#endif
};

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// A rescale finish's sums over a block (the defects d_j = sum w_j (c2 - xi), the negative xi counted, the
// compensated Gram sums and the magnitudes A_j): the AVX2 version, four elements' terms at a time, and the dispatched
// one give the bits of the scalar loop and gram_add, element by element, as gram_block alone does, for blocks of 64
// and a tail of 3, weights of either sign and of very different sizes, and negative xi in the vector body and the
// tail.
TEST(FinishDispatch, RescaleSumsRoundLikeTheScalarLoop) {
    constexpr std::size_t n = 131;  // two blocks of 64 and one of 3
    std::mt19937_64 rng(31);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    std::vector<double> w0(n), w1(n), c2(n), xi(n);
    for (std::size_t i = 0; i < n; ++i) {
        w0[i] = std::ldexp(u(rng), int(rng() % 41) - 20), w1[i] = u(rng);
        c2[i] = std::ldexp(std::abs(u(rng)), int(rng() % 61) - 30);
        xi[i] = c2[i] * (1.0 + 1e-3 * u(rng));
    }
    xi[5] = -1.0, xi[66] = -2.0, xi[n - 1] = -0.5;
    using pass_t = remedy_pieces::conditioned_pass;
    const auto run = [&](auto block) {
        pass_t p;
        p.w0 = w0.data(), p.w1 = w1.data();
        std::array<double, 3> total{};
        for (std::size_t e0 = 0; e0 < n; e0 += 64) {
            std::array<double, 3> d{};
            block(p, e0, c2.data() + e0, xi.data() + e0, std::min<std::size_t>(64, n - e0), d);
            for (std::size_t j = 0; j < 3; ++j) total[j] += d[j];
        }
        return std::pair{p, total};
    };
    // the scalar reference: the loop finish_by_rescale ran before session 45, and gram_add
    const auto reference = run([&](pass_t& p, std::size_t e0, const double* c, const double* x, std::size_t nb,
                                   std::array<double, 3>& d) {
        double d0 = 0.0, d1 = 0.0, neg = 0.0;
        for (std::size_t b = 0; b < nb; ++b) {
            const double v = c[b] - x[b];
            d0 += w0[e0 + b] * v, d1 += w1[e0 + b] * v, neg += x[b] < 0.0 ? 1.0 : 0.0;
        }
        d = {d0, d1, neg};
        for (std::size_t b = 0; b < nb; ++b) remedy_pieces::gram_add(p, e0 + b, c[b]);
    });
    EXPECT_EQ(reference.second[2], 3.0);
    std::vector<std::remove_const_t<decltype(reference)>> versions{run(remedy_pieces::defect_gram_block)};
#if ECI_DETAIL_X86_SIMD
    if (__builtin_cpu_supports("avx2")) versions.push_back(run(remedy_pieces::defect_gram_avx2));
#endif
    for (const auto& [p, d] : versions) {
        const pass_t& r = reference.first;
        for (std::size_t j = 0; j < 3; ++j) EXPECT_TRUE(same_bits(d[j], reference.second[j])) << j;
        EXPECT_TRUE(same_bits(p.g00.s, r.g00.s) && same_bits(p.g00.err, r.g00.err));
        EXPECT_TRUE(same_bits(p.g01.s, r.g01.s) && same_bits(p.g01.err, r.g01.err));
        EXPECT_TRUE(same_bits(p.g11.s, r.g11.s) && same_bits(p.g11.err, r.g11.err));
        EXPECT_TRUE(same_bits(p.a0, r.a0) && same_bits(p.a1, r.a1));
    }
    // gram_block alone (the conditioned pass's Gram sums; AVX2 where the processor has it) is gram_add's
    const auto gram = run([&](pass_t& p, std::size_t e0, const double* c, const double*, std::size_t nb,
                              std::array<double, 3>&) { remedy_pieces::gram_block(p, e0, c, nb); });
    const pass_t& r = reference.first;
    const pass_t& g = gram.first;
    EXPECT_TRUE(same_bits(g.g00.s, r.g00.s) && same_bits(g.g00.err, r.g00.err));
    EXPECT_TRUE(same_bits(g.g01.s, r.g01.s) && same_bits(g.g01.err, r.g01.err));
    EXPECT_TRUE(same_bits(g.g11.s, r.g11.s) && same_bits(g.g11.err, r.g11.err));
    EXPECT_TRUE(same_bits(g.a0, r.a0) && same_bits(g.a1, r.a1));
}

// The rescale pass o <- o + o h(c_0 w_0 + c_1 w_1) over complex modes: its AVX2 copy rounds like the baseline and
// sees the same non-finite values (an overflow in the vector body, a NaN in the tail).
TEST(FinishDispatch, RescalePassRoundsLikeTheBaselineLoop) {
    constexpr std::size_t ne = 103;
    const auto w0 = random_values(ne, 41, 0.0, 2.0), w1 = random_values(ne, 42, 0.0, 1.0);
    const auto o0 = random_values(2 * ne, 43, -1.0, 1.0);
    const double c0 = 3e-4, c1 = -2e-4;
    auto h = [](double s) { return remedy_pieces::h_taylor(s); };
    for (const int bad : {0, 1, 2}) {
        auto base = o0;
        if (bad == 1) base[2 * 10 + 1] = 1.7976931348623157e308;  // x (1 + h) with h > 0 overflows
        if (bad == 2) base[2 * (ne - 1)] = std::nan("");
        const std::uint64_t flag = remedy_pieces::factor_two_base<2>(base.data(), w0.data(), w1.data(), c0, c1, 0,
                                                                    ne, h);
        EXPECT_EQ(eci::detail::none_non_finite(flag), bad == 0) << bad;
#if ECI_DETAIL_X86_SIMD
        if (__builtin_cpu_supports("avx2")) {
            auto wide = o0;
            if (bad == 1) wide[2 * 10 + 1] = 1.7976931348623157e308;
            if (bad == 2) wide[2 * (ne - 1)] = std::nan("");
            const std::uint64_t wflag = remedy_pieces::factor_two_avx2<2>(wide.data(), w0.data(), w1.data(), c0,
                                                                         c1, 0, ne, h);
            EXPECT_EQ(eci::detail::none_non_finite(wflag), bad == 0) << bad;
            EXPECT_TRUE(same_bits(wide, base)) << bad;
        }
#endif
        if (bad == 0) {
            EXPECT_FALSE(same_bits(base, o0));  // (the pass moved the values)
        }
    }
}

// The series the rescale takes for sqrt(1 + s) - 1 where |s| <= taylor_limit: its truncation, evaluated in long
// double against s / (1 + sqrt(1 + s)), stays below 2^-60 of h for every |s| up to the limit, far below the 2^-53 of
// one rounding (a series too short for its limit, to s^6 at 2^-8, leaves 2^-53 there); in double it is within its
// two roundings of h.
TEST(FinishDispatch, RescaleSeriesIsExactToRoundingWithinItsLimit) {
    const long double limit = remedy_pieces::taylor_limit;
    for (const long double s : {limit, -limit, limit / 2, -limit / 3, limit / 1024, -limit / 1e6L, 1e-12L}) {
        const long double exact = s / (1.0L + std::sqrt(1.0L + s));
        const long double series = remedy_pieces::h_taylor(s);
        EXPECT_LE(std::abs(series - exact), 0x1p-60L * std::abs(exact)) << double(s);
        const double in_double = remedy_pieces::h_taylor(double(s));
        EXPECT_LE(std::abs((long double)in_double - exact), 0x1p-51L * std::abs(exact)) << double(s);
    }
}

}  // namespace

namespace {

// An element-wise system: each unknown's rate depends on itself alone, so a step of a long state and steps of its
// pieces form the same numbers, element by element.
struct elementwise {
    void operator()(const std::vector<double>& x, std::vector<double>& dx, double) const {
        dx.resize(x.size());
        for (std::size_t i = 0; i < x.size(); ++i) dx[i] = -0.3 * x[i] + 0.1 * x[i] * x[i] + 0.05;
    }
};

// C-RK4's paper update (finish_general) is dispatched to an AVX2 copy for ranges of 64 unknowns or more: a step of
// 1000 unknowns (dispatched) equals, bit for bit, steps of its 25 pieces of 40 (below the threshold: the baseline).
TEST(FinishDispatch, ConservativeUpdateOfALongStateRoundsLikeItsShortPieces) {
    const std::vector<double> x0 = random_values(1000, 21, -1.0, 1.0);
    std::vector<double> whole = x0;
    elementwise f;
    eci::c_rk4<std::vector<double>> a;
    ASSERT_TRUE(bool(a.step(f, whole, 0.0, 0.1)));
    std::vector<double> pieces;
    for (std::size_t i0 = 0; i0 < x0.size(); i0 += 40) {
        std::vector<double> y(x0.begin() + std::ptrdiff_t(i0), x0.begin() + std::ptrdiff_t(i0 + 40));
        eci::c_rk4<std::vector<double>> b;
        ASSERT_TRUE(bool(b.step(f, y, 0.0, 0.1)));
        pieces.insert(pieces.end(), y.begin(), y.end());
    }
    EXPECT_TRUE(same_bits(whole, pieces));
    EXPECT_FALSE(same_bits(whole, x0));  // (the step moved the state)
}

}  // namespace

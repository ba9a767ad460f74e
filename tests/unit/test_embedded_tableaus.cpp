// Order conditions of the embedded pairs in tableaus.hpp, checked tree by tree: every rooted tree t with |t| <= p
// must satisfy sum_i b_i Phi_i(t) = 1 / gamma(t), and some tree of order p + 1 must not (the order is exact).
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstddef>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include <eci/tableaus.hpp>

namespace {

constexpr double eps = std::numeric_limits<double>::epsilon();

/// Every rooted tree up to a given order, with its density gamma and, for a tableau, the stage vector
/// Phi_i(t) = prod over subtrees u of (sum_j a_ij Phi_j(u)) and the same with |a| (the magnitude of the rounding).
struct tree {
    int order = 1;
    double gamma = 1.0;
    std::vector<int> children;  // indices of subtrees, non-decreasing (one canonical form per tree)
};

std::vector<tree> rooted_trees(int max_order) {
    std::vector<tree> all{tree{}};  // the single node
    std::vector<std::vector<int>> by_order(max_order + 1);
    by_order[1] = {0};
    for (int n = 2; n <= max_order; ++n) {
        // multisets of subtrees (indices non-decreasing) whose orders sum to n - 1
        std::vector<int> chosen;
        std::function<void(int, int)> extend = [&](int remaining, int min_index) {
            if (remaining == 0) {
                tree t;
                t.order = n;
                t.children = chosen;
                t.gamma = n;
                for (int c : chosen) t.gamma *= all[std::size_t(c)].gamma;
                by_order[std::size_t(n)].push_back(int(all.size()));
                all.push_back(t);
                return;
            }
            for (int idx = min_index; idx < int(all.size()); ++idx) {
                if (all[std::size_t(idx)].order > remaining) continue;
                chosen.push_back(idx);
                extend(remaining - all[std::size_t(idx)].order, idx);
                chosen.pop_back();
            }
        };
        const std::size_t before = all.size();
        extend(n - 1, 0);
        // trees of order n must only use subtrees of lower order: they were all created before this pass
        for (std::size_t i = before; i < all.size(); ++i)
            for (int c : all[i].children) EXPECT_LT(std::size_t(c), before);
    }
    return all;
}

/// The residual sum b Phi(t) - 1/gamma(t) of each tree and a bound on its rounding.
template <std::size_t S>
struct condition_check {
    std::vector<double> residual, magnitude;
    std::vector<int> order;
};

template <std::size_t S>
condition_check<S> check(const eci::embedded_tableau<S>& T, const std::array<double, S>& b,
                         const std::vector<tree>& trees) {
    std::vector<std::array<double, S>> phi(trees.size()), phi_abs(trees.size());
    condition_check<S> out;
    for (std::size_t t = 0; t < trees.size(); ++t) {
        for (std::size_t i = 0; i < S; ++i) {
            double p = 1.0, pa = 1.0;
            for (int c : trees[t].children) {
                double s = 0.0, sa = 0.0;
                for (std::size_t j = 0; j < i; ++j) {
                    s += T.a[i][j] * phi[std::size_t(c)][j];
                    sa += std::abs(T.a[i][j]) * phi_abs[std::size_t(c)][j];
                }
                p *= s;
                pa *= sa;
            }
            phi[t][i] = p;
            phi_abs[t][i] = pa;
        }
        double s = 0.0, sa = 0.0;
        for (std::size_t i = 0; i < S; ++i) s += b[i] * phi[t][i], sa += std::abs(b[i]) * phi_abs[t][i];
        out.residual.push_back(s - 1.0 / trees[t].gamma);
        out.magnitude.push_back(sa + 1.0 / trees[t].gamma);
        out.order.push_back(trees[t].order);
    }
    return out;
}

// The coefficients are rounded to double, and each Phi is at most 8 levels of sums and products: the residual of
// a satisfied condition is a few dozen roundings of the terms' magnitudes. A violated one is far above that.
constexpr double roundings = 64.0;

template <std::size_t S>
void expect_exact_order(const eci::embedded_tableau<S>& T, const std::array<double, S>& b, int p,
                        const std::string& what) {
    const auto trees = rooted_trees(p + 1);
    const auto r = check(T, b, trees);
    bool violated_above = false;
    for (std::size_t t = 0; t < trees.size(); ++t) {
        const double tol = roundings * eps * r.magnitude[t];
        if (r.order[t] <= p)
            EXPECT_LE(std::abs(r.residual[t]), tol) << what << ": tree " << t << " of order " << r.order[t];
        else if (std::abs(r.residual[t]) > 1e6 * tol)
            violated_above = true;
    }
    EXPECT_TRUE(violated_above) << what << " also has order " << p + 1 << ": its declared order is not exact";
}

template <std::size_t S>
void expect_pair(const eci::embedded_tableau<S>& T, const std::string& name) {
    // Row sums: c_i = sum_j a_ij, the stages' times (so that a non-autonomous f sees the right t).
    for (std::size_t i = 0; i < S; ++i) {
        double s = 0.0, sa = 0.0;
        for (std::size_t j = 0; j < i; ++j) s += T.a[i][j], sa += std::abs(T.a[i][j]);
        EXPECT_LE(std::abs(s - T.c[i]), 8.0 * eps * (sa + 1.0)) << name << " row " << i;
        for (std::size_t j = i; j < S; ++j) EXPECT_EQ(T.a[i][j], 0.0) << name << ": not explicit at " << i << j;
    }
    expect_exact_order(T, T.b, T.order, name + " b");
    expect_exact_order(T, T.bhat, T.embedded_order, name + " bhat");
}

TEST(EmbeddedTableaus, TreeCountsAreTheKnownOnes) {
    // 1, 1, 2, 4, 9, 20, 48, 115, 286 rooted trees of orders 1..9 (OEIS A000081)
    const auto trees = rooted_trees(9);
    std::array<int, 10> count{};
    for (const tree& t : trees) ++count[std::size_t(t.order)];
    EXPECT_EQ(count, (std::array<int, 10>{0, 1, 1, 2, 4, 9, 20, 48, 115, 286}));
}

TEST(EmbeddedTableaus, BogackiShampine32) { expect_pair(eci::tableaus::bogacki_shampine_32, "BS32"); }
TEST(EmbeddedTableaus, CashKarp54) { expect_pair(eci::tableaus::cash_karp_54, "CK54"); }
TEST(EmbeddedTableaus, DormandPrince54) { expect_pair(eci::tableaus::dormand_prince_54, "DP54"); }
TEST(EmbeddedTableaus, Fehlberg78) { expect_pair(eci::tableaus::fehlberg_78, "F78"); }
TEST(EmbeddedTableaus, DormandPrince853) {
    const auto& T = eci::tableaus::dormand_prince_853;
    expect_pair(T, "DP853");  // b of order 8, bhat of order 5
    expect_exact_order(T, T.bhat_low, T.low_order, "DP853 bhat_low");
    EXPECT_EQ(T.order, 8);
    EXPECT_EQ(T.embedded_order, 5);
    EXPECT_EQ(T.low_order, 3);
}

TEST(EmbeddedTableaus, FsalIsDetectedFromTheCoefficients) {
    EXPECT_TRUE(eci::is_fsal(eci::tableaus::bogacki_shampine_32));
    EXPECT_TRUE(eci::is_fsal(eci::tableaus::dormand_prince_54));
    EXPECT_TRUE(eci::is_fsal(eci::tableaus::dormand_prince_853));
    EXPECT_FALSE(eci::is_fsal(eci::tableaus::cash_karp_54));
    EXPECT_FALSE(eci::is_fsal(eci::tableaus::fehlberg_78));
}

// The continuous extension of DP54 written as y0 + h sum_i beta_i(theta) k_i: beta_i(theta) satisfies every order
// condition up to order 4 with theta^|t| / gamma(t) on the right, at any theta; and beta(1) = b (continuity).
TEST(EmbeddedTableaus, DormandPrinceContinuousExtensionIsFourthOrder) {
    const auto& T = eci::tableaus::dormand_prince_54;
    const auto trees = rooted_trees(5);
    bool fifth_violated = false;
    for (double theta : {0.2, 0.5, 0.7, 1.0}) {
        // y(theta) - y0 = theta (D + (1 - theta)(h k1 - D + theta (2 D - h k1 - h k7 + (1 - theta) h sum d k)))
        // with D = h sum b k: collect the weight of each k_i.
        std::array<double, 7> beta{};
        const double c_d = theta * (1.0 - (1.0 - theta) + (1.0 - theta) * theta * 2.0);
        for (std::size_t i = 0; i < 7; ++i) beta[i] = c_d * T.b[i] + theta * (1.0 - theta) * theta * (1.0 - theta) * T.d[0][i];
        beta[0] += theta * (1.0 - theta) * (1.0 - theta);
        beta[6] -= theta * (1.0 - theta) * theta;
        // scale the order conditions: sum beta Phi(t) = theta^|t| / gamma(t)  <=>  sum (beta / theta) Phi = ...
        const auto r = check(static_cast<const eci::embedded_tableau<7>&>(T), beta, trees);
        for (std::size_t t = 0; t < trees.size(); ++t) {
            const double target = std::pow(theta, trees[t].order) / trees[t].gamma;
            const double residual = r.residual[t] + 1.0 / trees[t].gamma - target;
            if (trees[t].order <= 4)
                EXPECT_LE(std::abs(residual), roundings * eps * r.magnitude[t]) << "theta " << theta << " tree " << t;
            else if (theta < 1.0 && std::abs(residual) > 1e-6)
                fifth_violated = true;
        }
        if (theta == 1.0) {
            for (std::size_t i = 0; i < 7; ++i) EXPECT_NEAR(beta[i], T.b[i], 4.0 * eps) << "continuity at stage " << i;
        }
    }
    EXPECT_TRUE(fifth_violated) << "a fourth-order extension cannot be fifth order inside the step";
}

// DP853's continuous extension over its 13 stages and 3 extra ones (one tableau of 16 stages), written as
// y0 + h sum_i beta_i(theta) k_i from y0 + theta (F0 + (1 - theta)(F1 + theta (F2 + (1 - theta)(F3 + theta (F4 +
// (1 - theta)(F5 + theta F6)))))), F0 = D = h sum b k, F1 = h k_1 - D, F2 = 2 D - h (k_1 + k_13), F_{3+r} = h sum
// d[r] k: every order condition up to order 7 holds with theta^|t| / gamma(t) at any theta, some of order 8
// does not inside the step, and beta(1) = b (continuity).
TEST(EmbeddedTableaus, DormandPrince853ContinuousExtensionIsSeventhOrder) {
    const auto& T = eci::tableaus::dormand_prince_853;
    constexpr std::size_t S = 13, N = 16;
    eci::embedded_tableau<N> X{};
    for (std::size_t i = 0; i < S; ++i) {
        for (std::size_t j = 0; j < S; ++j) X.a[i][j] = T.a[i][j];
        X.c[i] = T.c[i];
    }
    for (std::size_t e = 0; e < 3; ++e) {
        for (std::size_t j = 0; j < N; ++j) X.a[S + e][j] = T.a_extra[e][j];
        X.c[S + e] = T.c_extra[e];
        double sum = 0.0, magnitude = 0.0;  // the extra stages' times are their rows' sums, as for the others
        for (std::size_t j = 0; j < N; ++j) sum += T.a_extra[e][j], magnitude += std::abs(T.a_extra[e][j]);
        EXPECT_LE(std::abs(sum - T.c_extra[e]), 8.0 * eps * (magnitude + 1.0)) << "extra stage " << e;
    }
    const auto trees = rooted_trees(8);
    bool eighth_violated = false;
    for (double theta : {0.2, 0.5, 0.7, 1.0}) {
        const double u = 1.0 - theta;
        // the factor in front of each F: theta, theta u, theta^2 u, theta^2 u^2, theta^3 u^2, theta^3 u^3, ...
        std::array<double, 7> p{};
        p[0] = theta;
        for (std::size_t m = 1; m < 7; ++m) p[m] = p[m - 1] * (m % 2 == 1 ? u : theta);
        std::array<double, N> beta{};
        for (std::size_t i = 0; i < S; ++i) beta[i] = (p[0] - p[1] + 2.0 * p[2]) * T.b[i];
        beta[0] += p[1] - p[2];
        beta[S - 1] -= p[2];
        for (std::size_t r = 0; r < 4; ++r)
            for (std::size_t i = 0; i < N; ++i) beta[i] += p[3 + r] * T.d[r][i];
        const auto res = check(X, beta, trees);
        for (std::size_t t = 0; t < trees.size(); ++t) {
            const double target = std::pow(theta, trees[t].order) / trees[t].gamma;
            const double residual = res.residual[t] + 1.0 / trees[t].gamma - target;
            if (trees[t].order <= 7)
                EXPECT_LE(std::abs(residual), roundings * eps * res.magnitude[t]) << "theta " << theta << " tree " << t;
            else if (theta < 1.0 && std::abs(residual) > 1e-6)
                eighth_violated = true;
        }
        if (theta == 1.0) {
            for (std::size_t i = 0; i < S; ++i) EXPECT_NEAR(beta[i], T.b[i], 4.0 * eps) << "continuity at stage " << i;
            for (std::size_t i = S; i < N; ++i) EXPECT_EQ(beta[i], 0.0) << "continuity at extra stage " << i;
        }
    }
    EXPECT_TRUE(eighth_violated) << "a seventh-order extension cannot be eighth order inside the step";
}

}  // namespace

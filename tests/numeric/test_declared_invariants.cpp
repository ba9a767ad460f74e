// Invariants declared by the model itself: a model that gives the weights of its quadratic invariants gets
// relaxation and projection, which keep them; a model that declares none is refused them with the reason; every
// model of the list declares its invariants, and the declared sets measure what its named invariants measure.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <cstddef>
#include <ranges>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <eci/eci.hpp>
#include <eci/models/list.hpp>

#include "numeric/support.hpp"
#include "unit/solve_tests.hpp"

namespace {

using eci::test::eps;

// A triad with wavenumbers k^2 = 1, 2, 3 and M = (k_P^2 - k_Q^2, k_Q^2 - k_K^2, k_K^2 - k_P^2) = (-1, 2, -1):
// sum M = 0 and sum k^2 M = 0 (eqs. (2)-(3)), so E = sum psi^2 and Z = sum k^2 psi^2 are invariant.
struct triad_rhs {
    using state_type = std::array<double, 3>;
    void operator()(const state_type& x, state_type& d, double) const {
        d[0] = -1.0 * x[1] * x[2];
        d[1] = 2.0 * x[2] * x[0];
        d[2] = -1.0 * x[0] * x[1];
    }
    double energy(const state_type& x) const { return x[0] * x[0] + x[1] * x[1] + x[2] * x[2]; }
    double enstrophy(const state_type& x) const {
        return x[0] * x[0] + 2.0 * (x[1] * x[1]) + 3.0 * (x[2] * x[2]);
    }
};

// The triad declaring its invariants by their weights only: no invariant set, no transform, no table elsewhere.
struct weighted_triad : triad_rhs {
    static constexpr auto invariants() {
        return std::array<eci::named_invariant<weighted_triad>, 2>{
            {{"energy", &weighted_triad::energy}, {"enstrophy", &weighted_triad::enstrophy}}};
    }
    double quadratic_invariant_weight(std::size_t j, std::size_t k) const { return j == 0 ? 1.0 : double(k + 1); }
};

// The same triad declaring nothing for relaxation and projection (its named invariants are only measured).
struct undeclared_triad : triad_rhs {
    static constexpr auto invariants() {
        return std::array<eci::named_invariant<undeclared_triad>, 2>{
            {{"energy", &undeclared_triad::energy}, {"enstrophy", &undeclared_triad::enstrophy}}};
    }
};

constexpr std::array<double, 3> triad_x0{1.0, 0.5, -0.8};

bool offers(const std::vector<eci::method_info>& methods, std::string_view name) {
    for (const auto& m : methods)
        if (m.name == name) return true;
    return false;
}

bool keeps_invariants(const eci::method_info& m) {
    return m.family == eci::method_family::relaxation || m.family == eci::method_family::projection;
}

TEST(DeclaredInvariants, QuadraticWeightsAloneGiveRelaxationAndProjectionThatKeepThem) {
    static_assert(eci::declares_quadratic_weights<weighted_triad>);
    static_assert(eci::independent_invariant_count<weighted_triad> == 2);
    const auto methods = eci::methods_for<weighted_triad>();
    for (const char* name : {"rrk-rk4", "idt-rk4", "mrrk-rk4", "projected-rk4", "rrk-bs32", "rrk-dp54", "mrrk-bs32",
                             "mrrk-dp54", "projected-dp54"})
        EXPECT_TRUE(offers(methods, name)) << name;
    // The weights are the model's one declaration: the set they define is its named invariants, with the
    // gradient 2 w_jk x_k and the bilinear form sum_k w_jk a_k b_k.
    const weighted_triad model;
    const auto set = eci::invariants_of(model);
    static_assert(eci::quadratic_invariant_set<decltype(set), weighted_triad::state_type>);
    EXPECT_EQ(set.count(), 2u);
    EXPECT_EQ(set.value(triad_x0, 0), model.energy(triad_x0));
    EXPECT_EQ(set.value(triad_x0, 1), model.enstrophy(triad_x0));
    weighted_triad::state_type g{};
    set.gradient(triad_x0, 1, g);
    EXPECT_EQ(g, (weighted_triad::state_type{2.0 * triad_x0[0], 4.0 * triad_x0[1], 6.0 * triad_x0[2]}));
    EXPECT_EQ(eci::quadratic_weights_of(model, 3), (eci::quadratic_weights{{1.0, 1.0, 1.0}, {1.0, 2.0, 3.0}}));

    // Each such method keeps what it promises over 10^3 steps: relaxation on one invariant keeps the first,
    // multiple relaxation and projection (conservative) keep both. Each step adds a few roundings of the
    // invariant's size, which add up as a random walk: 16 eps sqrt(steps) relative.
    constexpr double steps = 1000.0;
    const double bound = 16.0 * eps * std::sqrt(steps);
    int ran = 0;
    for (const auto& m : methods) {
        if (!keeps_invariants(m)) continue;
        eci::run_config cfg;
        cfg.t_end = 10.0;
        cfg.dt = 10.0 / steps;
        auto x = triad_x0;
        const eci::solve_report r = eci::solve<weighted_triad>(model, x, m.name, cfg, eci::no_sink{});
        ASSERT_TRUE(r.completed()) << m.name;
        ASSERT_EQ(r.invariants.size(), 2u);
        EXPECT_LE(r.invariants[0].max_rel_drift(), bound) << m.name;
        if (m.conservative) {
            EXPECT_LE(r.invariants[1].max_rel_drift(), bound) << m.name;
        }
        ++ran;
    }
    EXPECT_EQ(ran, 9);
}

TEST(DeclaredInvariants, AModelThatDeclaresNoneIsRefusedThemWithTheReason) {
    static_assert(!eci::declares_invariants<undeclared_triad>);
    static_assert(eci::independent_invariant_count<undeclared_triad> == 0);
    const auto methods = eci::methods_for<undeclared_triad>();
    EXPECT_TRUE(offers(methods, "c-rk4"));  // its invariants are quadratic: the conservative engine runs on it
    for (const auto& m : methods) EXPECT_FALSE(keeps_invariants(m)) << m.name;
    auto refusal = [](const char* method, auto model) -> std::string {
        using M = decltype(model);
        typename M::state_type x{1.0, 0.5, -0.8};
        eci::run_config cfg;
        cfg.t_end = 1.0;
        cfg.dt = 0.1;
        try {
            eci::solve<M>(model, x, method, cfg, eci::no_sink{}, {}, "model triad");
        } catch (const std::invalid_argument& e) {
            return e.what();
        }
        return "accepted";
    };
    const std::string reason = "relaxation and projection keep the invariants a model declares, and it declares none";
    for (const char* method : {"rrk-rk4", "mrrk-dp54", "projected-rk4"})
        EXPECT_EQ(refusal(method, undeclared_triad{}).rfind(std::string("method '") + method +
                                                                "' is not available for model triad: " + reason +
                                                                " (available: euler, ",
                                                            0),
                  0u)
            << refusal(method, undeclared_triad{});
    // Methods refused for another reason keep the message they had: Kahan needs a Jacobian.
    EXPECT_EQ(refusal("kahan", undeclared_triad{}).rfind("method 'kahan' is not available for model triad (available: ", 0),
              0u);
    EXPECT_EQ(refusal("rrk-rk4", weighted_triad{}), "accepted");
    // Multiple relaxation keeps two independent invariants: on a model that declares one, refused with that reason.
    for (const char* method : {"mrrk-rk4", "mrrk-dp54"}) {
        eci::nonlinear_oscillator m;
        eci::nonlinear_oscillator::state_type x{1.0, 0.2};
        eci::run_config cfg;
        cfg.t_end = 1.0;
        cfg.dt = 0.1;
        std::string what = "accepted";
        try {
            solve_tests::discard<eci::nonlinear_oscillator::state_type> none;  // (the compiled runs, src/models)
            eci::solve_model<eci::nonlinear_oscillator>(m, x, method, cfg, none, {}, "model nonlinear-oscillator");
        } catch (const std::invalid_argument& e) {
            what = e.what();
        }
        EXPECT_EQ(what.rfind(std::string("method '") + method + "' is not available for model nonlinear-oscillator: "
                             "multiple relaxation keeps two independent invariants, and this model declares one",
                             0),
                  0u)
            << what;
    }
    // Kepler reports three invariants (H and the Runge-Lenz vector), one of them independent: said so ("declares one"
    // read as a contradiction of its summary's three)
    {
        const auto preset = eci::kepler::presets().front();
        eci::kepler m = preset.model;
        eci::kepler::state_type x = preset.x0;
        eci::run_config cfg;
        cfg.t_end = 1.0;
        cfg.dt = 0.1;
        std::string what = "accepted";
        try {
            solve_tests::discard<eci::kepler::state_type> none;
            eci::solve_model<eci::kepler>(m, x, "mrrk-rk4", cfg, none, {}, "model kepler");
        } catch (const std::invalid_argument& e) {
            what = e.what();
        }
        EXPECT_EQ(what.rfind("method 'mrrk-rk4' is not available for model kepler: multiple relaxation keeps two "
                             "independent invariants, and of the invariants this model declares one is independent (",
                             0),
                  0u)
            << what;
    }
}

// Central differences with h = eps^(1/3) |x|-scaled: error O(h^2) + O(eps / h) ~ eps^(2/3) ~ 4e-11 relative to the
// invariant's scale; 1e-8 leaves room for third derivatives of order 100 (Kepler near pericentre).
template <class Set, class S>
void expect_gradients(const Set& set, const S& x, std::string_view model) {
    for (std::size_t i = 0; i < set.count(); ++i) {
        S g = x;
        set.gradient(x, i, g);
        const auto gr = eci::reals(std::as_const(g));
        for (std::size_t j = 0; j < gr.size(); ++j) {
            S a = x, b = x;
            const double h = std::cbrt(eps) * std::max(1.0, std::abs(eci::reals(x)[j]));
            eci::reals(a)[j] += h;
            eci::reals(b)[j] -= h;
            const double fd = (set.value(a, i) - set.value(b, i)) / (2.0 * h);
            EXPECT_NEAR(gr[j], fd, 1e-8 * std::max(1.0, std::abs(fd))) << model << " invariant " << i << ", unknown " << j;
        }
    }
}

// A model of the list and a state of it: a small random n-wave system, else the first preset.
template <class M>
std::pair<M, typename M::state_type> example_of() {
    if constexpr (requires { M::random(9, 2, 7); }) {
        M m = M::random(9, 2, 7);
        auto x = m.random_state(3);
        return {std::move(m), std::move(x)};
    } else {
        const auto p = M::presets()[0];
        return {p.model, p.x0};
    }
}

TEST(DeclaredInvariants, EveryModelOfTheListDeclaresItsInvariantsAndTheyAreItsNamedOnes) {
    eci::for_each_ode_model([]<class M>() {
        static_assert(eci::declares_invariants<M>);
        static_assert(eci::independent_invariant_count<M> >= 1);
        const auto [model, x] = example_of<M>();
        const auto set = eci::invariants_of(model);
        constexpr auto named = M::invariants();
        ASSERT_EQ(set.count(), named.size()) << M::name;
        // A quadratic model's set sums the same n terms w_k |x_k|^2 as its named invariant, in another
        // association: each is within (n - 1) eps of the exact sum of nonnegative terms (Higham, recursive
        // summation), the products add one rounding each. Non-quadratic sets call the named functions: equal.
        const double n = double(std::ranges::size(x));
        for (std::size_t j = 0; j < named.size(); ++j) {
            const double v = (model.*named[j].value)(x);
            EXPECT_NEAR(set.value(x, j), v, 2.0 * (n + 1.0) * eps * std::abs(v)) << M::name << " " << named[j].name;
        }
        expect_gradients(set, x, M::name);
        EXPECT_TRUE(offers(eci::methods_for<M>(), "rrk-rk4")) << M::name;
        EXPECT_TRUE(offers(eci::methods_for<M>(), "projected-rk4")) << M::name;
        EXPECT_EQ(offers(eci::methods_for<M>(), "mrrk-rk4"), eci::independent_invariant_count<M> == 2) << M::name;
    });
}

}  // namespace

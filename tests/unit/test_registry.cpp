// Unit tests of the registry: which methods each model supports is computed from what it offers, the stepper
// behind each name is the right engine, steppers read the model they step, and docs/methods.md matches the list.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include <eci/eci.hpp>
#include <eci/models/kepler.hpp>
#include <eci/models/list.hpp>
#include <eci/models/lotka_volterra.hpp>
#include <eci/models/n_wave.hpp>
#include <eci/models/three_wave.hpp>

namespace {

constexpr double eps = std::numeric_limits<double>::epsilon();

std::vector<std::string> names_of(const std::vector<eci::method_info>& methods) {
    std::vector<std::string> out;
    for (const eci::method_info& m : methods) out.emplace_back(m.name);
    return out;
}

using strings = std::vector<std::string>;

// The family of the method called `name` among `methods` (by name: a method added to the list moves the others).
eci::method_family family_of(const std::vector<eci::method_info>& methods, std::string_view name) {
    for (const eci::method_info& m : methods)
        if (m.name == name) return m.family;
    ADD_FAILURE() << name << " is not offered";
    return eci::method_family::conventional;
}

}  // namespace

// The lists the CLI adapters used to type by hand, now computed; Kepler gains implicit-midpoint (the
// bench ran it, `eci run kepler --method implicit-midpoint` refused it).
TEST(Registry, MethodsPerModelAreComputedFromWhatTheModelOffers) {
    EXPECT_EQ(names_of(eci::methods_for<eci::three_wave>()),
              (strings{"euler", "pc", "rk2", "rk4", "c-euler", "c-pc", "c-rk2", "c-rk4", "c-pc-compensated",
                       "implicit-midpoint", "bs32", "c-bs32", "ck54", "c-ck54", "dp54", "c-dp54", "dp853", "c-dp853", "f78", "c-f78",
                       "rrk-rk4", "idt-rk4", "mrrk-rk4", "projected-rk4", "rrk-bs32", "rrk-dp54", "mrrk-bs32", "mrrk-dp54",
                       "projected-dp54"}));
    EXPECT_EQ(names_of(eci::methods_for<eci::n_wave<std::complex<double>>>()),
              names_of(eci::methods_for<eci::three_wave>()));
    EXPECT_EQ(names_of(eci::methods_for<eci::lotka_volterra>()),
              (strings{"euler", "pc", "rk2", "rk4", "c-pc", "c-rk2", "c-rk4", "implicit-midpoint", "kahan", "bs32", "c-bs32", "ck54", "c-ck54", "dp54", "c-dp54", "dp853", "c-dp853", "f78", "c-f78",
                       "rrk-rk4", "idt-rk4", "projected-rk4", "rrk-bs32", "rrk-dp54", "projected-dp54"}));
    EXPECT_EQ(names_of(eci::methods_for<eci::kepler>()),
              (strings{"euler", "pc", "rk2", "rk4", "c-pc", "c-rk2", "c-rk4", "implicit-midpoint", "bs32", "c-bs32", "ck54", "c-ck54", "dp54", "c-dp54", "dp853", "c-dp853", "f78", "c-f78",
                       "rrk-rk4", "idt-rk4", "projected-rk4", "rrk-bs32", "rrk-dp54", "projected-dp54"}));
    // Each with its family on the model: the transform is used on Kepler, the psi^2 engine on three-wave.
    EXPECT_EQ(family_of(eci::methods_for<eci::kepler>(), "c-pc"), eci::method_family::transformed);
    EXPECT_EQ(family_of(eci::methods_for<eci::three_wave>(), "c-pc"), eci::method_family::conservative);
    // Multiple relaxation where there are two independent invariants, symplectic methods on a separable
    // Hamiltonian, and no C-RK on Kepler in Cartesian variables (H is not a sum of squares there).
    EXPECT_EQ(names_of(eci::methods_for<eci::kepler_cartesian>()),
              (strings{"euler", "pc", "rk2", "rk4", "implicit-midpoint", "bs32", "ck54", "dp54", "dp853", "f78", "rrk-rk4",
                       "idt-rk4", "mrrk-rk4", "projected-rk4", "rrk-bs32", "rrk-dp54", "mrrk-bs32", "mrrk-dp54",
                       "projected-dp54", "stormer-verlet", "sb3a"}));
    EXPECT_EQ(names_of(eci::methods_for<eci::rigid_body>()), names_of(eci::methods_for<eci::three_wave>()));
    // A plain system on a state type: every method but the model-specific one and the eleven that need the
    // model's invariants or a separable Hamiltonian.
    EXPECT_EQ(eci::methods_for<std::vector<double>>().size(), eci::methods.size() - 12);
}

// The engine behind a name depends on the model: the transform where it has one, the fused psi^2 path otherwise.
TEST(Registry, PicksTheEngineFromTheModel) {
    namespace m = eci::method_entries;
    using tw = eci::three_wave::state_type;
    static_assert(std::same_as<eci::stepper_for<m::c_pc, eci::three_wave>, eci::c_pc<tw>>);
    static_assert(std::same_as<eci::stepper_for<m::c_pc, eci::kepler>, eci::transformed_pc<eci::kepler::transform>>);
    static_assert(std::same_as<eci::stepper_for<m::c_rk4, eci::lotka_volterra>,
                               eci::transformed_rk4<eci::lotka_volterra::transform>>);
    static_assert(std::same_as<eci::stepper_for<m::kahan, eci::lotka_volterra>,
                               eci::kahan<eci::lotka_volterra::state_type>>);
    static_assert(!eci::runs_on<m::c_euler, eci::kepler>);  // psi^2 is not Kepler's invariant
    static_assert(eci::family_on<m::c_pc, eci::kepler>() == eci::method_family::transformed);
    static_assert(eci::family_on<m::c_pc, eci::three_wave>() == eci::method_family::conservative);
    EXPECT_EQ(eci::identifier("c-pc-compensated"), "c_pc_compensated");
}

// with_stepper hands over a working stepper: implicit-midpoint on Kepler keeps H (a quadratic-invariant method
// on a non-quadratic H: not to round-off, but to O(dt^2) without secular growth), and unknown names are refused.
TEST(Registry, WithStepperRunsWhatTheModelSupports) {
    const eci::kepler model;
    eci::kepler::state_type x{1.0, 0.0, 0.0};
    bool ran = false;
    ASSERT_TRUE(eci::with_stepper("implicit-midpoint", model, [&](auto stepper) {
        eci::integrate_n_steps(stepper, model, x, 0.0, 0.01, 1000);
        ran = true;
    }));
    EXPECT_TRUE(ran);
    // Its error in H is O(dt^2) = 1e-4 times the orbit's scale: well below 1e-3 of |H|.
    EXPECT_NEAR(model.hamiltonian(x), model.hamiltonian({1.0, 0.0, 0.0}), 1e-3);
    EXPECT_FALSE(eci::with_stepper("c-euler", model, [](auto) {}));
    EXPECT_FALSE(eci::with_stepper<eci::kepler>("rk5", [](auto) {}));
}

// A transformed stepper takes its transform from the model it steps: the same stepper object keeps the
// Hamiltonian of two Lotka-Volterra systems with different mu (a stored transform would keep only one of them).
TEST(Registry, TransformComesFromTheSteppedModel) {
    eci::transformed_pc<eci::lotka_volterra::transform> st;
    for (const double mu : {1.5, 0.7}) {
        const eci::lotka_volterra model{mu};
        eci::lotka_volterra::state_type x{1.0, 0.4};
        const double h0 = model.hamiltonian(x);
        const std::uint64_t n = 5000;
        eci::integrate_n_steps(st, model, x, 0.0, 0.02, n);
        // A random walk of a few roundings of H per step (see numeric/test_lotka_volterra.cpp).
        EXPECT_NEAR(model.hamiltonian(x), h0, 4.0 * eps * h0 * std::sqrt(double(n))) << "mu " << mu;
    }
}

// docs/methods.md's table has one row per registered method, in list order, with its family, order and whether
// it conserves: the docs cannot drift from the registry.
TEST(Registry, MethodsDocTableMatchesTheRegistry) {
    std::ifstream in(ECI_SOURCE_DIR "/docs/methods.md");
    ASSERT_TRUE(in) << "cannot read docs/methods.md";
    std::vector<std::vector<std::string>> rows;
    bool in_table = false;
    for (std::string line; std::getline(in, line);) {
        if (line.starts_with("| name | family | order |")) {
            in_table = true;
            continue;
        }
        if (!in_table) continue;
        if (!line.starts_with("|")) break;
        if (line.starts_with("|--")) continue;
        std::vector<std::string> cells;
        std::stringstream ss(line.substr(1));
        for (std::string cell; std::getline(ss, cell, '|');) {
            const auto a = cell.find_first_not_of(' '), b = cell.find_last_not_of(' ');
            cells.push_back(a == std::string::npos ? "" : cell.substr(a, b - a + 1));
        }
        rows.push_back(cells);
    }
    ASSERT_EQ(rows.size(), eci::methods.size()) << "one table row per registered method";
    for (std::size_t i = 0; i < rows.size(); ++i) {
        const eci::method_info& m = eci::methods[i];
        ASSERT_GE(rows[i].size(), 6u);
        const std::string& name = rows[i][0];  // `name`, with the backticks
        EXPECT_TRUE(name.size() > 2 && name.front() == '`' && name.back() == '`') << name;
        EXPECT_EQ(std::string_view(name).substr(1, name.size() - 2), m.name);
        EXPECT_EQ(rows[i][1], std::string(eci::family_name(m.family))) << m.name;
        EXPECT_EQ(rows[i][2], std::to_string(m.order)) << m.name;
        EXPECT_EQ(rows[i][5].starts_with("yes"), m.conservative) << m.name;
    }
}

// The one list of eci's methods, as data: name, family, tableau, order, one line. From what a model offers
// (a linearizing transform, a Jacobian, quadratic invariants) it computes the stepper behind each name.
#pragma once

#include <array>
#include <concepts>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "concepts.hpp"
#include "invariants.hpp"
#include "steppers/compensated_c_pc.hpp"
#include "steppers/conservative_euler.hpp"
#include "steppers/conservative_rk.hpp"
#include "steppers/explicit_rk.hpp"
#include "steppers/implicit_midpoint.hpp"
#include "steppers/kahan.hpp"
#include "steppers/projection.hpp"
#include "steppers/relaxation_rk.hpp"
#include "steppers/symplectic.hpp"
#include "steppers/transformed_rk.hpp"
#include "tableaus.hpp"

namespace eci {

/// How a method is built. A conventional or conservative method is a tableau run by an engine: explicit_rk
/// (conventional); conservative_rk on a model with quadratic invariants, transformed_rk on a model with a
/// linearizing transform (reported as `transformed`). Implicit and model-specific methods name their stepper.
/// Relaxation, projection and symplectic methods keep invariants given as functions of the state, or
/// a separable Hamiltonian's structure, instead.
enum class method_family {
    conventional,
    conservative,
    transformed,
    implicit,
    model_specific,
    relaxation,
    projection,
    symplectic
};

/// The family's name as `eci list` prints it.
constexpr std::string_view family_name(method_family f) {
    switch (f) {
        case method_family::conventional: return "conventional";
        case method_family::conservative: return "conservative";
        case method_family::transformed: return "transformed";
        case method_family::implicit: return "implicit";
        case method_family::model_specific: return "model-specific";
        case method_family::relaxation: return "relaxation";
        case method_family::projection: return "projection";
        case method_family::symplectic: return "symplectic";
    }
    return "?";
}

/// What the registry knows about a method.
struct method_info {
    std::string_view name;         ///< the name the CLI and the docs use; C++ and bench labels write '-' as '_'
    method_family family;          ///< how it is built
    int order;                     ///< global order of accuracy
    bool conservative;             ///< conserves every quadratic invariant of eqs. (2)-(3) to round-off
    std::string_view description;  ///< one line
};

/// A method's name as a C++ identifier and bench label: '-' written '_' (c-pc-compensated -> c_pc_compensated,
/// the name of its stepper type eci::c_pc_compensated and of its entry method_entries::c_pc_compensated).
inline std::string identifier(std::string_view name) {
    std::string s(name);
    for (char& c : s) c = c == '-' ? '_' : c;
    return s;
}

/// The registry's entries, one struct per method, named like its C++ stepper. A tableau method gives `tableau`
/// (and `sign`, whose sign the conservative update takes; the update's by default). Any other method gives its
/// stepper for a model, `stepper<Model>`, and the models it runs on, `runs_on<Model>`.
namespace method_entries {

/// Forward Euler.
struct euler {
    static constexpr method_info info{"euler", method_family::conventional, 1, false, "forward Euler, eq. (7)"};
    static constexpr const auto& tableau = tableaus::euler;
};
/// Heun's predictor-corrector.
struct pc {
    static constexpr method_info info{"pc", method_family::conventional, 2, false,
                                      "predictor-corrector (Heun), eq. (18)"};
    static constexpr const auto& tableau = tableaus::heun;
};
/// Explicit midpoint rule.
struct rk2 {
    static constexpr method_info info{"rk2", method_family::conventional, 2, false,
                                      "second-order Runge-Kutta (explicit midpoint rule)"};
    static constexpr const auto& tableau = tableaus::midpoint;
};
/// Classical Runge-Kutta.
struct rk4 {
    static constexpr method_info info{"rk4", method_family::conventional, 4, false,
                                      "classical fourth-order Runge-Kutta"};
    static constexpr const auto& tableau = tableaus::rk4;
};
/// Conservative Euler (its own engine: an implicit midpoint step near a zero mode).
struct c_euler {
    static constexpr method_info info{"c-euler", method_family::conservative, 1, true,
                                      "conservative Euler, eq. (16), implicit midpoint step near a zero mode"};
    template <class M> using stepper = eci::c_euler<typename M::state_type>;
    template <class M> static constexpr bool runs_on = quadratic_invariants<M>;
};
/// Conservative predictor-corrector: Heun's tableau, the predictor's sign (on quadratic invariants the fused path).
struct c_pc {
    static constexpr method_info info{"c-pc", method_family::conservative, 2, true,
                                      "conservative predictor-corrector, eq. (30)"};
    static constexpr const auto& tableau = tableaus::heun;
    static constexpr sign_rule sign = sign_rule::of_last_stage;
};
/// Conservative midpoint rule.
struct c_rk2 {
    static constexpr method_info info{"c-rk2", method_family::conservative, 2, true,
                                      "conservative second-order Runge-Kutta (midpoint tableau)"};
    static constexpr const auto& tableau = tableaus::midpoint;
};
/// Conservative classical Runge-Kutta.
struct c_rk4 {
    static constexpr method_info info{"c-rk4", method_family::conservative, 4, true,
                                      "conservative fourth-order Runge-Kutta"};
    static constexpr const auto& tableau = tableaus::rk4;
};
/// C-PC that carries the rounding residual of psi^2 between steps (long runs: no sqrt(steps) random walk).
struct c_pc_compensated {
    static constexpr method_info info{"c-pc-compensated", method_family::conservative, 2, true,
                                      "C-PC with compensated psi^2 (no round-off random walk; one more buffer)"};
    template <class M> using stepper = eci::c_pc_compensated<typename M::state_type>;
    template <class M> static constexpr bool runs_on = quadratic_invariants<M>;
};
/// The implicit midpoint rule, the implicit way to conserve quadratic invariants (for comparison).
struct implicit_midpoint {
    static constexpr method_info info{"implicit-midpoint", method_family::implicit, 2, true,
                                      "implicit midpoint rule, fixed-point iteration to round-off (for comparison)"};
    template <class M> using stepper = eci::implicit_midpoint<typename M::state_type>;
    template <class M> static constexpr bool runs_on = true;
};
/// Kahan's linearly implicit method, on models with a Jacobian and a fixed-size state.
struct kahan {
    static constexpr method_info info{"kahan", method_family::model_specific, 2, false,
                                      "Kahan's linearly implicit method (quadratic fields; needs the model's Jacobian)"};
    template <class M> using stepper = eci::kahan<typename M::state_type>;
    template <class M>
    static constexpr bool runs_on = has_jacobian<M> && requires { std::tuple_size<typename M::state_type>::value; };
};

/// Bogacki-Shampine 3(2), adaptive with --rtol/--atol.
struct bs32 {
    static constexpr method_info info{"bs32", method_family::conventional, 3, false,
                                      "Bogacki-Shampine 3(2) embedded pair (adaptive with --rtol/--atol)"};
    static constexpr const auto& tableau = tableaus::bogacki_shampine_32;
};
/// Conservative Bogacki-Shampine 3(2).
struct c_bs32 {
    static constexpr method_info info{"c-bs32", method_family::conservative, 3, true,
                                      "conservative Bogacki-Shampine 3(2), xi = psi^2 error estimate, Hermite dense output"};
    static constexpr const auto& tableau = tableaus::bogacki_shampine_32;
};
/// Cash-Karp 5(4).
struct ck54 {
    static constexpr method_info info{"ck54", method_family::conventional, 5, false,
                                      "Cash-Karp 5(4) embedded pair (adaptive with --rtol/--atol)"};
    static constexpr const auto& tableau = tableaus::cash_karp_54;
};
/// Conservative Cash-Karp 5(4) (Bowman's adaptive conservative RK5).
struct c_ck54 {
    static constexpr method_info info{"c-ck54", method_family::conservative, 5, true,
                                      "conservative Cash-Karp 5(4) (adaptive with --rtol/--atol)"};
    static constexpr const auto& tableau = tableaus::cash_karp_54;
};
/// Dormand-Prince 5(4).
struct dp54 {
    static constexpr method_info info{"dp54", method_family::conventional, 5, false,
                                      "Dormand-Prince 5(4) embedded pair, FSAL, dense output (adaptive with --rtol/--atol)"};
    static constexpr const auto& tableau = tableaus::dormand_prince_54;
};
/// Conservative Dormand-Prince 5(4).
struct c_dp54 {
    static constexpr method_info info{"c-dp54", method_family::conservative, 5, true,
                                      "conservative Dormand-Prince 5(4), FSAL, invariant-exact dense output"};
    static constexpr const auto& tableau = tableaus::dormand_prince_54;
};
/// Dormand-Prince 8(5,3), SciPy's DOP853.
struct dp853 {
    static constexpr method_info info{"dp853", method_family::conventional, 8, false,
                                      "Dormand-Prince 8(5,3) embedded pair, FSAL, 7th-order dense output (SciPy's DOP853)"};
    static constexpr const auto& tableau = tableaus::dormand_prince_853;
};
/// Conservative Dormand-Prince 8(5,3).
struct c_dp853 {
    static constexpr method_info info{"c-dp853", method_family::conservative, 8, true,
                                      "conservative Dormand-Prince 8(5,3), FSAL, invariant-exact 7th-order dense output"};
    static constexpr const auto& tableau = tableaus::dormand_prince_853;
};
/// Fehlberg 7(8), propagating order 8.
struct f78 {
    static constexpr method_info info{"f78", method_family::conventional, 8, false,
                                      "Fehlberg 7(8) embedded pair, order 8 propagated (adaptive with --rtol/--atol)"};
    static constexpr const auto& tableau = tableaus::fehlberg_78;
};
/// Conservative Fehlberg 7(8).
struct c_f78 {
    static constexpr method_info info{"c-f78", method_family::conservative, 8, true,
                                      "conservative Fehlberg 7(8), order 8 (adaptive with --rtol/--atol)"};
    static constexpr const auto& tableau = tableaus::fehlberg_78;
};
/// Relaxation on tableau T's weights b, keeping the model's first invariant (what every rrk-* entry shares).
template <const auto& T>
struct relaxation_on {
    template <class M> using stepper = eci::relaxation_rk<T, typename M::state_type, first_model_invariant>;
    template <class M> static constexpr bool runs_on = independent_invariant_count<M> >= 1;
};
/// Multiple relaxation on the embedded pair T (directions b and b - bhat), keeping the model's two invariants.
template <const auto& T>
struct multiple_relaxation_on {
    template <class M> using stepper = eci::mrrk_pair<T, typename M::state_type, independent_model_invariants>;
    template <class M> static constexpr bool runs_on = independent_invariant_count<M> == 2;
};
/// Tableau T's conventional step followed by the orthogonal projection onto the model's independent invariants.
template <const auto& T>
struct projection_after {
    template <class M>
    using stepper = eci::orthogonal_projection<eci::explicit_rk<T, typename M::state_type>, typename M::state_type,
                                               independent_model_invariants>;
    template <class M> static constexpr bool runs_on = independent_invariant_count<M> >= 1;
};

/// Relaxation RK4 on the model's first invariant.
struct rrk_rk4 {
    static constexpr method_info info{"rrk-rk4", method_family::relaxation, 4, false,
                                      "relaxation RK4 keeping the model's first invariant (time advanced gamma tau)"};
    template <class M> using stepper = eci::rrk4<typename M::state_type, first_model_invariant>;
    template <class M> static constexpr bool runs_on = independent_invariant_count<M> >= 1;
};
/// RK4 with the incremental direction technique on the model's first invariant.
struct idt_rk4 {
    static constexpr method_info info{"idt-rk4", method_family::relaxation, 3, false,
                                      "RK4 relaxed by the incremental direction technique (first invariant; order 3)"};
    template <class M> using stepper = eci::idt_rk4<typename M::state_type, first_model_invariant>;
    template <class M> static constexpr bool runs_on = independent_invariant_count<M> >= 1;
};
/// Multiple relaxation RK4 (Biswas & Ketcheson) on a model with two independent invariants.
struct mrrk_rk4 {
    static constexpr method_info info{"mrrk-rk4", method_family::relaxation, 4, true,
                                      "multiple relaxation RK4 keeping two invariants (Biswas & Ketcheson 2023)"};
    template <class M> using stepper = eci::mrrk4_2<typename M::state_type, independent_model_invariants>;
    template <class M> static constexpr bool runs_on = independent_invariant_count<M> == 2;
};
/// RK4 followed by the orthogonal projection onto the model's independent invariants.
struct projected_rk4 {
    static constexpr method_info info{"projected-rk4", method_family::projection, 4, true,
                                      "RK4 + orthogonal projection onto the invariants (simplified Newton)"};
    template <class M>
    using stepper = eci::orthogonal_projection<eci::rk4<typename M::state_type>, typename M::state_type,
                                               independent_model_invariants>;
    template <class M> static constexpr bool runs_on = independent_invariant_count<M> >= 1;
};
/// Relaxation on Bogacki-Shampine 3(2)'s third-order weights.
struct rrk_bs32 : relaxation_on<tableaus::bogacki_shampine_32> {
    static constexpr method_info info{"rrk-bs32", method_family::relaxation, 3, false,
                                      "relaxation on Bogacki-Shampine 3(2) keeping the model's first invariant"};
};
/// Relaxation on Dormand-Prince 5(4)'s fifth-order weights.
struct rrk_dp54 : relaxation_on<tableaus::dormand_prince_54> {
    static constexpr method_info info{"rrk-dp54", method_family::relaxation, 5, false,
                                      "relaxation on Dormand-Prince 5(4) keeping the model's first invariant"};
};
/// Multiple relaxation on Bogacki-Shampine 3(2), directions b and b - bhat.
struct mrrk_bs32 : multiple_relaxation_on<tableaus::bogacki_shampine_32> {
    static constexpr method_info info{"mrrk-bs32", method_family::relaxation, 3, true,
                                      "multiple relaxation on Bogacki-Shampine 3(2), directions b and b - bhat"};
};
/// Multiple relaxation on Dormand-Prince 5(4), directions b and b - bhat.
struct mrrk_dp54 : multiple_relaxation_on<tableaus::dormand_prince_54> {
    static constexpr method_info info{"mrrk-dp54", method_family::relaxation, 5, true,
                                      "multiple relaxation on Dormand-Prince 5(4), directions b and b - bhat"};
};
/// Dormand-Prince 5(4) followed by the orthogonal projection.
struct projected_dp54 : projection_after<tableaus::dormand_prince_54> {
    static constexpr method_info info{"projected-dp54", method_family::projection, 5, true,
                                      "Dormand-Prince 5(4) + orthogonal projection onto the invariants"};
};
/// Stormer-Verlet on a separable Hamiltonian model.
struct stormer_verlet {
    static constexpr method_info info{"stormer-verlet", method_family::symplectic, 2, false,
                                      "Stormer-Verlet (separable Hamiltonians)"};
    template <class M>
    using stepper = eci::symplectic_splitting<splittings::stormer_verlet, typename M::state_type, drift_rule_of<M>>;
    template <class M> static constexpr bool runs_on = separable_hamiltonian<M>;
};
/// McLachlan's fourth-order SB3A on a separable Hamiltonian model.
struct sb3a {
    static constexpr method_info info{"sb3a", method_family::symplectic, 4, false,
                                      "McLachlan's symplectic SB3A, fourth order (separable Hamiltonians)"};
    template <class M>
    using stepper = eci::symplectic_splitting<splittings::mclachlan_sb3a, typename M::state_type, drift_rule_of<M>>;
    template <class M> static constexpr bool runs_on = separable_hamiltonian<M>;
};

}  // namespace method_entries

namespace detail {

/// A list of types (the registry's entries, or a selection of them).
template <class... T>
struct type_list {
    static constexpr std::size_t size = sizeof...(T);
};
template <class... A, class... B>
type_list<A..., B...> operator+(type_list<A...>, type_list<B...>);  // for decltype only

/// The entries E of the list for which Keep<E>::value holds, in order.
template <template <class> class Keep, class List>
struct filter;
template <template <class> class Keep, class... E>
struct filter<Keep, type_list<E...>> {
    using type = decltype((type_list<>{} + ... + std::conditional_t<Keep<E>::value, type_list<E>, type_list<>>{}));
};

/// The model of a plain system on state S (a user's lambda): no transform, no Jacobian, quadratic invariants.
template <state S>
struct plain_system {
    using state_type = S;
    void operator()(const S&, S&, double) const {}
};

/// T itself if it is a model (it has a state_type), else the plain system on state T.
template <class T>
struct as_model {
    using type = T;
};
template <state S>
    requires(!requires { typename S::state_type; })
struct as_model<S> {
    using type = plain_system<S>;
};

struct unsupported {};
template <class T>
struct type_is {
    using type = T;
};

template <class E>
concept tableau_method = requires { E::tableau; };

template <class T>
inline constexpr bool is_butcher_tableau = false;
template <std::size_t N>
inline constexpr bool is_butcher_tableau<butcher_tableau<N>> = true;

/// A tableau method of fixed steps: a Butcher tableau, not an embedded pair (those are the adaptive methods).
template <class E>
concept fixed_tableau_method =
    tableau_method<E> && is_butcher_tableau<std::remove_cvref_t<decltype(E::tableau)>>;

template <class E>
constexpr sign_rule sign_of() {
    if constexpr (requires { E::sign; })
        return E::sign;
    else
        return sign_rule::of_update;
}

template <class M>
using transform_t = std::remove_cvref_t<decltype(std::declval<const M&>().linearizing_transform())>;

// The stepper of entry E for model M, or `unsupported`: the one place where a method meets a model.
template <class E, class M>
constexpr auto resolve() {
    using S = typename M::state_type;
    if constexpr (records_stages<M> && !fixed_tableau_method<E>) {
        // A model that integrates its budget with the stepper's weights (concepts.hpp) runs the Runge-Kutta
        // engines over the fixed-step tableaux: other engines have no tableau, and the embedded pairs are adaptive.
        return type_is<unsupported>{};
    } else if constexpr (!tableau_method<E>) {
        if constexpr (E::template runs_on<M>)
            return type_is<typename E::template stepper<M>>{};
        else
            return type_is<unsupported>{};
    } else if constexpr (E::info.family == method_family::conventional) {
        return type_is<explicit_rk<E::tableau, S>>{};
    } else if constexpr (E::info.family == method_family::conservative) {
        if constexpr (linearizable<M>)
            return type_is<transformed_rk<E::tableau, transform_t<M>, sign_of<E>()>>{};
        else if constexpr (quadratic_invariants<M>)
            return type_is<conservative_rk<E::tableau, S, sign_of<E>()>>{};
        else
            return type_is<unsupported>{};
    } else {
        static_assert(tableau_method<E> && false, "a tableau method is conventional or conservative");
    }
}

}  // namespace detail

/// The stepper type of method entry E for a model M (or a state type, for a plain system on it); detail::
/// unsupported if the method does not run on it.
template <class E, class M>
using stepper_for = typename decltype(detail::resolve<E, typename detail::as_model<M>::type>())::type;

/// Whether method entry E runs on model M (or on a plain system on state type M).
template <class E, class M>
inline constexpr bool runs_on = !std::same_as<stepper_for<E, M>, detail::unsupported>;

/// How method entry E is built on model M: `transformed` for a conservative tableau on a model with a transform.
template <class E, class M>
constexpr method_family family_on() {
    if constexpr (detail::tableau_method<E> && E::info.family == method_family::conservative &&
                  linearizable<typename detail::as_model<M>::type>)
        return method_family::transformed;
    else
        return E::info.family;
}

/// THE list. To add a method: its tableau in tableaus.hpp (if it has one), its entry above, and its name here;
/// every model that can run it, `eci list`, `eci run`, the tests and the docs check pick it up.
using method_entry_list =
    detail::type_list<method_entries::euler, method_entries::pc, method_entries::rk2, method_entries::rk4,
                      method_entries::c_euler, method_entries::c_pc, method_entries::c_rk2, method_entries::c_rk4,
                      method_entries::c_pc_compensated, method_entries::implicit_midpoint, method_entries::kahan,
                      method_entries::bs32, method_entries::c_bs32, method_entries::ck54, method_entries::c_ck54,
                      method_entries::dp54, method_entries::c_dp54, method_entries::dp853, method_entries::c_dp853,
                      method_entries::f78, method_entries::c_f78,
                      method_entries::rrk_rk4, method_entries::idt_rk4, method_entries::mrrk_rk4,
                      method_entries::projected_rk4, method_entries::rrk_bs32, method_entries::rrk_dp54,
                      method_entries::mrrk_bs32, method_entries::mrrk_dp54, method_entries::projected_dp54,
                      method_entries::stormer_verlet, method_entries::sb3a>;

namespace detail {

template <class List>
struct method_table;
template <class... E>
struct method_table<type_list<E...>> {
    static constexpr std::array<method_info, sizeof...(E)> infos{E::info...};

    // Calls fn(stepper) for the entry called `name` if it runs on M; one instantiation of fn per stepper type.
    template <class M, class Fn>
    static bool dispatch(std::string_view name, Fn& fn) {
        auto try_one = [&]<class Entry>(Entry*) {
            if constexpr (runs_on<Entry, M>) {
                if (Entry::info.name != name) return false;
                fn(stepper_for<Entry, M>{});
                return true;
            } else {
                return false;
            }
        };
        return (try_one(static_cast<E*>(nullptr)) || ...);
    }

    // The entries that run on M, each with its family on M (`transformed` where the model's transform is used).
    template <class M>
    static std::vector<method_info> supported() {
        std::vector<method_info> out;
        auto add = [&]<class Entry>(Entry*) {
            if constexpr (runs_on<Entry, M>) {
                method_info m = Entry::info;
                m.family = family_on<Entry, M>();
                out.push_back(m);
            }
        };
        (add(static_cast<E*>(nullptr)), ...);
        return out;
    }

    // The declared order is the stepper's own, so the list cannot drift from the code.
    template <class Entry>
    static constexpr bool order_matches() {
        if constexpr (tableau_method<Entry>)
            return Entry::info.order == Entry::tableau.order;
        else
            return Entry::info.order == Entry::template stepper<plain_system<std::array<double, 2>>>::order;
    }
    static_assert((order_matches<E>() && ...), "a method's declared order differs from its stepper's");

    static constexpr bool names_unique() {
        for (std::size_t i = 0; i < infos.size(); ++i)
            for (std::size_t j = i + 1; j < infos.size(); ++j)
                if (infos[i].name == infos[j].name) return false;
        return true;
    }
    static_assert(names_unique(), "two methods share a name");
};

}  // namespace detail

/// The registry over the list.
using registered_methods = detail::method_table<method_entry_list>;

namespace detail {
template <class Fn, class... E>
void for_each_entry(Fn& fn, type_list<E...>) {
    (fn(static_cast<E*>(nullptr)), ...);
}
}  // namespace detail

/// Calls fn(static_cast<Entry*>(nullptr)) for every registry entry, in list order (fn a generic lambda
/// `[]<class Entry>(Entry*) {...}`): to build something per method at compile time.
template <class Fn>
void for_each_method_entry(Fn&& fn) {
    detail::for_each_entry(fn, method_entry_list{});
}

/// Every registered method, in list order.
inline constexpr auto methods = registered_methods::infos;

/// The registered method called `name`, if any.
constexpr std::optional<method_info> find_method(std::string_view name) {
    for (const method_info& m : methods)
        if (m.name == name) return m;
    return std::nullopt;
}

/// Calls fn(stepper) with a default-constructed stepper of the method `name` as it runs on Model (a model type,
/// or a state type for a plain system), and returns true; false if no such method runs on it. The choice is
/// made once, here: fn is instantiated per stepper type, so the loop inside it has no indirection.
template <class Model, class Fn>
bool with_stepper(std::string_view name, Fn&& fn) {
    return registered_methods::dispatch<typename detail::as_model<Model>::type>(name, fn);
}

/// The same, with the model's type taken from `model` (which the stepper does not keep: pass it to step).
template <class Model, class Fn>
bool with_stepper(std::string_view name, const Model&, Fn&& fn) {
    return with_stepper<Model>(name, std::forward<Fn>(fn));
}

/// with_stepper for a plain system on state S (the former name).
template <state S, class Fn>
bool with_method(std::string_view name, Fn&& fn) {
    return with_stepper<S>(name, std::forward<Fn>(fn));
}

/// The methods that run on Model (a model type, or a state type for a plain system), in list order, each with its
/// family on Model (`transformed` for the conservative tableaux on a model with a linearizing transform):
/// computed from what the model offers, never typed by hand.
template <class Model>
std::vector<method_info> methods_for() {
    return registered_methods::supported<typename detail::as_model<Model>::type>();
}

/// The invariants of Model (by the names its invariants() gives) that method `m` keeps to round-off by construction:
/// every one for a conservative or transformed method; the first for single relaxation (rrk-*, idt-rk4), the
/// independent ones (independent_invariants_of) for multiple relaxation and projection; for the implicit midpoint
/// rule, which keeps quadratic invariants, every one if the model declares them by quadratic weights, else none
/// (a quadratic invariant declared otherwise, as Cartesian Kepler's angular momentum, is not known to be one);
/// none for the conventional, symplectic and model-specific methods. What a run's summary says of its method.
template <class Model>
std::vector<std::string> invariants_kept(const method_info& m) {
    using M = typename detail::as_model<Model>::type;
    std::vector<std::string> all;
    if constexpr (requires { M::invariants(); })
        for (const auto& inv : M::invariants()) all.emplace_back(inv.name);
    const auto independent = [&] {
        if constexpr (names_independent_invariants<M>) {
            std::vector<std::string> v;
            for (std::size_t i : M::independent_invariants) v.push_back(all.at(i));
            return v;
        } else {
            return all;
        }
    };
    switch (m.family) {
        case method_family::conservative:
        case method_family::transformed: return all;
        case method_family::relaxation:
            if (m.conservative) return independent();  // mrrk-*: the two independent ones
            return all.empty() ? all : std::vector<std::string>{all.front()};
        case method_family::projection: return independent();
        case method_family::implicit: return declares_quadratic_weights<M> ? all : std::vector<std::string>{};
        default: return {};
    }
}

/// Why method `m` is not offered on Model (a model type, or a state type for a plain system) when what the model
/// lacks is a declaration of its own, as a clause for the refusal's message; empty otherwise. Relaxation and
/// projection keep the invariants a model declares (declares_invariants, invariants.hpp).
template <class Model>
std::string_view missing_declaration(const method_info& m) {
    using M = typename detail::as_model<Model>::type;
    const bool keeps_invariants = m.family == method_family::relaxation || m.family == method_family::projection;
    if (keeps_invariants && !declares_invariants<M> && !records_stages<M>)
        return "relaxation and projection keep the invariants a model declares, and it declares none";
    // multiple relaxation (a relaxation method that keeps every declared invariant: mrrk-*) needs exactly two
    if constexpr (declares_invariants<M>) {
        if (m.family == method_family::relaxation && m.conservative && independent_invariant_count<M> != 2) {
            if (independent_invariant_count<M> > 2)
                return "multiple relaxation keeps two independent invariants, and this model declares more";
            // (Kepler reports three invariants, of which one is independent: "declares one" read as a contradiction)
            if constexpr (names_independent_invariants<M>)
                if (M::invariants().size() > independent_invariant_count<M>)
                    return "multiple relaxation keeps two independent invariants, and of the invariants this model "
                           "declares one is independent";
            return "multiple relaxation keeps two independent invariants, and this model declares one";
        }
    }
    return {};
}

/// Their names.
template <class Model>
std::vector<std::string_view> method_names_for() {
    std::vector<std::string_view> names;
    for (const method_info& m : methods_for<Model>()) names.push_back(m.name);
    return names;
}

// The C++ names follow the registry's: each entry's stepper on a plain system is eci::<identifier><S>, and C-PC
// is the fused conservative engine over Heun's tableau.
static_assert(std::same_as<stepper_for<method_entries::euler, std::vector<double>>, euler<std::vector<double>>>);
static_assert(std::same_as<stepper_for<method_entries::pc, std::vector<double>>, pc<std::vector<double>>>);
static_assert(std::same_as<stepper_for<method_entries::rk2, std::vector<double>>, rk2<std::vector<double>>>);
static_assert(std::same_as<stepper_for<method_entries::rk4, std::vector<double>>, rk4<std::vector<double>>>);
static_assert(std::same_as<stepper_for<method_entries::c_euler, std::vector<double>>, c_euler<std::vector<double>>>);
static_assert(std::same_as<stepper_for<method_entries::c_pc, std::vector<double>>, c_pc<std::vector<double>>>);
static_assert(std::same_as<stepper_for<method_entries::c_rk2, std::vector<double>>, c_rk2<std::vector<double>>>);
static_assert(std::same_as<stepper_for<method_entries::c_rk4, std::vector<double>>, c_rk4<std::vector<double>>>);
static_assert(std::same_as<stepper_for<method_entries::c_pc_compensated, std::vector<double>>,
                           c_pc_compensated<std::vector<double>>>);
static_assert(std::same_as<stepper_for<method_entries::implicit_midpoint, std::vector<double>>,
                           implicit_midpoint<std::vector<double>>>);

}  // namespace eci

// The one list of eci's methods: name, order, whether it is exactly conservative, a one-line description,
// and the stepper type behind each name. `eci list`, the docs table and parameterised tests all loop over it.
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <string_view>
#include <utility>
#include <vector>

#include "concepts.hpp"
#include "steppers/compensated_c_pc.hpp"
#include "steppers/conservative_euler.hpp"
#include "steppers/conservative_rk.hpp"
#include "steppers/explicit_rk.hpp"
#include "steppers/implicit_midpoint.hpp"

namespace eci {

/// What the registry knows about a method.
struct method_info {
    std::string_view name;         ///< the name the CLI and the docs use
    int order;                     ///< global order of accuracy
    bool conservative;             ///< conserves every quadratic invariant of eqs. (2)-(3) to round-off
    std::string_view description;  ///< one line
};

/// The registry's entries: one struct per method, with its `info` and, if the method works on any state,
/// `stepper<S>`. A method whose stepper needs a particular model (a transform, a model-specific solve) omits
/// `stepper`; the models that support it dispatch it themselves (see apps/eci/models.cpp).
namespace method_entries {

/// Forward Euler.
struct euler {
    static constexpr method_info info{"euler", 1, false, "forward Euler, eq. (7)"};
    template <state S> using stepper = eci::euler<S>;
};
/// Heun's predictor-corrector.
struct pc {
    static constexpr method_info info{"pc", 2, false, "predictor-corrector (Heun), eq. (18)"};
    template <state S> using stepper = eci::pc<S>;
};
/// Explicit midpoint rule.
struct rk2 {
    static constexpr method_info info{"rk2", 2, false, "second-order Runge-Kutta (explicit midpoint rule)"};
    template <state S> using stepper = eci::rk2<S>;
};
/// Classical Runge-Kutta.
struct rk4 {
    static constexpr method_info info{"rk4", 4, false, "classical fourth-order Runge-Kutta"};
    template <state S> using stepper = eci::rk4<S>;
};
/// Conservative Euler.
struct c_euler {
    static constexpr method_info info{"c-euler", 1, true,
                                      "conservative Euler, eq. (16), implicit midpoint step near a zero mode"};
    template <state S> using stepper = eci::c_euler<S>;
};
/// Conservative predictor-corrector.
struct c_pc {
    static constexpr method_info info{"c-pc", 2, true, "conservative predictor-corrector, eq. (30)"};
    template <state S> using stepper = eci::c_pc<S>;
};
/// Conservative midpoint rule.
struct c_rk2 {
    static constexpr method_info info{"c-rk2", 2, true, "conservative second-order Runge-Kutta (midpoint tableau)"};
    template <state S> using stepper = eci::c_rk2<S>;
};
/// Conservative classical Runge-Kutta.
struct c_rk4 {
    static constexpr method_info info{"c-rk4", 4, true, "conservative fourth-order Runge-Kutta"};
    template <state S> using stepper = eci::c_rk4<S>;
};

/// C-PC that carries the rounding residual of psi^2 between steps (long runs: no sqrt(steps) random walk).
struct c_pc_compensated {
    static constexpr method_info info{"c-pc-compensated", 2, true,
                                      "C-PC with compensated psi^2 (no round-off random walk; one more buffer)"};
    template <state S> using stepper = eci::compensated_c_pc<S>;
};
/// The implicit midpoint rule, the implicit way to conserve quadratic invariants (for comparison).
struct implicit_midpoint {
    static constexpr method_info info{"implicit-midpoint", 2, true,
                                      "implicit midpoint rule, fixed-point iteration to round-off (for comparison)"};
    template <state S> using stepper = eci::implicit_midpoint<S>;
};

/// Kahan's linearly implicit method; eci::kahan<Model> needs the model's Jacobian, so models dispatch it.
struct kahan {
    static constexpr method_info info{"kahan", 2, false,
                                      "Kahan's linearly implicit method (quadratic fields; needs the model's Jacobian)"};
};

}  // namespace method_entries

namespace detail {

template <class Entry, class S>
concept generic_method = requires { typename Entry::template stepper<S>; };

template <class... Entries>
struct method_list {
    static constexpr std::array<method_info, sizeof...(Entries)> infos{Entries::info...};

    template <state S, class Fn>
    static bool dispatch(std::string_view name, Fn&& fn) {
        auto try_one = [&]<class E>(E*) {
            if constexpr (generic_method<E, S>) {
                if (E::info.name != name) return false;
                fn(typename E::template stepper<S>{});
                return true;
            } else {
                return false;
            }
        };
        return (try_one(static_cast<Entries*>(nullptr)) || ...);
    }

    template <state S>
    static std::vector<std::string_view> names_for() {
        std::vector<std::string_view> names;
        ((generic_method<Entries, S> ? names.push_back(Entries::info.name) : void()), ...);
        return names;
    }

    // The declared order is the stepper's own, so the list cannot drift from the code.
    template <class E>
    static constexpr bool order_matches() {
        if constexpr (generic_method<E, std::vector<double>>)
            return E::info.order == E::template stepper<std::vector<double>>::order;
        else
            return true;
    }
    static_assert((order_matches<Entries>() && ...), "a method's declared order differs from its stepper's");
};

}  // namespace detail

/// THE list. To add a method: write its entry above (info, and `stepper<S>` if it runs on any state), then
/// append it here; `eci list` and every loop over `methods` pick it up.
using registered_methods =
    detail::method_list<method_entries::euler, method_entries::pc, method_entries::rk2, method_entries::rk4,
                        method_entries::c_euler, method_entries::c_pc, method_entries::c_rk2, method_entries::c_rk4,
                        method_entries::c_pc_compensated, method_entries::implicit_midpoint, method_entries::kahan>;

/// Every registered method, in list order.
inline constexpr auto methods = registered_methods::infos;

/// The registered method called `name`, if any.
constexpr std::optional<method_info> find_method(std::string_view name) {
    for (const method_info& m : methods)
        if (m.name == name) return m;
    return std::nullopt;
}

/// Calls fn(stepper) with a default-constructed stepper of the method called `name` for state type S, and
/// returns true; returns false if no method of that name runs on any state. The choice is made once, here:
/// fn is instantiated for each stepper type, so the integration loop inside it has no indirection.
template <state S, class Fn>
bool with_method(std::string_view name, Fn&& fn) {
    return registered_methods::dispatch<S>(name, std::forward<Fn>(fn));
}

/// The names of the methods whose stepper runs on any state of type S, in list order.
template <state S>
std::vector<std::string_view> method_names_for() {
    return registered_methods::names_for<S>();
}

}  // namespace eci

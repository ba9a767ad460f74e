// Pieces every benchmark program shares: the right-hand side handle both libraries call, the Boost.Odeint
// steppers built the way a user would build them, a right-hand-side counter and sets of registry methods.
#pragma once

#include <cstdint>
#include <type_traits>

#include <boost/numeric/odeint.hpp>

#include <eci/models/three_wave.hpp>

namespace eci::bench {

/// f out of line: one function, compiled once, that both libraries call.
template <class Model, class S>
[[gnu::noinline]] void call_out_of_line(const Model& model, const S& x, S& dxdt, double t) {
    model(x, dxdt, t);
}

/// A cheap handle on a model, passed by value (odeint copies systems) and called identically by both libraries.
/// The n-wave right-hand side is never inlined, so both libraries run the very same machine code for it and the
/// comparison measures the steppers, not how the compiler scheduled an inlined f in each context; the three-wave
/// one (six multiplications) is inlined, as any user's would be.
template <class Model>
struct rhs {
    const Model* model;
    template <class S>
    void operator()(const S& x, S& dxdt, double t) const {
        if constexpr (std::is_same_v<Model, eci::three_wave>)
            (*model)(x, dxdt, t);
        else
            call_out_of_line(*model, x, dxdt, t);
    }
};

/// The same handle, counting its calls.
template <class Model>
struct counted_rhs {
    const Model* model;
    std::uint64_t* count;
    template <class S>
    void operator()(const S& x, S& dxdt, double t) const {
        ++*count;
        (*model)(x, dxdt, t);
    }
};

/// A set of registry entries (eci::method_entries::...) a benchmark runs, each labelled eci::identifier(name).
template <class... Entry>
struct method_set {};

namespace odeint = boost::numeric::odeint;

/// odeint's classical fourth-order Runge-Kutta method on state type S.
template <class S>
using odeint_rk4 = odeint::runge_kutta4<S>;

/// Heun's method (the paper's predictor-corrector) built with odeint's generic explicit Runge-Kutta engine.
template <class S>
using odeint_heun = odeint::explicit_generic_rk<2, 2, S, double>;

template <class S>
odeint_heun<S> make_odeint_heun() {
    const boost::array<double, 1> a1{{1.0}};
    const typename odeint_heun<S>::coef_a_type a(a1);
    const typename odeint_heun<S>::coef_b_type b{{0.5, 0.5}};
    const typename odeint_heun<S>::coef_c_type c{{0.0, 1.0}};
    return odeint_heun<S>(a, b, c);
}

}  // namespace eci::bench

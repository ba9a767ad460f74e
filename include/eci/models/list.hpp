// THE list of eci's ODE models, in `eci list` order. Everything that offers "every model" reads it: `eci run`
// (apps/eci/CMakeLists.txt makes one translation unit per entry, so the models' runs compile in parallel), the
// tests that run over every model, and the classes of eci.models in Python (python/src/models.cpp.in).
//
// Adding a model: its header in this directory (a described model, see description.hpp), its #include below and
// its type as one more line of ode_models. One type per line: the CMake step counts the lines.
#pragma once

#include <complex>
#include <cstddef>
#include <tuple>
#include <utility>

#include "exponential_entropy.hpp"
#include "kepler.hpp"
#include "kepler_cartesian.hpp"
#include "lotka_volterra.hpp"
#include "n_wave.hpp"
#include "nonlinear_oscillator.hpp"
#include "rigid_body.hpp"
#include "three_wave.hpp"

namespace eci {

/// Every ODE model, one per line (tuple_element_t<I, ode_models> is entry I).
using ode_models = std::tuple<
    three_wave,
    n_wave<double>,
    n_wave<std::complex<double>>,
    lotka_volterra,
    kepler,
    rigid_body,
    kepler_cartesian,
    nonlinear_oscillator,
    exponential_entropy>;

/// The number of ODE models.
inline constexpr std::size_t ode_model_count = std::tuple_size_v<ode_models>;

/// Entry I of the list.
template <std::size_t I>
using ode_model = std::tuple_element_t<I, ode_models>;

/// Calls f.template operator()<Model>() for every model of the list, in order.
template <class F>
void for_each_ode_model(F&& f) {
    [&]<std::size_t... I>(std::index_sequence<I...>) {
        (f.template operator()<ode_model<I>>(), ...);
    }(std::make_index_sequence<ode_model_count>{});
}

}  // namespace eci

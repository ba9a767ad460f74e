// THE list of models `eci run` and `eci list` know. Each adapter is in its own model_*.cpp.
#include "models.hpp"

namespace eci::cli {

// Adding a model (say lotka-volterra, with methods kahan and its own c-pc):
//  1. The library: the model as a plain struct in include/eci/models/ (state_type, operator(), validate(),
//     invariants() -> named_invariant list); a new method gets its entry in include/eci/registry.hpp (info,
//     and `stepper<S>` only if it runs on any state; a model-specific stepper such as a transformed C-PC has
//     none there and is dispatched by its model's adapter).
//  2. apps/eci/model_lotka_volterra.cpp (copy model_three_wave.cpp): a model_command whose info() lists the
//     method names it supports, add_options() binds its parameters and initial condition, and run() builds the
//     model and calls run_model(info, model, x0, columns, settings, dispatch). For methods of its own, pass a
//     dispatch(name, fn) that calls fn(its_stepper{}) for those names and falls back to
//     registry_dispatch<state_type>{}(name, fn) for the rest. CMake picks the file up by itself.
//  3. Here: declare its make_*_command() and append one line to the list below.
std::unique_ptr<model_command> make_three_wave_command();
std::unique_ptr<model_command> make_n_wave_command();
std::unique_ptr<model_command> make_n_wave_complex_command();
std::unique_ptr<model_command> make_lotka_volterra_command();
std::unique_ptr<model_command> make_kepler_command();
#ifdef ECI_HAVE_SPECTRAL
std::unique_ptr<model_command> make_navier_stokes_2d_command();
#endif

std::vector<std::unique_ptr<model_command>> registered_models() {
    std::vector<std::unique_ptr<model_command>> models;
    models.push_back(make_three_wave_command());
    models.push_back(make_n_wave_command());
    models.push_back(make_n_wave_complex_command());
    models.push_back(make_lotka_volterra_command());
    models.push_back(make_kepler_command());
#ifdef ECI_HAVE_SPECTRAL
    models.push_back(make_navier_stokes_2d_command());
#endif
    return models;
}

}  // namespace eci::cli

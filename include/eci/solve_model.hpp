// The definition of solve_model (eci/dynamic_sink.hpp): include it in the one translation unit that compiles a
// model's runs, with ECI_INSTANTIATE_SOLVE_MODEL(Model), and nowhere else.
#pragma once

#include <string_view>
#include <utility>
#include <vector>

#include "dynamic_sink.hpp"
#include "solve.hpp"

namespace eci {

template <class Model>
solve_report solve_model(const Model& model, typename Model::state_type& x, std::string_view method,
                         const run_config& cfg, dynamic_sink<typename Model::state_type>& sink,
                         std::vector<extra_invariant<typename Model::state_type>> extra, std::string_view what) {
    return solve<Model>(model, x, method, cfg, sink, std::move(extra), what);
}

}  // namespace eci

/// Compiles solve_model<Model>: every method that runs on Model, fixed and adaptive.
#define ECI_INSTANTIATE_SOLVE_MODEL(Model)                                                                          \
    template ::eci::solve_report eci::solve_model<Model>(                                                          \
        const Model&, typename Model::state_type&, std::string_view, const ::eci::run_config&,                     \
        ::eci::dynamic_sink<typename Model::state_type>&,                                                          \
        std::vector<::eci::extra_invariant<typename Model::state_type>>, std::string_view)

// How a model describes itself besides its invariants: its parameters, the options that set its initial state,
// and named presets for the paper's set-ups. The CLI, the figures, the tests and the benchmarks all read these.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>

#include "../steps.hpp"
#include "invariant.hpp"

namespace eci {

/// A model parameter: its name (the CLI option `--name`), one line, its constraint in words (the model's
/// validate() enforces it; "" when any finite value will do) and where its values live in a model: one double,
/// or several (three-wave's coupling M_K, M_P, M_Q).
template <class Model>
struct parameter {
    std::string_view name;
    std::string_view description;
    std::string_view constraint;
    std::span<double> (*values)(Model&);
};

/// The values of the data member `Member` of a model, a double or an array of them (for parameter::values).
template <auto Member, class Model>
std::span<double> member_values(Model& m) {
    auto& v = m.*Member;
    if constexpr (std::is_same_v<std::remove_cvref_t<decltype(v)>, double>)
        return {&v, 1};
    else
        return {v.data(), v.size()};
}

/// A part of a model's initial state set by one CLI option: `count` components from `first`, in the order of
/// the model's component_names.
struct state_field {
    std::string_view name;
    std::string_view description;
    std::string_view constraint;
    std::size_t first, count;
};

/// The two columns a run's picture (`eci run MODEL --plot`) draws against each other in its phase-plane panel: a
/// model's orbit, cycle or rotation, where a drifting method shows as a spiral or a band and a conservative one as a
/// closed curve. Each names a state component (component_names) or a derived column (derived_columns()); a model
/// declares `static constexpr phase_plane plot_plane{...}` (none: no such panel). `equal_axes`: one scale on both
/// axes (an orbit in space, a rotation), not each axis fitted to its own range.
struct phase_plane {
    std::string_view x, y;
    bool equal_axes;
};

/// A whole-number setting of a model generator (n-wave's modes, triads per mode, seed): name, one line, the
/// smallest value allowed and the member of the generator's recipe it sets.
template <class Recipe>
struct count_parameter {
    std::string_view name;
    std::string_view description;
    std::uint64_t min;
    std::uint64_t Recipe::*value;
};

/// A named set-up of a model: the paper's figures' parameters, initial condition, step and span, and the method
/// the paper runs on it. The first preset of a model is what `eci run MODEL` does without options.
template <class Model>
struct preset {
    std::string_view name;
    std::string_view description;  ///< one line: which figure, what it shows
    Model model;                   ///< the parameters
    typename Model::state_type x0;
    std::string_view method;  ///< registry name
    double dt;
    double t_end;  ///< the run covers [0, t_end]

    /// The number of steps of dt that cover [0, t_end] (the last one shortened if t_end is not on the grid).
    std::uint64_t steps() const { return steps_to_reach(0.0, t_end, dt); }
};

/// The preset of `Model` called `name`; throws std::invalid_argument naming the presets there are.
template <class Model>
preset<Model> find_preset(std::string_view name) {
    std::string known;
    for (const auto& p : Model::presets()) {
        if (p.name == name) return p;
        known += (known.empty() ? "" : ", ") + std::string(p.name);
    }
    throw std::invalid_argument("unknown preset '" + std::string(name) + "' (presets: " + known + ")");
}

}  // namespace eci

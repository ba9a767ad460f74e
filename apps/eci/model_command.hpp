// The one adapter between a model and `eci run`: everything it needs comes from the model's own description
// (name, parameters, initial-state fields, presets, invariants; see include/eci/models/description.hpp) and the
// registry (which methods run on it). apps/eci/CMakeLists.txt instantiates it once per model of the list,
// include/eci/models/list.hpp.
#pragma once

#include <algorithm>
#include <cstdio>
#include <cstddef>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include <eci/memory.hpp>
#include <eci/models/description.hpp>
#include <eci/registry.hpp>
#include <eci/solve.hpp>

#include "command.hpp"
#include "output.hpp"
#include "run_model.hpp"

namespace eci::cli {

namespace detail {

/// "1", or "1,1,-2" for several values: the default as `--help` prints it.
inline std::string shortest_list(std::span<const double> values) {
    std::string s;
    for (double v : values) {
        if (!s.empty()) s.push_back(',');
        s.append(shortest(v));  // appends only: GCC 12 warns (-Wrestrict, falsely) on operator+ chains
    }
    return s;
}

/// "what, constraint (default v)".
inline std::string option_help(std::string_view description, std::string_view constraint, const std::string& value) {
    std::string h(description);
    if (!constraint.empty()) h.append(", ").append(constraint);
    return h.append(" (default ").append(value).append(")");
}

}  // namespace detail

/// `eci run MODEL` for any described model: its options are its parameters and initial-state fields (or, for a
/// generated model such as n-wave, its recipe's settings), their defaults those of its first preset.
template <class Model>
class model_command_for final : public model_command {
    using state_type = typename Model::state_type;
    static constexpr bool generated = requires { Model::recipe_parameters(); };

   public:
    model_command_for() {
        const preset<Model> p = Model::presets()[0];
        info_.name = std::string(Model::name);
        info_.description = std::string(Model::description);
        for (const method_info& m : methods_for<Model>()) info_.methods.emplace_back(m.name);
        info_.default_method = std::string(p.method);
        if (const auto m = default_adaptive_method_for<Model>()) info_.default_adaptive_method = std::string(m->name);
        info_.default_dt = p.dt;
        info_.default_t_end = p.t_end;
        for (const auto& q : Model::presets())
            info_.presets.emplace_back(std::string(q.name), std::string(q.description));

        if constexpr (generated) {
            const typename Model::recipe defaults{};
            const auto settings = Model::recipe_parameters();
            whole_.resize(settings.size());
            for (std::size_t i = 0; i < settings.size(); ++i) {
                const auto& s = settings[i];
                whole_[i] = defaults.*s.value;
                options_.push_back({std::string(s.name),
                                    detail::option_help(s.description, "", std::to_string(defaults.*s.value)), 1,
                                    nullptr, &whole_[i], s.min});
            }
        } else {
            Model defaults = p.model;
            const auto parameters = Model::parameters();
            const auto fields = Model::initial_condition();
            reals_.resize(parameters.size() + fields.size());
            std::size_t k = 0;
            for (const auto& q : parameters) {
                const std::span<double> v = q.values(defaults);
                options_.push_back({std::string(q.name),
                                    detail::option_help(q.description, q.constraint, detail::shortest_list(v)),
                                    v.size(), &reals_[k++]});
            }
            for (const state_field& f : fields) {
                const auto v = std::span<const double>(p.x0).subspan(f.first, f.count);
                options_.push_back({std::string(f.name),
                                    detail::option_help(f.description, f.constraint, detail::shortest_list(v)),
                                    f.count, &reals_[k++]});
            }
        }
    }

    const model_info& info() const override { return info_; }
    std::vector<option_spec>& options() override { return options_; }

    int run(const run_settings& settings) override {
        preset<Model> p = Model::presets()[0];
        if (!settings.preset.empty()) {
            try {
                p = find_preset<Model>(settings.preset);
            } catch (const std::invalid_argument& e) {
                throw bad_input(info_.name + ": " + e.what());
            }
        }
        if constexpr (generated) {
            typename Model::recipe r{};
            const auto settings_of = Model::recipe_parameters();
            for (std::size_t i = 0; i < settings_of.size(); ++i) r.*settings_of[i].value = whole_[i];
            if constexpr (requires { Model::bytes_needed(r); }) check_memory(r);
            try {
                std::tie(p.model, p.x0) = Model::generate(r);
            } catch (const std::invalid_argument& e) {
                throw bad_input(info_.name + ": " + e.what());
            }
        } else {
            std::size_t k = 0;
            for (const auto& q : Model::parameters()) {
                const option_spec& o = options_[k++];
                if (o.given) std::copy(o.reals->begin(), o.reals->end(), q.values(p.model).begin());
            }
            for (const state_field& f : Model::initial_condition()) {
                const option_spec& o = options_[k++];
                if (o.given) std::copy(o.reals->begin(), o.reals->end(), p.x0.begin() + std::ptrdiff_t(f.first));
            }
        }
        // no --method: the library's rule, Python's too (the preset's method; with --rtol/--atol the model's
        // default adaptive method)
        std::string method_name = settings.method;
        if (method_name.empty()) {
            try {
                const bool adaptive = settings.rtol || settings.atol;
                method_name = default_method_for<Model>(p.method, adaptive, "model " + info_.name);
            } catch (const std::invalid_argument& e) {
                throw bad_input(e.what());
            }
        }
        // the library's resolution on the model itself: its sentences, with the reason where the model lacks what a
        // method needs (multiple relaxation's two invariants), as Python's
        const method_info method = [&] {
            try {
                return resolve_method_for<Model>(method_name, false, "model " + info_.name);
            } catch (const std::invalid_argument& e) {
                throw bad_input(e.what());
            }
        }();
        const run_plan plan = resolve_plan(p.dt, p.t_end, settings);
        return run_model(info_, p.model, p.x0, columns(p.model), method, plan, settings);
    }

   private:
    // A huge request says what it costs before it starts; one beyond this machine's memory is refused with the
    // library's sentence (check_fits_in_memory, which the generator applies for Python too).
    template <class Recipe>
    void check_memory(const Recipe& r) const {
        double bytes = 0.0;
        try {
            bytes = Model::bytes_needed(r);
            check_fits_in_memory(bytes, "the system");
        } catch (const std::invalid_argument& e) {
            throw bad_input(info_.name + ": " + e.what());
        }
        if (bytes > double(256ull << 20))
            std::fprintf(stderr, "eci: note: %s needs about %s of memory\n", info_.name.c_str(),
                         gib_text(bytes).c_str());
    }

    /// The CSV names of the real unknowns: the model's component names, or psi_0, ... (re_/im_ when complex).
    static column_names columns(const Model& model) {
        if constexpr (requires { Model::component_names; }) {
            return std::vector<std::string>(Model::component_names.begin(), Model::component_names.end());
        } else {
            bool complex = false;
            if constexpr (requires { Model::is_complex; }) complex = Model::is_complex;
            return indexed_columns("psi_", model.size(), complex);
        }
    }

    model_info info_;
    std::vector<option_spec> options_;
    std::vector<std::vector<double>> reals_;
    std::vector<std::uint64_t> whole_;
};

}  // namespace eci::cli

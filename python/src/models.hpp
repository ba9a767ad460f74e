// A built-in model as a Python object: eci.solve(model, ...) runs the whole integration in C++ with the GIL
// released; the object is also callable as model(t, y), SciPy-style, and evaluates its invariants.
#pragma once


#include <array>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <eci/models/invariant.hpp>

#include "core.hpp"
#include "python_system.hpp"
#include "solve.hpp"

namespace eci::python {

/// The methods the registry runs on Model, as strings (computed, the list `eci list` shows).
template <class Model>
std::vector<std::string> registry_methods() {
    std::vector<std::string> v;
    for (std::string_view n : method_names_for<Model>()) v.emplace_back(n);
    return v;
}

/// What every model object offers Python; eci.solve only needs _solve.
class model_base {
   public:
    virtual ~model_base() = default;
    /// The model's name in the CLI (`eci run NAME`).
    virtual std::string name() const = 0;
    /// The methods eci.solve accepts for this model.
    virtual std::vector<std::string> methods() const = 0;
    /// How each method is built on this model (the registry's family: "transformed" where its transform is used).
    virtual py::dict method_families() const = 0;
    /// The CLI's default step and end time.
    virtual double default_dt() const = 0;
    virtual double default_t_end() const = 0;
    /// The CLI's default initial condition.
    virtual py::array default_y0() const = 0;
    /// The names of the model's invariants.
    virtual std::vector<std::string> invariant_names() const = 0;
    /// dy/dt at (t, y), as a NumPy array.
    virtual py::array call(double t, const py::object& y) const = 0;
    /// Each invariant at y (one-dimensional) or at every column of y (n x m, SciPy's layout).
    virtual py::dict invariants(const py::object& y) const = 0;
    /// The integration behind eci.solve(model, ...): fixed steps of dt, or adaptive control from a first step dt.
    virtual py::dict solve(double t0, double t1, const py::object& y0, const std::string& method, double dt,
                           const py::dict& settings, std::vector<py::object> invariants,
                           const std::vector<std::string>& invariant_names) const = 0;
    /// The methods with an error estimate, for eci.solve(model, ..., rtol=...).
    virtual std::vector<std::string> adaptive_methods() const = 0;
};

/// A model of eci's library behind model_base; the registry builds the stepper each method is on it.
template <class Model>
class model_object : public model_base {
   public:
    using S = typename Model::state_type;
    using value_type = std::ranges::range_value_t<S>;
    static constexpr bool is_complex = std::is_same_v<value_type, std::complex<double>>;

    struct meta {
        std::string name;
        std::vector<std::string> methods;
        double default_dt, default_t_end;
        std::vector<std::string> columns;  ///< the real unknowns' names, for messages
    };

    /// Validates the model with the CLI's message ("invalid NAME model: ...").
    model_object(Model model, meta m, S y0) : model_(std::move(model)), meta_(std::move(m)), y0_(std::move(y0)) {
        try {
            model_.validate();
        } catch (const std::invalid_argument& e) {
            throw std::invalid_argument("invalid " + meta_.name + " model: " + e.what());
        }
    }

    const Model& model() const { return model_; }

    std::string name() const override { return meta_.name; }
    std::vector<std::string> methods() const override { return meta_.methods; }
    py::dict method_families() const override {
        py::dict d;
        for (const method_info& m : methods_for<Model>()) d[py::str(std::string(m.name))] = std::string(family_name(m.family));
        return d;
    }
    double default_dt() const override { return meta_.default_dt; }
    double default_t_end() const override { return meta_.default_t_end; }
    py::array default_y0() const override { return to_array(y0_); }
    std::vector<std::string> invariant_names() const override {
        std::vector<std::string> names;
        for (const auto& inv : Model::invariants()) names.emplace_back(inv.name);
        return names;
    }

    py::array call(double t, const py::object& y) const override {
        const S x = to_state(y);
        S dxdt = x;
        model_(x, dxdt, t);
        return to_array(dxdt);
    }

    py::dict invariants(const py::object& y) const override {
        const py::array a = py::array::ensure(y);
        py::dict d;
        if (a && a.ndim() == 2) {  // n x m: one value per column
            const std::size_t n = size(), m = static_cast<std::size_t>(a.shape(1));
            const auto c = py::array_t<value_type, py::array::f_style | py::array::forcecast>::ensure(a);
            if (!c || static_cast<std::size_t>(c.shape(0)) != n)
                throw py::value_error("y must have shape (" + std::to_string(n) + ", m), got " + shape_text(a));
            for (const auto& inv : Model::invariants()) {
                py::array_t<double> v(static_cast<py::ssize_t>(m));
                for (std::size_t j = 0; j < m; ++j) {
                    S x = y0_;
                    std::copy(c.data() + j * n, c.data() + (j + 1) * n, std::ranges::begin(x));
                    v.mutable_data()[j] = (model_.*inv.value)(x);
                }
                d[inv.name] = v;
            }
            return d;
        }
        const S x = to_state(y);
        for (const auto& inv : Model::invariants()) d[inv.name] = (model_.*inv.value)(x);
        return d;
    }

    py::dict solve(double t0, double t1, const py::object& y0, const std::string& method, double dt,
                   const py::dict& settings, std::vector<py::object> invariants,
                   const std::vector<std::string>& invariant_names) const override {
        S x = y0.is_none() ? y0_ : to_state(y0);
        const component_namer namer{meta_.columns, false};
        check_initial_state(model_, x, std::function<std::string(std::size_t)>(namer));
        const bool release = invariants.empty();  // Python invariants need the GIL at every step
        // the model itself as the system, as `eci run` passes it: the same bits
        return run_python<Model>(model_, x, method, request_from(t0, t1, dt, settings),
                                 python_extra_invariants<S>(std::move(invariants), invariant_names), namer,
                                 "model " + meta_.name, release);
    }

    std::vector<std::string> adaptive_methods() const override {
        std::vector<std::string> v;
        for (const method_info& m : adaptive_methods_for<Model>()) v.emplace_back(m.name);
        return v;
    }

   private:
    std::size_t size() const { return std::ranges::size(y0_); }

    static std::vector<value_type> to_vector(const S& x) { return {std::ranges::begin(x), std::ranges::end(x)}; }

    static py::array to_array(const S& x) { return to_numpy(to_vector(x)); }

    S to_state(const py::object& y) const {
        const std::size_t n = size();
        const auto a = as_vector<value_type>(y, n, "y", false, "the " + meta_.name + " state");
        S x = y0_;
        std::copy(a.data(), a.data() + n, std::ranges::begin(x));
        return x;
    }

    Model model_;
    meta meta_;
    S y0_;
};

/// What eci.solve and the CLI take from a model's own description: its name, the methods that run on it, and
/// its first preset's step and end time (`eci run NAME`'s defaults); `columns` names its real unknowns.
template <class Model, class Meta>
Meta describe(std::vector<std::string> columns) {
    const auto standard = Model::presets()[0];
    return {std::string(Model::name), registry_methods<Model>(), standard.dt, standard.t_end, std::move(columns)};
}

/// A fixed-size model's component names.
template <class Model>
std::vector<std::string> component_columns() {
    return {Model::component_names.begin(), Model::component_names.end()};
}

/// The CLI's column names for a state of `size` modes: psi_0... or re_psi_0, im_psi_0, ...
inline std::vector<std::string> indexed_columns(const std::string& prefix, std::size_t size, bool complex) {
    std::vector<std::string> c;
    for (std::size_t i = 0; i < size; ++i) {
        const std::string name = prefix + std::to_string(i);
        if (complex) {
            c.push_back("re_" + name);
            c.push_back("im_" + name);
        } else {
            c.push_back(name);
        }
    }
    return c;
}

/// Adds the static `_presets()` to a model's class: the model's named set-ups (models/description.hpp) as tuples
/// (name, description, model object, y0, method, dt, t_end), which eci.models wraps as Preset. columns(model)
/// names a preset model's real unknowns.
template <class Model, class Columns>
void add_presets(py::module_& m, const char* class_name, Columns columns) {
    auto c = py::reinterpret_borrow<py::class_<model_object<Model>, model_base>>(m.attr(class_name));
    c.def_static(
        "_presets",
        [columns] {
            using object = model_object<Model>;
            py::list l;
            for (const auto& p : Model::presets()) {
                auto meta = describe<Model, typename object::meta>(columns(p.model));
                const std::vector<std::ranges::range_value_t<typename Model::state_type>> y0(std::ranges::begin(p.x0),
                                                                                          std::ranges::end(p.x0));
                l.append(py::make_tuple(std::string(p.name), std::string(p.description),
                                        object(p.model, std::move(meta), p.x0), to_numpy(y0), std::string(p.method),
                                        p.dt, p.t_end));
            }
            return l;
        },
        "The model's named set-ups (the paper's figures) as tuples; see eci.models.Preset.");
}

/// Binds model_object<Model> as the Python class `name`, a subclass of eci._eci.Model.
template <class Model>
py::class_<model_object<Model>, model_base> bind_model(py::module_& m, const char* name, const char* doc) {
    return py::class_<model_object<Model>, model_base>(m, name, doc);
}

}  // namespace eci::python

// A built-in model as a Python object: eci.solve(model, ...) runs the whole integration in C++ with the GIL
// released; the object is also callable as model(t, y), SciPy-style, and evaluates its invariants.
#pragma once


#include <algorithm>
#include <array>
#include <charconv>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <eci/models/description.hpp>
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
    /// The method eci.solve runs when given none: the library's rule, the CLI's (eci::default_method_for: the
    /// model's default method, or with a tolerance its default adaptive method; ValueError if it has none).
    virtual std::string default_method(bool adaptive) const = 0;
    /// The real unknowns' names (the CLI's CSV columns: re_/im_ for a complex state); empty where the state has
    /// none of its own (a spectral field).
    virtual std::vector<std::string> component_names() const { return {}; }
    /// The model's plot_plane (description.hpp) as (x name, y name, equal_axes), or None.
    virtual py::object plot_plane() const { return py::none(); }
    /// The model's derived columns (derived_columns(), Kepler's x, y) at y or at every column of y, as
    /// invariants(y) gives the invariants; empty for a model without.
    virtual py::dict derived_columns(const py::object&) const { return py::dict(); }
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
        std::string default_method;  ///< its first preset's method, `eci run NAME`'s
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

    py::dict invariants(const py::object& y) const override { return evaluate(Model::invariants(), y); }

    std::vector<std::string> component_names() const override { return meta_.columns; }
    py::object plot_plane() const override {
        if constexpr (requires { Model::plot_plane; })
            return py::make_tuple(std::string(Model::plot_plane.x), std::string(Model::plot_plane.y),
                                  Model::plot_plane.equal_axes);
        else
            return py::none();
    }
    py::dict derived_columns(const py::object& y) const override {
        if constexpr (requires { Model::derived_columns(); })
            return evaluate(Model::derived_columns(), y);
        else
            return py::dict();
    }

    py::dict solve(double t0, double t1, const py::object& y0, const std::string& method, double dt,
                   const py::dict& settings, std::vector<py::object> invariants,
                   const std::vector<std::string>& invariant_names) const override {
        S x = y0.is_none() ? y0_ : to_state(y0);
        const component_namer namer{meta_.columns, false};
        check_initial_state(model_, x, std::function<std::string(std::size_t)>(namer));
        const bool release = invariants.empty();  // Python invariants need the GIL at every step
        // the model's compiled runs (src/models), which `eci run` runs too: the same bits
        return run_python_model<Model>(model_, x, method, request_from(t0, t1, dt, settings),
                                       python_extra_invariants<S>(std::move(invariants), invariant_names), namer,
                                       "model " + meta_.name, release);
    }

    std::vector<std::string> adaptive_methods() const override {
        std::vector<std::string> v;
        for (const method_info& m : adaptive_methods_for<Model>()) v.emplace_back(m.name);
        return v;
    }

    std::string default_method(bool adaptive) const override {
        return default_method_for<Model>(meta_.default_method, adaptive, "model " + meta_.name);
    }

   private:
    std::size_t size() const { return std::ranges::size(y0_); }

    /// Each function of a list of named_invariant (the invariants, the derived columns) at y, or at every column
    /// of y (n x m, SciPy's layout).
    template <class List>
    py::dict evaluate(const List& list, const py::object& y) const {
        const py::array a = py::array::ensure(y);
        py::dict d;
        if (a && a.ndim() == 2) {  // n x m: one value per column
            const std::size_t n = size(), m = static_cast<std::size_t>(a.shape(1));
            const auto c = py::array_t<value_type, py::array::f_style | py::array::forcecast>::ensure(a);
            if (!c || static_cast<std::size_t>(c.shape(0)) != n)
                throw py::value_error("y must have shape (" + std::to_string(n) + ", m), got " + shape_text(a));
            for (const auto& inv : list) {
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
        for (const auto& inv : list) d[inv.name] = (model_.*inv.value)(x);
        return d;
    }

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
    return {std::string(Model::name), registry_methods<Model>(), std::string(standard.method), standard.dt,
            standard.t_end, std::move(columns)};
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

/// The names of a model's real unknowns, as the CLI's CSV header gives them: its component names, or psi_0, ...
/// (re_/im_ when complex).
template <class Model>
std::vector<std::string> columns_of(const Model& model) {
    if constexpr (requires { Model::component_names; }) {
        return {Model::component_names.begin(), Model::component_names.end()};
    } else {
        bool complex = false;
        if constexpr (requires { Model::is_complex; }) complex = Model::is_complex;
        return indexed_columns("psi_", model.size(), complex);
    }
}

/// A model's Python class name: its CLI name in CamelCase (three-wave: ThreeWave, n-wave-complex: NWaveComplex).
inline std::string class_name_of(std::string_view cli_name) {
    std::string s;
    bool upper = true;
    for (char c : cli_name) {
        if (c == '-') {
            upper = true;
            continue;
        }
        s.push_back(upper && c >= 'a' && c <= 'z' ? char(c - 'a' + 'A') : c);
        upper = false;
    }
    return s;
}

/// A setting's Python keyword: its CLI option name with '-' written '_' (triads-per-mode: triads_per_mode).
inline std::string keyword_of(std::string_view option) {
    std::string s(option);
    for (char& c : s)
        if (c == '-') c = '_';
    return s;
}

/// "(1, 1, -2)" or "1.5": values as a repr shows them.
inline std::string values_text(std::span<const double> v) {
    if (v.size() == 1) return shortest_text(v[0]);
    std::string s = "(";
    for (std::size_t i = 0; i < v.size(); ++i) s.append(i ? ", " : "").append(shortest_text(v[i]));
    return s + ")";
}

/// The Python class of a described model (include/eci/models/description.hpp), built from the description alone:
///   - its constructor takes the model's parameters (or, for a generated model such as n-wave, its recipe's
///     settings) by position or keyword, with the defaults `eci run NAME` has: its first preset's (the recipe's);
///   - each parameter is a read-only property, and repr shows them;
///   - `_presets()` gives the model's presets (eci.models wraps them as Preset).
/// What a model offers beyond that (Kepler's runge_lenz_turn) is added by add_extras (model_extras.hpp).
template <class Model>
class described_binder {
    using object = model_object<Model>;
    using value_type = std::ranges::range_value_t<typename Model::state_type>;
    static constexpr bool generated = requires { Model::recipe_parameters(); };

   public:
    explicit described_binder(py::module_& m)
        : name_(class_name_of(Model::name)), class_(m, name_.c_str(), doc().c_str()) {
        const std::string cls = name_;
        class_.def(py::init([cls](py::args args, py::kwargs kwargs) { return make(cls, args, kwargs); }));
        if constexpr (!generated) {
            const auto parameters = Model::parameters();
            for (std::size_t i = 0; i < parameters.size(); ++i)
                class_.def_property_readonly(
                    keyword_of(parameters[i].name).c_str(),
                    [i](const object& o) -> py::object {
                        Model copy = o.model();
                        const std::span<double> v = Model::parameters()[i].values(copy);
                        if (v.size() == 1) return py::float_(v[0]);
                        return py::cast(std::vector<double>(v.begin(), v.end()));
                    },
                    std::string(parameters[i].description).c_str());
            class_.def("__repr__", [cls](const object& o) {
                Model copy = o.model();
                std::string s = cls + "(";
                bool first = true;
                for (const auto& q : Model::parameters()) {
                    s.append(first ? "" : ", ")
                        .append(keyword_of(q.name))
                        .append("=")
                        .append(values_text(q.values(copy)));
                    first = false;
                }
                return s + ")";
            });
        }
        class_.def_static(
            "_parameters",
            [] {
                py::list l;
                if constexpr (generated)
                    for (const auto& q : Model::recipe_parameters())
                        l.append(py::make_tuple(std::string(q.name), keyword_of(q.name), 1));
                else
                    for (const auto& q : Model::parameters()) {
                        Model defaults = Model::presets()[0].model;
                        l.append(py::make_tuple(std::string(q.name), keyword_of(q.name), q.values(defaults).size()));
                    }
                return l;
            },
            "The constructor's parameters as (CLI option, keyword, number of values), in order.");
        class_.def_static(
            "_initial_condition",
            [] {
                py::list l;
                if constexpr (!generated)
                    for (const state_field& f : Model::initial_condition())
                        l.append(py::make_tuple(std::string(f.name), f.first, f.count));
                return l;
            },
            "The CLI options that set the initial state as (option, first component, number of components).");
        class_.def_static(
            "_presets",
            [] {
                py::list l;
                for (const auto& p : Model::presets()) {
                    const std::vector<value_type> y0(std::ranges::begin(p.x0), std::ranges::end(p.x0));
                    l.append(py::make_tuple(
                        std::string(p.name), std::string(p.description),
                        object(p.model, describe<Model, typename object::meta>(columns_of(p.model)), p.x0),
                        to_numpy(y0), std::string(p.method), p.dt, p.t_end));
                }
                return l;
            },
            "The model's named set-ups (the paper's figures) as tuples; see eci.models.Preset.");
    }

    py::class_<object, model_base>& py_class() { return class_; }

   private:
    /// The keywords of the constructor, in order.
    static std::vector<std::string> keywords() {
        std::vector<std::string> k;
        if constexpr (generated)
            for (const auto& s : Model::recipe_parameters()) k.push_back(keyword_of(s.name));
        else
            for (const auto& q : Model::parameters()) k.push_back(keyword_of(q.name));
        return k;
    }

    /// "ThreeWave(K=1.7320508075688772, P=3, ...)": the constructor with its defaults.
    static std::string signature() {
        std::string s = class_name_of(Model::name) + "(";
        if constexpr (generated) {
            const typename Model::recipe defaults{};
            for (const auto& q : Model::recipe_parameters())
                s.append(s.back() == '(' ? "" : ", ")
                    .append(keyword_of(q.name))
                    .append("=")
                    .append(std::to_string(defaults.*q.value));
        } else {
            Model defaults = Model::presets()[0].model;
            for (const auto& q : Model::parameters())
                s.append(s.back() == '(' ? "" : ", ")
                    .append(keyword_of(q.name))
                    .append("=")
                    .append(values_text(q.values(defaults)));
        }
        return s + ")";
    }

    static std::string doc() {
        std::string d = signature() + "\n\n" + std::string(Model::description) + " (`eci run " +
                        std::string(Model::name) + "`). Invariants as eci.solve's result.invariants names them:";
        bool first = true;
        for (const auto& inv : Model::invariants()) d.append(first ? " " : ", ").append(inv.name), first = false;
        d.append(".");
        if constexpr (!generated)
            for (const auto& q : Model::parameters()) {
                d.append("\n").append(keyword_of(q.name)).append(": ").append(q.description);
                if (!q.constraint.empty()) d.append(", ").append(q.constraint);
            }
        else
            for (const auto& q : Model::recipe_parameters())
                d.append("\n")
                    .append(keyword_of(q.name))
                    .append(": ")
                    .append(q.description)
                    .append(", a whole number >= ")
                    .append(std::to_string(q.min));
        return d;
    }

    /// The arguments given, by keyword index; TypeError on an unknown keyword, one given twice or too many.
    static std::vector<py::object> arguments(const std::string& cls, const py::args& args, const py::kwargs& kwargs) {
        const std::vector<std::string> names = keywords();
        std::vector<py::object> given(names.size());
        if (args.size() > names.size())
            throw py::type_error(cls + "() takes at most " + std::to_string(names.size()) + " arguments (" +
                                 std::to_string(args.size()) + " given)");
        for (std::size_t i = 0; i < args.size(); ++i) given[i] = args[i];
        for (const auto& [key, value] : kwargs) {
            const std::string k = py::cast<std::string>(key);
            const auto at = std::find(names.begin(), names.end(), k);
            if (at == names.end()) throw py::type_error(cls + "() got an unexpected keyword argument '" + k + "'");
            auto& slot = given[std::size_t(at - names.begin())];
            if (slot) throw py::type_error(cls + "() got multiple values for argument '" + k + "'");
            slot = py::reinterpret_borrow<py::object>(value);
        }
        return given;
    }

    static double number(const std::string& cls, const std::string& key, const py::handle& v) {
        try {
            return py::cast<double>(v);
        } catch (const py::cast_error&) {
            throw py::type_error(cls + ": " + key + " must be a number, not " +
                                 py::cast<std::string>(py::type::handle_of(v).attr("__name__")));
        }
    }

    static object make(const std::string& cls, const py::args& args, const py::kwargs& kwargs) {
        const std::vector<py::object> given = arguments(cls, args, kwargs);
        const std::vector<std::string> names = keywords();
        if constexpr (generated) {
            typename Model::recipe r{};
            const auto settings = Model::recipe_parameters();
            for (std::size_t i = 0; i < settings.size(); ++i) {
                if (!given[i]) continue;
                // the CLI's checks of its whole-number options (a Python int beyond 64 bits in its sentence, not
                // a TypeError), then the generator's own
                std::uint64_t v = 0;
                bool negative = false;
                std::string text;
                try {
                    const long long w = py::cast<long long>(given[i]);
                    negative = w < 0;
                    v = std::uint64_t(w);
                    text = std::to_string(w);
                } catch (const py::cast_error&) {
                    if (!py::isinstance<py::int_>(given[i]))
                        throw py::type_error(cls + ": " + names[i] + " must be a whole number, not " +
                                             py::cast<std::string>(py::type::handle_of(given[i]).attr("__name__")));
                    text = py::str(given[i]);
                    negative = text.starts_with('-');
                    if (!negative && std::from_chars(text.data(), text.data() + text.size(), v).ec != std::errc())
                        throw std::invalid_argument(names[i] + ": '" + text + "' is too large (at most " +
                                                    std::to_string(std::numeric_limits<std::uint64_t>::max()) + ")");
                }
                if (negative || v < settings[i].min)
                    throw std::invalid_argument(names[i] + " must be a whole number >= " +
                                                std::to_string(settings[i].min) + ", not " + text);
                r.*settings[i].value = v;
            }
            std::pair<Model, typename Model::state_type> generated_model;
            try {
                generated_model = Model::generate(r);
            } catch (const std::invalid_argument& e) {
                throw std::invalid_argument(std::string(Model::name) + ": " + e.what());
            }
            auto& [model, x0] = generated_model;
            auto meta = describe<Model, typename object::meta>(columns_of(model));
            return object(std::move(model), std::move(meta), std::move(x0));
        } else {
            auto p = Model::presets()[0];
            const auto parameters = Model::parameters();
            for (std::size_t i = 0; i < parameters.size(); ++i) {
                if (!given[i]) continue;
                const std::span<double> v = parameters[i].values(p.model);
                if (v.size() == 1) {
                    v[0] = number(cls, names[i], given[i]);
                    continue;
                }
                if (!py::isinstance<py::iterable>(given[i]) || py::isinstance<py::str>(given[i]))
                    throw py::type_error(cls + ": " + names[i] + " must be " + std::to_string(v.size()) + " numbers");
                std::vector<double> values;
                for (const py::handle& x : py::iter(given[i])) values.push_back(number(cls, names[i], x));
                if (values.size() != v.size())
                    throw std::invalid_argument(names[i] + " takes " + std::to_string(v.size()) + " values, not " +
                                                std::to_string(values.size()));
                std::copy(values.begin(), values.end(), v.begin());
            }
            auto meta = describe<Model, typename object::meta>(columns_of(p.model));
            return object(std::move(p.model), std::move(meta), std::move(p.x0));
        }
    }

    std::string name_;
    py::class_<object, model_base> class_;
};

}  // namespace eci::python

// What a model's Python class offers beyond what described_binder (models.hpp) builds from its description:
// add_extras(cls) for that model's class. A model without an overload here gets nothing more.
#pragma once

#include <array>
#include <complex>
#include <string>
#include <vector>

#include <eci/models/kepler.hpp>
#include <eci/models/n_wave.hpp>

#include "models.hpp"

namespace eci::python {

template <class Model>
using model_class = py::class_<model_object<Model>, model_base>;

/// Nothing beyond the description.
template <class Model>
void add_extras(model_class<Model>&) {}

/// Kepler: the turn of the orbit's axis between two states (the CLI's summary reports it).
inline void add_extras(model_class<kepler>& c) {
    c.def(
        "runge_lenz_turn",
        [](const model_object<kepler>& o, const py::object& y_from, const py::object& y_to) {
            const auto a = py::array_t<double, py::array::forcecast>::ensure(y_from);
            const auto b = py::array_t<double, py::array::forcecast>::ensure(y_to);
            if (!a || !b || a.size() != 3 || b.size() != 3)
                throw py::value_error("runge_lenz_turn takes two states (r, v_r, theta)");
            return o.model().runge_lenz_turn({a.data()[0], a.data()[1], a.data()[2]},
                                             {b.data()[0], b.data()[1], b.data()[2]});
        },
        py::arg("y_from"), py::arg("y_to"),
        "The angle (radians, in (-pi, pi]) by which the orbit's axis (the Runge-Lenz vector) turned");
}

/// n-wave: what the generator drew (modes, triads, wavenumbers), which its recipe alone does not show.
template <class T>
void add_extras(model_class<n_wave<T>>& c) {
    using object = model_object<n_wave<T>>;
    c.def_property_readonly("modes", [](const object& o) { return o.model().size(); })
        .def_property_readonly("triads_per_mode",
                               [](const object& o) { return 3 * o.model().triads.size() / o.model().size(); })
        .def_property_readonly(
            "wavenumber", [](const object& o) { return to_numpy(o.model().wavenumber); },
            "|k| of each mode (the enstrophy weights' square roots)")
        .def_property_readonly(
            "triads",
            [](const object& o) {
                std::vector<std::array<double, 6>> rows;
                for (const triad& t : o.model().triads)
                    rows.push_back({double(t.k), double(t.p), double(t.q), t.Mk, t.Mp, t.Mq});
                return rows;
            },
            "each triad as (k, p, q, M_k, M_p, M_q)")
        .def("__repr__", [](const object& o) {
            return class_name_of(n_wave<T>::name) + "(modes=" + std::to_string(o.model().size()) + ", " +
                   std::to_string(o.model().triads.size()) + " triads)";
        });
}

/// Binds a model of the list as eci._eci.<its class name> and returns the class.
template <class Model>
py::object bind_listed_model(py::module_& m) {
    described_binder<Model> binder(m);
    add_extras(binder.py_class());
    return binder.py_class();
}

}  // namespace eci::python

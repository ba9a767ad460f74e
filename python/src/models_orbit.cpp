// eci.models.LotkaVolterra and Kepler: eqs. (36)-(42) and (43)-(54), with the CLI's parameters, defaults, methods
// and messages; the registry runs the conservative methods through each model's transform, Kahan on its Jacobian.
#include <eci/models/kepler.hpp>
#include <eci/models/lotka_volterra.hpp>

#include "models.hpp"
#include "module.hpp"

namespace eci::python {

namespace {

using lv_object = model_object<lotka_volterra>;
using kepler_object = model_object<kepler>;

}  // namespace

void init_orbit_models(py::module_& m) {
    bind_model<lotka_volterra>(
        m, "LotkaVolterra",
        "Predator-prey equations (36), dx/dt = -mu x (1 - y), dy/dt = y (1 - x); invariant the Hamiltonian (37). "
        "c-pc is eq. (42); every conservative method goes through the transform (39).")
        .def(py::init([](double mu) {
                 lotka_volterra model;
                 model.mu = mu;
                 return lv_object(model, describe<lotka_volterra, lv_object::meta>(component_columns<lotka_volterra>()),
                                  lotka_volterra::presets()[0].x0);
             }),
             py::arg("mu") = 1.5)
        .def_property_readonly("mu", [](const lv_object& o) { return o.model().mu; })
        .def("__repr__", [](const lv_object& o) { return "LotkaVolterra(mu=" + shortest_text(o.model().mu) + ")"; });

    bind_model<kepler>(
        m, "Kepler",
        "The Kepler problem (45) in polar variables (r, v_r, theta), bound orbits; invariants H (46) and the "
        "Runge-Lenz vector (47). c-pc is eqs. (49)-(54); every conservative method goes through the transform (50).")
        .def(py::init([](double mass, double K, double ell) {
                 kepler model;
                 model.m = mass, model.K = K, model.ell = ell;
                 return kepler_object(model, describe<kepler, kepler_object::meta>(component_columns<kepler>()),
                                      kepler::presets()[0].x0);
             }),
             py::arg("m") = 1.0, py::arg("K") = 1.5, py::arg("ell") = 1.0)
        .def_property_readonly("m", [](const kepler_object& o) { return o.model().m; })
        .def_property_readonly("K", [](const kepler_object& o) { return o.model().K; })
        .def_property_readonly("ell", [](const kepler_object& o) { return o.model().ell; })
        .def("runge_lenz_turn",
             [](const kepler_object& o, const py::object& y_from, const py::object& y_to) {
                 const auto a = py::array_t<double, py::array::forcecast>::ensure(y_from);
                 const auto b = py::array_t<double, py::array::forcecast>::ensure(y_to);
                 if (!a || !b || a.size() != 3 || b.size() != 3)
                     throw py::value_error("runge_lenz_turn takes two states (r, v_r, theta)");
                 return o.model().runge_lenz_turn({a.data()[0], a.data()[1], a.data()[2]},
                                                  {b.data()[0], b.data()[1], b.data()[2]});
             },
             py::arg("y_from"), py::arg("y_to"),
             "The angle (radians, in (-pi, pi]) by which the orbit's axis (the Runge-Lenz vector) turned")
        .def("__repr__", [](const kepler_object& o) {
            const kepler& k = o.model();
            return "Kepler(m=" + shortest_text(k.m) + ", K=" + shortest_text(k.K) + ", ell=" + shortest_text(k.ell) +
                   ")";
        });
    add_presets<lotka_volterra>(m, "LotkaVolterra",
                                [](const lotka_volterra&) { return component_columns<lotka_volterra>(); });
    add_presets<kepler>(m, "Kepler", [](const kepler&) { return component_columns<kepler>(); });
}

}  // namespace eci::python

// The extension module eci._eci: the registry's methods, the Model base class of the built-in models, the solvers
// behind eci.solve, and the translation of a step-size underflow into eci.StepSizeUnderflow.

#include <eci/registry.hpp>
#include <eci/version.hpp>

#include "core.hpp"
#include "models.hpp"
#include "module.hpp"

namespace eci::python {

namespace {

void bind_model_base(py::module_& m) {
    py::class_<model_base>(m, "Model", "A built-in model: eci.solve(model, ...) integrates it entirely in C++.")
        .def_property_readonly("name", &model_base::name, "the model's name in the CLI (eci run NAME)")
        .def_property_readonly("methods", &model_base::methods, "the methods eci.solve accepts for this model")
        .def_property_readonly("method_families", &model_base::method_families,
                               "how each method is built on this model: conventional, conservative, transformed "
                               "(through the model's transform), implicit or model-specific")
        .def_property_readonly("default_dt", &model_base::default_dt, "the CLI's default time step")
        .def_property_readonly("default_t_end", &model_base::default_t_end, "the CLI's default end time")
        .def_property_readonly("default_y0", &model_base::default_y0, "the CLI's default initial condition")
        .def_property_readonly("invariant_names", &model_base::invariant_names, "the model's invariants, by name")
        .def(
            "__call__",
            [](const model_base& self, const py::handle t, const py::object& y) {
                // t read as pybind11 reads a float, but a wrong one said in one line naming it (pybind11's refusal
                // is the signature over many lines), at no cost on solve_ivp's path (a Python wrapper cost 0.4 us)
                const double v = PyFloat_Check(t.ptr()) ? PyFloat_AS_DOUBLE(t.ptr()) : PyFloat_AsDouble(t.ptr());
                if (v == -1.0 && PyErr_Occurred()) {
                    PyErr_Clear();
                    throw py::type_error(py::str(py::type::of(py::cast(self)).attr("__name__")).cast<std::string>() +
                                         "(t, y): t must be a real number, not " +
                                         py::str(py::type::of(t).attr("__name__")).cast<std::string>() + " " +
                                         py::repr(t).cast<std::string>());
                }
                return self.call(v, y);
            },
            py::arg("t"), py::arg("y"),
             "dy/dt at (t, y), SciPy's fun(t, y) (so the model can be given to scipy.integrate.solve_ivp too)")
        .def("invariants", &model_base::invariants, py::arg("y"),
             "each invariant at the state y, or at every column of y (n x m, SciPy's layout), by name")
        .def_property_readonly("component_names", &model_base::component_names,
                               "the real unknowns' names, as the CLI's CSV columns (re_/im_ for a complex state)")
        .def_property_readonly("plot_plane", &model_base::plot_plane,
                               "the phase plane `eci run --plot` and SolveResult.plot draw: (x name, y name, "
                               "equal_axes), each a component or a derived column, or None")
        .def("derived_columns", &model_base::derived_columns, py::arg("y"),
             "the model's columns computed from the state (Kepler's Cartesian x, y) at the state y, or at every "
             "column of y (n x m), by name; empty for a model without")
        .def("_solve", &model_base::solve, py::arg("t0"), py::arg("t1"), py::arg("y0"), py::arg("method"),
             py::arg("dt"), py::arg("settings"), py::arg("invariants"), py::arg("invariant_names"),
             "The integration behind eci.solve(model, ...): fixed steps of dt, or adaptive control from a first "
             "step dt (settings['adaptive']).")
        .def_property_readonly("adaptive_methods", &model_base::adaptive_methods,
                               "the methods with an error estimate, for eci.solve(model, ..., rtol=...)")
        .def_property_readonly(
            "default_method", [](const model_base& m) { return m.default_method(false); },
            "the method eci.solve runs when given none, as `eci run NAME` without --method")
        .def("_default_method", &model_base::default_method, py::arg("adaptive"),
             "The method eci.solve runs when given none: with adaptive=True (rtol/atol given) the model's default "
             "adaptive method, as `eci run NAME --rtol R`; ValueError if it has none.");
}

py::list method_list() {
    py::list l;
    for (const method_info& i : eci::methods)
        l.append(py::make_tuple(std::string(i.name), i.order, i.conservative, std::string(i.description)));
    return l;
}

}  // namespace

}  // namespace eci::python

PYBIND11_MODULE(_eci, m) {
    using namespace eci::python;
    m.doc() = "The compiled part of eci (use the package eci: eci.solve, eci.models, eci.methods).";
    m.attr("__version__") = ECI_VERSION_STRING;  // project(eci VERSION ...), the one version source
    m.def("_methods", &method_list, "Every registered method as (name, order, conservative, description).");
    m.attr("_max_grid_steps") = eci::max_grid_steps;  // the most fixed steps of a run (steps.hpp)
    m.def("_step_dividing", &eci::step_dividing, py::arg("h"), py::arg("dt"),
          "The largest step of at most dt that divides h into whole steps (the spectral CFL step with output_dt).");
    bind_model_base(m);
    init_models(m);
    init_functions(m);
    init_scipy_stepper(m);
#ifdef ECI_PYTHON_SPECTRAL
    init_ns2d(m);
#endif
}

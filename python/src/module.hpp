// The parts of the extension eci._eci: each source file adds its functions or classes to the module.
#pragma once

#include <pybind11/pybind11.h>

namespace eci::python {

/// _solve_function: eci.solve with a Python fun (fixed or adaptive, real or complex, a transform, Kahan's method).
void init_functions(pybind11::module_& m);
/// NavierStokes2D (built with eci::spectral only).
void init_ns2d(pybind11::module_& m);
/// eci.models' class of every model of the list (include/eci/models/list.hpp), and _ode_models in list order
/// (generated from models.cpp.in).
void init_models(pybind11::module_& m);
/// _EmbeddedStepper, _embedded_pairs: the engine behind eci.scipy's OdeSolver classes.
void init_scipy_stepper(pybind11::module_& m);

}  // namespace eci::python

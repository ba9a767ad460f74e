// The parts of the extension eci._eci: each source file adds its functions or classes to the module.
#pragma once

#include <pybind11/pybind11.h>

namespace eci::python {

/// _solve_real, _solve_complex, _solve_transformed: eci.solve with a Python fun.
void init_functions(pybind11::module_& m);
/// _solve_adaptive_real, _solve_adaptive_complex, _solve_adaptive_transformed: eci.solve with rtol/atol.
void init_adaptive_functions(pybind11::module_& m);
/// _solve_kahan: Kahan's method on a Python fun with its Jacobian.
void init_kahan(pybind11::module_& m);
/// NavierStokes2D (built with eci::spectral only).
void init_ns2d(pybind11::module_& m);
/// The model base class and ThreeWave, NWave, NWaveComplex.
void init_wave_models(pybind11::module_& m);
/// LotkaVolterra and Kepler.
void init_orbit_models(pybind11::module_& m);
/// _EmbeddedStepper, _embedded_pairs: the engine behind eci.scipy's OdeSolver classes.
void init_scipy_stepper(pybind11::module_& m);

}  // namespace eci::python

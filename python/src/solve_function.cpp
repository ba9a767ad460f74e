// eci.solve with a Python fun(t, y): every registry method that runs on any state, for real and complex y, and the
// transformed engine (C-PC, C-RK2, C-RK4) through a transform given as Python functions.
#include <eci/steppers/transformed_rk.hpp>

#include "module.hpp"
#include "python_system.hpp"

namespace eci::python {

namespace {

template <class T>
using input_array = py::array_t<T, py::array::c_style | py::array::forcecast>;

template <class T>
std::vector<drift_record> named_records(const std::vector<std::string>& names) {
    std::vector<drift_record> r;
    for (const std::string& n : names) r.push_back({n});
    return r;
}

template <class T>
py::dict solve_function(py::object fun, double t0, double t1, const input_array<T>& y0, const std::string& method,
                        double dt, std::optional<std::vector<double>> t_eval, std::vector<py::object> invariants,
                        const std::vector<std::string>& invariant_names, int max_halvings) {
    using S = std::vector<T>;
    const std::size_t n = static_cast<std::size_t>(y0.shape(0));
    S x(y0.data(), y0.data() + n);
    std::vector<std::string> available;
    for (std::string_view name : method_names_for<S>()) available.emplace_back(name);
    const method_info info = resolve_method(method, available, "fun(t, y)");
    const python_rhs<T> f(std::move(fun), n);
    const python_invariants<T> invs{std::move(invariants)};
    std::vector<drift_record> drift = named_records<T>(invariant_names);
    const run_request req{t0, t1, dt, std::move(t_eval), max_halvings};
    const component_namer namer{{}, std::is_same_v<T, std::complex<double>>};
    interrupt_check interrupt(true);
    recorded_output<S> out;
    run_report report;
    auto measure = [&](const S& s, bool first) { invs.measure(s, drift, 0, first); };
    with_method<S>(method, [&](auto stepper) { run_grid(stepper, f, x, req, measure, interrupt, out, report, namer); });
    return result_dict(out, n, report, drift, info);
}

py::dict solve_transformed(py::object fun, py::object forward, py::object inverse, py::object jacobian,
                           py::object rate, double t0, double t1, const input_array<double>& y0,
                           const std::string& method, double dt, std::optional<std::vector<double>> t_eval,
                           std::vector<py::object> invariants, const std::vector<std::string>& invariant_names,
                           int max_halvings) {
    using S = std::vector<double>;
    const std::size_t n = static_cast<std::size_t>(y0.shape(0));
    S x(y0.data(), y0.data() + n);
    // the conservative tableaux, which the registry runs through the system's transform
    std::vector<std::string> available;
    for (const method_info& m : methods_for<python_transformed_system>())
        if (m.family == method_family::transformed) available.emplace_back(m.name);
    const method_info info = resolve_method(method, available, "a transform");
    python_transform tr{std::move(forward), std::move(inverse), std::move(jacobian), std::move(rate), n};
    tr.measure_xi(x);
    const python_transformed_system f{python_rhs<double>(std::move(fun), n), tr};
    const python_invariants<double> invs{std::move(invariants)};
    std::vector<drift_record> drift = named_records<double>(invariant_names);
    const run_request req{t0, t1, dt, std::move(t_eval), max_halvings};
    const component_namer namer{};
    interrupt_check interrupt(true);
    recorded_output<S> out;
    run_report report;
    auto measure = [&](const S& s, bool first) { invs.measure(s, drift, 0, first); };
    with_stepper<python_transformed_system>(
        method, [&](auto stepper) { run_grid(stepper, f, x, req, measure, interrupt, out, report, namer); });
    return result_dict(out, n, report, drift, info);
}

}  // namespace

void init_functions(py::module_& m) {
    m.def("_solve_real", &solve_function<double>, py::arg("fun"), py::arg("t0"), py::arg("t1"), py::arg("y0"),
          py::arg("method"), py::arg("dt"), py::arg("t_eval"), py::arg("invariants"), py::arg("invariant_names"),
          py::arg("max_halvings"), "Integrate a real fun(t, y) on the fixed grid (used by eci.solve).");
    m.def("_solve_complex", &solve_function<std::complex<double>>, py::arg("fun"), py::arg("t0"), py::arg("t1"),
          py::arg("y0"), py::arg("method"), py::arg("dt"), py::arg("t_eval"), py::arg("invariants"),
          py::arg("invariant_names"), py::arg("max_halvings"),
          "Integrate a complex fun(t, y) on the fixed grid (used by eci.solve).");
    m.def("_solve_transformed", &solve_transformed, py::arg("fun"), py::arg("forward"), py::arg("inverse"),
          py::arg("jacobian"), py::arg("rate"), py::arg("t0"), py::arg("t1"), py::arg("y0"), py::arg("method"),
          py::arg("dt"), py::arg("t_eval"), py::arg("invariants"), py::arg("invariant_names"),
          py::arg("max_halvings"), "Integrate fun(t, y) through a user's transform (used by eci.solve).");
}

}  // namespace eci::python

// eci.solve(fun, ..., rtol=, atol=) with a Python fun: the registry's embedded pairs (conventional and conservative)
// for real and complex y, and the transformed embedded engine through a user's transform.
#include <eci/steppers/transformed_embedded_rk.hpp>

#include "adaptive_core.hpp"
#include "module.hpp"
#include "python_system.hpp"

namespace eci::python {

namespace {

template <class T>
using input_array = py::array_t<T, py::array::c_style | py::array::forcecast>;

std::vector<drift_record> records_named(const std::vector<std::string>& names) {
    std::vector<drift_record> r;
    for (const std::string& n : names) r.push_back({n});
    return r;
}

/// The run shared by a plain fun and a transformed one: System is python_rhs<T> or python_transformed_system.
template <class System, class S>
py::dict run_function(const System& f, S& x, const method_info& info, const adaptive_request& req,
                      std::vector<py::object> invariants, const std::vector<std::string>& invariant_names,
                      const component_namer& namer, non_finite_flag& flag) {
    using T = std::ranges::range_value_t<S>;
    const python_invariants<T> invs{std::move(invariants)};
    std::vector<drift_record> drift = records_named(invariant_names);
    interrupt_check interrupt(true);
    recorded_output<S> out;
    adaptive_outcome outcome;
    auto measure = [&](const S& s, bool first) { invs.measure(s, drift, 0, first); };
    // a plain fun runs on its state type (the registry's plain system), a transformed one as the model it is
    using dispatch_on = std::conditional_t<requires { typename System::state_type; }, System, S>;
    with_adaptive_stepper<dispatch_on>(info.name, [&](auto stepper) {
        outcome = run_adaptive_grid(stepper, f, x, req, measure, interrupt, out, &flag);
    });
    throw_if_failed(outcome, namer);
    py::dict d = result_dict(out, std::ranges::size(x), run_report{}, drift, info);
    d["stats"] = adaptive_stats_dict(outcome.stats, outcome.monitor);
    return d;
}

template <class T>
py::dict solve_adaptive(py::object fun, double t0, double t1, const input_array<T>& y0, const std::string& method,
                        double first_step, std::optional<std::vector<double>> t_eval,
                        std::vector<py::object> invariants, const std::vector<std::string>& invariant_names,
                        const py::dict& adaptive) {
    using S = std::vector<T>;
    const std::size_t n = static_cast<std::size_t>(y0.shape(0));
    S x(y0.data(), y0.data() + n);
    const method_info info = resolve_adaptive_method(method, adaptive_method_names<S>(), "fun(t, y)");
    non_finite_flag flag;
    const python_rhs<T> f(std::move(fun), n, &flag);
    const component_namer namer{{}, std::is_same_v<T, std::complex<double>>};
    return run_function(f, x, info, adaptive_request_from(t0, t1, first_step, std::move(t_eval), adaptive),
                        std::move(invariants), invariant_names, namer, flag);
}

py::dict solve_adaptive_transformed(py::object fun, py::object forward, py::object inverse, py::object jacobian,
                                    py::object rate, double t0, double t1, const input_array<double>& y0,
                                    const std::string& method, double first_step,
                                    std::optional<std::vector<double>> t_eval, std::vector<py::object> invariants,
                                    const std::vector<std::string>& invariant_names, const py::dict& adaptive) {
    using S = std::vector<double>;
    const std::size_t n = static_cast<std::size_t>(y0.shape(0));
    S x(y0.data(), y0.data() + n);
    const method_info info =
        resolve_adaptive_method(method, adaptive_method_names<python_transformed_system>(), "a transform");
    python_transform tr{std::move(forward), std::move(inverse), std::move(jacobian), std::move(rate), n};
    tr.measure_xi(x);
    non_finite_flag flag;
    const python_transformed_system f{python_rhs<double>(std::move(fun), n, &flag), tr};
    return run_function(f, x, info, adaptive_request_from(t0, t1, first_step, std::move(t_eval), adaptive),
                        std::move(invariants), invariant_names, component_namer{}, flag);
}

}  // namespace

void init_adaptive_functions(py::module_& m) {
    m.def("_solve_adaptive_real", &solve_adaptive<double>, py::arg("fun"), py::arg("t0"), py::arg("t1"),
          py::arg("y0"), py::arg("method"), py::arg("first_step"), py::arg("t_eval"), py::arg("invariants"),
          py::arg("invariant_names"), py::arg("adaptive"), "Integrate a real fun(t, y) adaptively (eci.solve).");
    m.def("_solve_adaptive_complex", &solve_adaptive<std::complex<double>>, py::arg("fun"), py::arg("t0"),
          py::arg("t1"), py::arg("y0"), py::arg("method"), py::arg("first_step"), py::arg("t_eval"),
          py::arg("invariants"), py::arg("invariant_names"), py::arg("adaptive"),
          "Integrate a complex fun(t, y) adaptively (eci.solve).");
    m.def("_solve_adaptive_transformed", &solve_adaptive_transformed, py::arg("fun"), py::arg("forward"),
          py::arg("inverse"), py::arg("jacobian"), py::arg("rate"), py::arg("t0"), py::arg("t1"), py::arg("y0"),
          py::arg("method"), py::arg("first_step"), py::arg("t_eval"), py::arg("invariants"),
          py::arg("invariant_names"), py::arg("adaptive"),
          "Integrate fun(t, y) adaptively through a user's transform (eci.solve).");
    m.def("_adaptive_methods_real", [] { return adaptive_method_names<std::vector<double>>(); });
    m.def("_adaptive_methods_complex", [] { return adaptive_method_names<std::vector<std::complex<double>>>(); });
    m.def("_adaptive_methods_transformed", [] { return adaptive_method_names<python_transformed_system>(); });
}

}  // namespace eci::python

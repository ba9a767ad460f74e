// eci.solve with a Python fun(t, y): every registry method that runs on any state, fixed steps or adaptive control,
// real or complex y, through a user's transform (the transformed engines), or Kahan's method with jac(t, y). All
// through eci::solve (solve.hpp).
#include <eci/steppers/transformed_embedded_rk.hpp>
#include <eci/steppers/transformed_rk.hpp>

#include "module.hpp"
#include "python_system.hpp"
#include "solve.hpp"

namespace eci::python {

namespace {

template <class T>
using input_array = py::array_t<T, py::array::c_style | py::array::forcecast>;

constexpr std::size_t kahan_max_unknowns = 8;

/// fun(t, y) and jac(t, y) on a fixed-size state: the model Kahan's stepper reaches through model_of. jac sees the
/// time of the evaluation of fun just before it (the step's start, where Kahan's method takes J).
template <std::size_t N>
struct python_jacobian_system {
    using state_type = std::array<double, N>;
    static constexpr bool reports_non_finite_rate = true;
    python_rhs<double> rhs;
    py::object jac;
    mutable double last_t = 0.0;

    void operator()(const state_type& x, state_type& dxdt, double t) const {
        last_t = t;
        const std::vector<double> y(x.begin(), x.end());
        std::vector<double> d(N);
        rhs(y, d, t);
        std::copy(d.begin(), d.end(), dxdt.begin());
    }

    std::array<std::array<double, N>, N> jacobian(const state_type& x) const {
        const py::object r = jac(last_t, to_numpy(std::vector<double>(x.begin(), x.end())));
        const py::array a = py::module_::import("numpy").attr("asarray")(r);
        const auto J = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
        const auto n = py::ssize_t(N);
        if (!J || a.dtype().kind() == 'c' || J.ndim() != 2 || J.shape(0) != n || J.shape(1) != n)
            throw py::value_error("jac(t, y) returned an array of shape " + shape_text(a) + ", expected (" +
                                  std::to_string(N) + ", " + std::to_string(N) + ") (rows: components of fun)");
        std::array<std::array<double, N>, N> out{};
        for (std::size_t i = 0; i < N; ++i)
            for (std::size_t j = 0; j < N; ++j) out[i][j] = J.data()[i * N + j];  // non-finite: the solve fails
        return out;
    }
};

template <std::size_t N>
py::dict solve_kahan_n(py::object fun, py::object jac, const input_array<double>& y0, const std::string& method,
                       const python_request& req, std::vector<py::object> invariants,
                       const std::vector<std::string>& names) {
    using S = std::array<double, N>;
    S x{};
    std::copy(y0.data(), y0.data() + N, x.begin());
    const python_jacobian_system<N> f{python_rhs<double>(std::move(fun), N), std::move(jac)};
    // jac is for Kahan's method alone (eci.solve refuses it with another), so only its stepper is compiled, per N
    return run_python<python_jacobian_system<N>, method_entries::kahan>(
        f, x, method, req, python_extra_invariants<S>(std::move(invariants), names), component_namer{},
        "fun(t, y) with jac", false);
}

template <std::size_t... I>
constexpr auto kahan_table(std::index_sequence<I...>) {
    return std::array{&solve_kahan_n<I + 1>...};
}

/// The quadratic invariants sum_k w[k] |x_k|^2 of the weights, as invariants the run measures (named
/// quadratic_j), each summed with its rounding carried (so that what is measured is the state's drift, not the
/// rounding of a sum of many terms).
template <class S>
void add_weighted_invariants(std::vector<extra_invariant<S>>& out, const quadratic_weights& w) {
    for (std::size_t j = 0; j < w.size(); ++j)
        out.push_back({"quadratic_" + std::to_string(j), [row = w[j]](const S& x) {
                           compensated_sum sum;
                           for (std::size_t k = 0; k < row.size(); ++k) sum.add(row[k] * std::norm(x[k]));
                           return sum.value();
                       }});
}

/// fun(t, y) on a real or complex y, with the quadratic invariants' weights when given (an empty set of rows
/// otherwise: the same runs as a system that declares none, compiled once for both).
template <class T>
py::dict solve_plain(py::object fun, const input_array<T>& y0, const std::string& method, const python_request& req,
                     std::vector<py::object> invariants, const std::vector<std::string>& names,
                     const py::object& weights) {
    using S = std::vector<T>;
    const std::size_t n = static_cast<std::size_t>(y0.shape(0));
    S x(y0.data(), y0.data() + n);
    const component_namer namer{{}, std::is_same_v<T, std::complex<double>>};
    auto extra = python_extra_invariants<S>(std::move(invariants), names);
    quadratic_weights rows;
    if (!weights.is_none()) {
        // checked by eci.solve: a float64 (m, n) array
        const auto w = input_array<double>::ensure(weights);
        rows.assign(static_cast<std::size_t>(w.shape(0)), std::vector<double>(n));
        for (std::size_t j = 0; j < rows.size(); ++j)
            std::copy(w.data() + j * n, w.data() + (j + 1) * n, rows[j].begin());
        add_weighted_invariants(extra, rows);
    }
    const python_weighted_system<T> g{python_rhs<T>(std::move(fun), n), std::move(rows)};
    return run_python<python_weighted_system<T>>(g, x, method, req, std::move(extra), namer, "fun(t, y)", false);
}

/// eci.solve(fun, ...): the one entry point for a Python fun. `transform` is None or (forward, inverse, jacobian,
/// rate); `jac` is Kahan's Jacobian (method kahan) or None.
py::dict solve_function(py::object fun, double t0, double t1, const py::array& y0, const std::string& method,
                        double dt, const py::dict& settings, std::vector<py::object> invariants,
                        const std::vector<std::string>& names, py::object transform, py::object jac,
                        py::object weights) {
    const python_request req = request_from(t0, t1, dt, settings);
    const std::size_t n = static_cast<std::size_t>(y0.shape(0));
    if (!jac.is_none()) {
        if (n == 0 || n > kahan_max_unknowns)
            throw std::invalid_argument("method kahan with a Python fun takes up to " +
                                        std::to_string(kahan_max_unknowns) +
                                        " unknowns (a fixed-size linear solve), not " + std::to_string(n));
        static constexpr auto table = kahan_table(std::make_index_sequence<kahan_max_unknowns>{});
        return table[n - 1](std::move(fun), std::move(jac), input_array<double>::ensure(y0), method, req,
                            std::move(invariants), names);
    }
    if (!transform.is_none()) {
        using S = std::vector<double>;
        if (!req.config.adaptive) {  // fixed steps: the methods that run through the transform
            std::vector<std::string> available;
            for (const method_info& m : methods_for<python_transformed_system>())
                if (m.family == method_family::transformed) available.emplace_back(m.name);
            resolve_named_method(method, available, "a transform");
        }
        const auto y = input_array<double>::ensure(y0);
        S x(y.data(), y.data() + n);
        const py::tuple t = transform.cast<py::tuple>();
        python_transform tr{t[0], t[1], t[2], t[3], n};
        tr.measure_xi(x);
        const python_transformed_system f{python_rhs<double>(std::move(fun), n), tr};
        return run_python<python_transformed_system>(f, x, method, req,
                                                     python_extra_invariants<S>(std::move(invariants), names),
                                                     component_namer{}, "a transform", false);
    }
    if (y0.dtype().kind() == 'c')
        return solve_plain<std::complex<double>>(std::move(fun), input_array<std::complex<double>>::ensure(y0), method,
                                                 req, std::move(invariants), names, weights);
    return solve_plain<double>(std::move(fun), input_array<double>::ensure(y0), method, req, std::move(invariants),
                               names, weights);
}

std::vector<std::string> names_of(const std::vector<method_info>& list) {
    std::vector<std::string> v;
    for (const method_info& m : list) v.emplace_back(m.name);
    return v;
}

}  // namespace

void init_functions(py::module_& m) {
    m.def("_solve_function", &solve_function, py::arg("fun"), py::arg("t0"), py::arg("t1"), py::arg("y0"),
          py::arg("method"), py::arg("dt"), py::arg("settings"), py::arg("invariants"), py::arg("invariant_names"),
          py::arg("transform"), py::arg("jac"), py::arg("quadratic_invariants") = py::none(),
          "Integrate a Python fun(t, y) (used by eci.solve).");
    m.def("_adaptive_methods_real", [] { return names_of(adaptive_methods_for<std::vector<double>>()); });
    m.def("_adaptive_methods_complex", [] { return names_of(adaptive_methods_for<std::vector<std::complex<double>>>()); });
    m.def("_adaptive_methods_transformed", [] { return names_of(adaptive_methods_for<python_transformed_system>()); });
    m.attr("_kahan_max_unknowns") = kahan_max_unknowns;
}

}  // namespace eci::python

// eci.solve(fun, ..., method="kahan", jac=...): Kahan's linearly implicit method on a Python fun with its Jacobian
// jac(t, y) (SciPy's jac), for real states of up to 8 unknowns (the stepper's linear solve is a fixed-size one).
#include <array>
#include <utility>

#include <eci/steppers/kahan.hpp>

#include "module.hpp"
#include "python_system.hpp"

namespace eci::python {

namespace {

constexpr std::size_t kahan_max_unknowns = 8;

/// fun(t, y) and jac(t, y) on a fixed-size state: the model Kahan's stepper reaches through model_of. jac sees the
/// time of the evaluation of fun just before it (the step's start, where Kahan's method takes J).
template <std::size_t N>
struct python_jacobian_system {
    using state_type = std::array<double, N>;
    static constexpr bool checks_finite = true;  ///< throws non_finite_rhs
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

using input_array = py::array_t<double, py::array::c_style | py::array::forcecast>;

template <std::size_t N>
py::dict solve_kahan_n(py::object fun, py::object jac, double t0, double t1, const input_array& y0, double dt,
                       std::optional<std::vector<double>> t_eval, std::vector<py::object> invariants,
                       const std::vector<std::string>& invariant_names, int max_halvings) {
    using S = std::array<double, N>;
    S x{};
    std::copy(y0.data(), y0.data() + N, x.begin());
    const python_jacobian_system<N> f{python_rhs<double>(std::move(fun), N), std::move(jac)};
    const python_invariants<double> invs{std::move(invariants)};
    std::vector<drift_record> drift;
    for (const std::string& n : invariant_names) drift.push_back({n});
    const run_request req{t0, t1, dt, std::move(t_eval), max_halvings};
    interrupt_check interrupt(true);
    recorded_output<S> out;
    run_report report;
    auto measure = [&](const S& s, bool first) { invs.measure({s.begin(), s.end()}, drift, 0, first); };
    kahan<S> stepper;
    run_grid(stepper, f, x, req, measure, interrupt, out, report, component_namer{});
    return result_dict(out, N, report, drift, *find_method("kahan"));
}

template <std::size_t... I>
constexpr auto kahan_table(std::index_sequence<I...>) {
    return std::array{&solve_kahan_n<I + 1>...};
}

py::dict solve_kahan(py::object fun, py::object jac, double t0, double t1, const input_array& y0, double dt,
                     std::optional<std::vector<double>> t_eval, std::vector<py::object> invariants,
                     const std::vector<std::string>& invariant_names, int max_halvings) {
    const std::size_t n = static_cast<std::size_t>(y0.shape(0));
    if (n == 0 || n > kahan_max_unknowns)
        throw std::invalid_argument("method kahan with a Python fun takes up to " +
                                    std::to_string(kahan_max_unknowns) + " unknowns (a fixed-size linear solve), not " +
                                    std::to_string(n));
    static constexpr auto table = kahan_table(std::make_index_sequence<kahan_max_unknowns>{});
    return table[n - 1](std::move(fun), std::move(jac), t0, t1, y0, dt, std::move(t_eval), std::move(invariants),
                        invariant_names, max_halvings);
}

}  // namespace

void init_kahan(py::module_& m) {
    m.def("_solve_kahan", &solve_kahan, py::arg("fun"), py::arg("jac"), py::arg("t0"), py::arg("t1"), py::arg("y0"),
          py::arg("dt"), py::arg("t_eval"), py::arg("invariants"), py::arg("invariant_names"),
          py::arg("max_halvings"), "Integrate fun(t, y) by Kahan's method with jac(t, y) (used by eci.solve).");
    m.attr("_kahan_max_unknowns") = kahan_max_unknowns;
}

}  // namespace eci::python

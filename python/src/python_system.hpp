// Python callables as eci systems: fun(t, y) as a right-hand side, invariants as callables of y, and a user's
// transform (forward, Jacobian or rate, inverse with a hint) for the transformation engine. The GIL is held.
#pragma once

#include <cmath>
#include <complex>
#include <cstddef>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

#include <eci/integrate.hpp>

#include "core.hpp"

namespace eci::python {

/// A fresh NumPy array holding x (a fresh one per call, as SciPy passes: fun may keep it).
template <class T>
py::array_t<T> to_numpy(const std::vector<T>& x) {
    py::array_t<T> a(static_cast<py::ssize_t>(x.size()));
    std::memcpy(a.mutable_data(), x.data(), x.size() * sizeof(T));
    return a;
}

/// The shape of a NumPy array as Python writes it, "(3,)".
inline std::string shape_text(const py::array& a) { return py::str(a.attr("shape")); }

/// r (a value returned by a Python callable when `returned`, else an argument) as a one-dimensional array of T
/// with n entries: TypeError for None, non-numbers or complex values where T is real; ValueError for another shape.
template <class T>
py::array_t<T, py::array::c_style> as_vector(const py::object& r, std::size_t n, std::string_view subject_view,
                                             bool returned, std::string_view like) {
    constexpr bool want_complex = std::is_same_v<T, std::complex<double>>;
    using exact = py::array_t<T, py::array::c_style>;
    auto wrong_shape = [&](const py::array& a) {  // messages are built on the error paths only
        return py::value_error(std::string(subject_view) + (returned ? " returned an array of shape " : " has shape ") +
                               shape_text(a) + ", expected (" + std::to_string(n) + ",) like " + std::string(like));
    };
    if (py::isinstance<exact>(r)) {  // the common case: already float64 (complex128), contiguous
        exact a = py::reinterpret_borrow<exact>(r);
        if (a.ndim() != 1 || static_cast<std::size_t>(a.shape(0)) != n) throw wrong_shape(a);
        return a;
    }
    const std::string subject(subject_view);
    if (r.is_none())
        throw py::type_error(subject + (returned ? " returned None, " : " is None, ") + "expected an array of " +
                             std::to_string(n) + " numbers");
    const py::array a = py::module_::import("numpy").attr("asarray")(r);
    const char kind = a.dtype().kind();
    if (!want_complex && kind == 'c')
        throw py::type_error(subject + (returned ? " returned complex values but y0 is real; pass a complex y0 "
                                                   "(e.g. y0.astype(complex)) to integrate complex modes"
                                                 : " is complex but the state is real"));
    const bool numeric = kind == 'f' || kind == 'i' || kind == 'u' || kind == 'b' || kind == 'c';
    if (!numeric)
        throw py::type_error(subject + (returned ? " returned values of dtype " : " has dtype ") +
                             std::string(py::str(a.dtype())) + ", expected " + (want_complex ? "complex" : "real") +
                             " numbers");
    if (a.ndim() != 1 || static_cast<std::size_t>(a.shape(0)) != n) throw wrong_shape(a);
    // Cast as SciPy's np.asarray(fun(t, y), dtype) does: also from a wider type (long double, rounded to double),
    // which a safe cast refuses, returning a null array (read, it crashed the interpreter). Complex values for a
    // real state and non-numbers were refused above.
    const auto c = py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(a);
    if (!c)
        throw py::type_error(subject + (returned ? " returned values of dtype " : " has dtype ") +
                             std::string(py::str(a.dtype())) + ", which cannot be converted to " +
                             (want_complex ? "complex" : "real") + " double precision numbers");
    return py::reinterpret_borrow<exact>(c);
}

/// fun(t, y) as an eci system over std::vector<T>. A non-finite value is reported as eci::non_finite_rate: the
/// run's drivers fail that attempt (retried smaller, or rejected) and count it as the fun's.
template <class T>
class python_rhs {
   public:
    static constexpr bool reports_non_finite_rate = true;

    python_rhs(py::object fun, std::size_t n) : fun_(std::move(fun)), n_(n) {}

    void operator()(const std::vector<T>& x, std::vector<T>& dxdt, double t) const {
        py::array_t<T> y = to_numpy(x);
        py::float_ time(t);
        PyObject* args[2] = {time.ptr(), y.ptr()};
        PyObject* raw = PyObject_Vectorcall(fun_.ptr(), args, 2, nullptr);
        if (!raw) throw py::error_already_set();
        const py::object r = py::reinterpret_steal<py::object>(raw);
        const auto a = as_vector<T>(r, n_, "fun(t, y)", true, "y0");
        const T* v = a.data();
        constexpr std::size_t per = sizeof(T) / sizeof(double);
        const double* d = reinterpret_cast<const double*>(v);
        for (std::size_t i = 0; i < n_ * per; ++i)
            if (!std::isfinite(d[i])) [[unlikely]]
                throw non_finite_rate{i, d[i]};
        std::memcpy(dxdt.data(), v, n_ * sizeof(T));
    }

   private:
    py::object fun_;
    std::size_t n_;
};

/// Invariants given as Python callables of y, each returning a real number.
template <class T>
struct python_invariants {
    std::vector<py::object> functions;

    void measure(const std::vector<T>& x, std::vector<invariant_record>& records, std::size_t first_record,
                 bool first) const {
        if (functions.empty()) return;
        py::array_t<T> y = to_numpy(x);
        for (std::size_t j = 0; j < functions.size(); ++j) {
            const py::object v = functions[j](y);
            double value;
            try {
                value = v.cast<double>();
            } catch (const py::cast_error&) {
                throw py::type_error("invariant " + records[first_record + j].name + " returned " +
                                     std::string(py::repr(v)) + ", expected a real number");
            }
            records[first_record + j].record(value, first);
        }
    }
};

/// A user's transform xi = T(x) for transformed_rk (paper §III.D): forward(x) -> xi; the rate dxi/dt at x either
/// as rate(x, dxdt) or as jacobian(x) @ dxdt; inverse(xi, hint) -> x on the branch of the hint, or None when xi is
/// not invertible (the step fails and is retried smaller), or (x, iterations) to count an iterative solve.
struct python_transform {
    using state_type = std::vector<double>;
    using xi_type = std::vector<double>;

    py::object forward, inverse, jacobian, rate;
    std::size_t n = 0;  ///< unknowns
    std::size_t m = 0;  ///< xi components (see measure_xi)

    /// Fixes m from forward(y0), checking that it is a non-empty one-dimensional array.
    void measure_xi(const state_type& y0) {
        const py::array a = py::array::ensure(forward(to_numpy(y0)));
        if (!a || a.ndim() != 1 || a.shape(0) == 0)
            throw py::value_error("transform forward(x) must return a non-empty one-dimensional array");
        m = static_cast<std::size_t>(a.shape(0));
    }

    void to_xi(const state_type& x, xi_type& xi) const {
        copy_checked(as_vector<double>(forward(to_numpy(x)), m, "transform forward(x)", true, "forward(y0)"), xi,
                     "forward(x)");
    }

    void xi_rate(const state_type& x, const state_type& dxdt, xi_type& out) const {
        out.resize(m);
        if (!rate.is_none()) {
            copy_checked(as_vector<double>(rate(to_numpy(x), to_numpy(dxdt)), m, "transform rate(x, dxdt)", true, "xi"),
                         out, "rate(x, dxdt)");
            return;
        }
        const py::object r = jacobian(to_numpy(x));
        const auto J = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(r);
        if (!J || J.ndim() != 2 || static_cast<std::size_t>(J.shape(0)) != m ||
            static_cast<std::size_t>(J.shape(1)) != n)
            throw py::value_error("transform jacobian(x) must return an array of shape (" + std::to_string(m) + ", " +
                                  std::to_string(n) + ") (xi components by unknowns)");
        const double* j = J.data();
        for (std::size_t a = 0; a < m; ++a) {
            double s = 0.0;
            for (std::size_t b = 0; b < n; ++b) s += j[a * n + b] * dxdt[b];
            out[a] = s;
        }
    }

    step_result from_xi(const xi_type& xi, const state_type& hint, state_type& x, solver_stats& stats) const {
        py::object r = inverse(to_numpy(xi), to_numpy(hint));
        if (r.is_none()) return step_result::failure(0);
        if (py::isinstance<py::tuple>(r)) {
            const py::tuple tup = r.cast<py::tuple>();
            if (tup.size() != 2)
                throw py::value_error("transform inverse(xi, hint) must return x, (x, iterations) or None");
            stats.record(tup[1].cast<int>());
            r = tup[0];
            if (r.is_none()) return step_result::failure(0);
        }
        const auto a = as_vector<double>(r, n, "transform inverse(xi, hint)", true, "y0");
        x.resize(n);
        const double* v = a.data();
        for (std::size_t i = 0; i < n; ++i) {
            if (!std::isfinite(v[i])) return step_result::failure(i);
            x[i] = v[i];
        }
        return step_result::success();
    }

   private:
    static void copy_checked(const py::array_t<double, py::array::c_style>& a, xi_type& out, const char*) {
        out.assign(a.data(), a.data() + a.shape(0));
    }
};

/// fun(t, y) with a user's transform: the system transformed_rk and transformed_embedded_rk step (a model with a
/// linearizing transform).
struct python_transformed_system {
    using state_type = std::vector<double>;
    static constexpr bool reports_non_finite_rate = true;
    python_rhs<double> rhs;
    python_transform transform;

    void operator()(const state_type& x, state_type& dxdt, double t) const { rhs(x, dxdt, t); }
    python_transform linearizing_transform() const { return transform; }
};

/// fun(t, y) with the quadratic invariants sum_k W[j][k] |y_k|^2 it keeps, declared by the user
/// (eci.solve(..., quadratic_invariants=W)): the conservative fixed-step engines take the weights for their remedy
/// of negative radicands (as a model's quadratic_invariant_weights()), instead of halving the step. No rows: a fun
/// that declares none (the remedy then has no weights, and halves), run by the same compiled code.
template <class T>
struct python_weighted_system {
    using state_type = std::vector<T>;
    static constexpr bool reports_non_finite_rate = true;
    python_rhs<T> rhs;
    quadratic_weights weights;

    void operator()(const state_type& x, state_type& dxdt, double t) const { rhs(x, dxdt, t); }
    quadratic_weights quadratic_invariant_weights() const { return weights; }
};

}  // namespace eci::python

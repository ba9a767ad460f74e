// eci._EmbeddedStepper: one of the registry's embedded pairs, step by step, for the OdeSolver classes of eci.scipy.
// SciPy's solve_ivp owns the loop (events, t_eval, direction, the step-size controller in Python); this object
// owns the state and the engine of include/eci/steppers/embedded_rk.hpp: attempt (stages, candidate, error norm),
// accept, and the dense output of the accepted step, snapshotted so that it stays valid after later steps.
//
// Depends only on the library's engine and registry (not on the run layer behind eci.solve).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <complex>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <eci/adaptive.hpp>
#include <eci/registry.hpp>
#include <eci/solve.hpp>
#include <eci/steppers/embedded_rk.hpp>

#include "module.hpp"

namespace eci::python {

namespace py = pybind11;

namespace {

template <class T>
py::array_t<T> fresh_array(const std::vector<T>& x) {
    py::array_t<T> a(static_cast<py::ssize_t>(x.size()));
    if (!x.empty()) std::memcpy(a.mutable_data(), x.data(), x.size() * sizeof(T));
    return a;
}

/// What fun(t, y) returned, as n values of T: None, non-numbers, complex values for a real state and a wrong shape
/// are errors with one line naming the problem (SciPy would fail later, inside NumPy, less clearly).
template <class T>
void copy_returned(const py::object& r, std::size_t n, T* out) {
    using exact = py::array_t<T, py::array::c_style>;
    if (py::isinstance<exact>(r)) {
        const exact a = py::reinterpret_borrow<exact>(r);
        if (a.ndim() == 1 && static_cast<std::size_t>(a.shape(0)) == n) {
            if (n) std::memcpy(out, a.data(), n * sizeof(T));
            return;
        }
    }
    if (r.is_none()) throw py::type_error("fun(t, y) returned None, expected " + std::to_string(n) + " numbers");
    const py::array a = py::module_::import("numpy").attr("asarray")(r);
    const char kind = a.dtype().kind();
    constexpr bool want_complex = std::is_same_v<T, std::complex<double>>;
    if (!want_complex && kind == 'c')
        throw py::type_error("fun(t, y) returned complex values but y0 is real; pass a complex y0 to integrate "
                             "complex values");
    if (!(kind == 'f' || kind == 'i' || kind == 'u' || kind == 'b' || kind == 'c'))
        throw py::type_error("fun(t, y) returned values of dtype " + std::string(py::str(a.dtype())) +
                             ", expected numbers");
    if (static_cast<std::size_t>(a.size()) != n || a.ndim() > 1)
        throw py::value_error("fun(t, y) returned an array of shape " + std::string(py::str(a.attr("shape"))) +
                              ", expected (" + std::to_string(n) + ",) like y0");
    const auto c = py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(a);
    if (n) std::memcpy(out, c.data(), n * sizeof(T));
}

/// fun(t, y) as an eci system, counting its calls. A derivative already known at (t0, y0) (SciPy's solver evaluates
/// it for its initial-step rule) is handed out once instead of calling fun again.
template <class T>
struct counted_rhs {
    py::object fun;
    std::shared_ptr<std::uint64_t> calls;  // shared with the dense outputs, which may outlive the solver
    bool have_seed = false;
    double seed_t = 0.0;
    std::vector<T> seed_x, seed_f;

    void operator()(const std::vector<T>& x, std::vector<T>& dxdt, double t) {
        dxdt.resize(x.size());
        if (have_seed) {
            have_seed = false;
            if (t == seed_t && x == seed_x) {
                dxdt = seed_f;
                return;
            }
        }
        py::array_t<T> y = fresh_array(x);  // a fresh array per call, as SciPy passes: fun may keep it
        py::float_ time(t);
        PyObject* args[2] = {time.ptr(), y.ptr()};
        PyObject* raw = PyObject_Vectorcall(fun.ptr(), args, 2, nullptr);
        if (!raw) throw py::error_already_set();
        ++*calls;
        copy_returned<T>(py::reinterpret_steal<py::object>(raw), x.size(), dxdt.data());
    }
};

/// A tolerance as one value, or one per component of y (n values; a complex component's two parts share one).
struct tolerance {
    double scalar = 0.0;
    std::vector<double> each;  // per real unknown, empty for a scalar
};

tolerance tolerance_from(const py::object& v, std::size_t n, std::size_t per, const char* name) {
    const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(v);
    if (!a) throw py::type_error(std::string(name) + " must be a number or one number per component of y");
    tolerance tol;
    if (a.ndim() == 0) {
        tol.scalar = *a.data();
        return tol;
    }
    if (a.ndim() != 1 || static_cast<std::size_t>(a.shape(0)) != n)
        throw py::value_error(std::string(name) + " has shape " + std::string(py::str(a.attr("shape"))) +
                              ", expected a number or (" + std::to_string(n) + ",)");
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t p = 0; p < per; ++p) tol.each.push_back(a.data()[i]);
    return tol;
}

/// The dense output of one accepted step: a copy of the engine as it was after the step (the stages and the
/// step's start are in it), the step's end state, and fun (for the points the interpolant cannot give).
class dense_step_base {
   public:
    virtual ~dense_step_base() = default;
    virtual py::array evaluate(const py::array_t<double, py::array::forcecast>& t) = 0;
    std::uint64_t landed = 0;   ///< points given by a step from the step's start instead (see evaluate)
    std::uint64_t clamped = 0;  ///< points where that step failed too, a negative psi^2 set to 0
};

template <class St, class T>
class dense_step : public dense_step_base {
   public:
    dense_step(const St& stepper, const std::vector<T>& x1, double t0, double h, const counted_rhs<T>& f)
        : stepper_(stepper), x1_(x1), t0_(t0), h_(h) {
        f_.fun = f.fun;
        f_.calls = f.calls;  // not the seed: that was for the first step only
    }

    // A conservative interpolant whose psi^2 comes out negative in some component (an interpolation error near a
    // zero of psi) cannot give that point; as eci's own driver does, a step of the engine lands on it instead: from
    // the step's start, exactly conservative and as accurate as the steps (it is shorter), at the cost of its
    // stages (calls of fun, counted in nfev).
    py::array evaluate(const py::array_t<double, py::array::forcecast>& t) override {
        const std::size_t n = x1_.size();
        const std::size_t m = static_cast<std::size_t>(t.size());
        if (t.ndim() > 1) throw py::value_error("`t` must be a float or a 1-D array.");
        py::array_t<T> out = t.ndim() == 0 ? py::array_t<T>(static_cast<py::ssize_t>(n))
                                           : py::array_t<T>({static_cast<py::ssize_t>(n), static_cast<py::ssize_t>(m)});
        T* o = out.mutable_data();
        std::vector<T> point;
        for (std::size_t j = 0; j < m; ++j) {
            const double theta = (t.data()[j] - t0_) / h_;
            const step_result r = stepper_.interpolate(x1_, theta, point);
            if (!r.ok) land(t.data()[j] - t0_, point);
            for (std::size_t i = 0; i < n; ++i) o[i * m + j] = point[i];  // column j (m == 1 for a scalar t)
        }
        return out;
    }

   private:
    void land(double dt, std::vector<T>& point) {
        St fresh = stepper_;
        fresh.reset();  // its carried first stage belongs to the step's end, not its start
        std::vector<T> y = stepper_.step_start();
        if (dt != 0.0 && fresh.attempt(f_, y, t0_, dt).ok) {
            fresh.accept(y);
            point = std::move(y);
            ++landed;
            return;
        }
        // Not even that (a shorter step can fail where the longer one did not): the nearest point with psi^2 >= 0,
        // psi = 0 in the failed components, off the invariants by the negative excess only.
        for (double& v : reals(point))
            if (!(v == v)) v = 0.0;
        ++clamped;
    }

    St stepper_;
    std::vector<T> x1_;
    double t0_, h_;
    counted_rhs<T> f_;
};

class stepper_base {
   public:
    virtual ~stepper_base() = default;
    virtual py::tuple attempt(double t, double h) = 0;
    virtual py::array accept() = 0;
    virtual std::unique_ptr<dense_step_base> dense(double t_old, double t) = 0;
    virtual py::array state() const = 0;
    std::uint64_t calls() const { return *calls_; }

   protected:
    std::shared_ptr<std::uint64_t> calls_ = std::make_shared<std::uint64_t>(0);
};

template <class St, class T>
class stepper_impl : public stepper_base {
   public:
    stepper_impl(py::object fun, const py::array& y0, double t0, const py::object& f0, const py::object& rtol,
                 const py::object& atol) {
        constexpr std::size_t per = sizeof(T) / sizeof(double);
        const auto y = py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(y0);
        x_.assign(y.data(), y.data() + y.size());
        const std::size_t n = x_.size();
        rtol_ = tolerance_from(rtol, n, per, "rtol");
        atol_ = tolerance_from(atol, n, per, "atol");
        weights_.rtol = rtol_.scalar;
        weights_.atol = atol_.scalar;
        weights_.rtol_each = rtol_.each.empty() ? nullptr : rtol_.each.data();
        weights_.atol_each = atol_.each.empty() ? nullptr : atol_.each.data();
        f_.fun = std::move(fun);
        f_.calls = calls_;
        if (!f0.is_none()) {
            f_.seed_x = x_;
            f_.seed_t = t0;
            f_.seed_f.resize(n);
            copy_returned<T>(f0, n, f_.seed_f.data());
            f_.have_seed = true;
        }
    }

    py::tuple attempt(double t, double h) override {
        const attempt_result r = stepper_.attempt(f_, x_, t, h, &weights_);
        t_attempt_ = t;
        return py::make_tuple(r.ok, r.ok ? r.error : std::nan(""), r.component);
    }

    py::array accept() override {
        stepper_.accept(x_);
        t_start_ = t_attempt_;
        return fresh_array(x_);
    }

    std::unique_ptr<dense_step_base> dense(double t_old, double t) override {
        stepper_.prepare_dense(f_, x_, t);  // non-FSAL pairs: f at the new state, reused by the next attempt
        return std::make_unique<dense_step<St, T>>(stepper_, x_, t_old, t - t_old, f_);
    }

    py::array state() const override { return fresh_array(x_); }

   private:
    St stepper_{};
    std::vector<T> x_;
    counted_rhs<T> f_;
    tolerance rtol_, atol_;
    error_weights weights_;
    double t_attempt_ = 0.0, t_start_ = 0.0;
};

/// Calls fn(Entry*) for every registry entry that is an embedded pair running on a plain system of T.
template <class T, class Fn>
void for_each_pair(Fn&& fn) {
    for_each_method_entry([&]<class Entry>(Entry*) {
        if constexpr (adaptive_runs_on<Entry, std::vector<T>>) fn(static_cast<Entry*>(nullptr));
    });
}

std::unique_ptr<stepper_base> make_stepper(const std::string& method, py::object fun, double t0, const py::array& y0,
                                           const py::object& f0, const py::object& rtol, const py::object& atol) {
    std::unique_ptr<stepper_base> out;
    auto build = [&]<class T>(T*) {
        for_each_pair<T>(
            [&]<class Entry>(Entry*) {
                if (out || Entry::info.name != method) return;
                using St = adaptive_stepper_for<Entry, std::vector<T>>;
                // a conservative pair steps squares: a state whose squares under- or overflow is refused as
                // eci.solve refuses it (every step failed instead, "a negative psi^2 or a non-finite value")
                if constexpr (St::is_conservative) {
                    const auto y = py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(y0);
                    eci::detail::check_conservative_scale(std::vector<T>(y.data(), y.data() + y.size()),
                                                          Entry::info.name);
                }
                out = std::make_unique<stepper_impl<St, T>>(
                    std::move(fun), y0, t0, f0, rtol, atol);
            });
    };
    if (y0.dtype().kind() == 'c')
        build(static_cast<std::complex<double>*>(nullptr));
    else
        build(static_cast<double*>(nullptr));
    if (!out) {
        std::string names;
        for_each_pair<double>(
            [&]<class Entry>(Entry*) { names += (names.empty() ? "" : ", ") + std::string(Entry::info.name); });
        throw py::value_error("unknown embedded pair '" + method + "' (eci's embedded pairs: " + names + ")");
    }
    return out;
}

/// Each embedded pair of the registry: name, orders, whether conservative, the tableau (SciPy's A, B, C and
/// E = b - bhat), FSAL and its dense output.
py::list embedded_pairs() {
    py::list l;
    for_each_pair<double>(
        [&]<class Entry>(Entry*) {
            using St = adaptive_stepper_for<Entry, std::vector<double>>;
            constexpr const auto& tab = Entry::tableau;
            constexpr std::size_t s = std::remove_cvref_t<decltype(tab)>::stages;
            py::array_t<double> A({static_cast<py::ssize_t>(s), static_cast<py::ssize_t>(s)});
            py::array_t<double> B(s), C(s), E(s);
            for (std::size_t i = 0; i < s; ++i) {
                for (std::size_t j = 0; j < s; ++j) A.mutable_data()[i * s + j] = tab.a[i][j];
                B.mutable_data()[i] = tab.b[i];
                C.mutable_data()[i] = tab.c[i];
                E.mutable_data()[i] = tab.b[i] - tab.bhat[i];
            }
            py::dict d;
            d["name"] = std::string(Entry::info.name);
            d["description"] = std::string(Entry::info.description);
            d["order"] = St::order;
            d["error_estimator_order"] = St::embedded_order;
            d["conservative"] = St::is_conservative;
            d["fsal"] = St::first_same_as_last;
            d["continuous_extension"] = St::has_continuous_extension;
            d["dense_matches_steps"] = St::dense_matches_steps;
            d["stages"] = s;
            d["A"] = A;
            d["B"] = B;
            d["C"] = C;
            d["E"] = E;
            l.append(d);
        });
    return l;
}

}  // namespace

void init_scipy_stepper(py::module_& m) {
    py::class_<dense_step_base>(m, "_DenseStep", "The dense output of one accepted step (eci.scipy).")
        .def("__call__", &dense_step_base::evaluate, py::arg("t"),
             "y at the times t (a number: shape (n,); a 1-D array: (n, len(t)))")
        .def_readonly("landed", &dense_step_base::landed,
                      "points where a conservative interpolant's psi^2 came out negative: a step landed on them")
        .def_readonly("clamped", &dense_step_base::clamped,
                      "points where that step failed too: the negative psi^2 set to 0");
    py::class_<stepper_base>(m, "_EmbeddedStepper", "An embedded pair step by step (eci.scipy's solvers).")
        .def("attempt", &stepper_base::attempt, py::arg("t"), py::arg("h"),
             "Attempt a step of h from the state at t: (ok, error norm, component). The state is not changed.")
        .def("accept", &stepper_base::accept, "Make the last attempt's candidate the state; returns it.")
        .def("dense", &stepper_base::dense, py::arg("t_old"), py::arg("t"),
             "The dense output of the accepted step from t_old to t.")
        .def_property_readonly("y", &stepper_base::state, "the current state (a copy)")
        .def_property_readonly("calls", &stepper_base::calls, "calls of fun so far (dense outputs' included)");
    m.def("_embedded_stepper", &make_stepper, py::arg("method"), py::arg("fun"), py::arg("t0"), py::arg("y0"),
          py::arg("f0"), py::arg("rtol"), py::arg("atol"),
          "The engine of eci's embedded pair `method` on fun(t, y) from y0 at t0 (f0 = fun(t0, y0) or None).");
    m.def("_embedded_pairs", &embedded_pairs, "eci's embedded pairs with their tableaux (eci.scipy).");
}

}  // namespace eci::python

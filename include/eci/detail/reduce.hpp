// The hook through which a model spread over several processes (eci::spectral::flow2d on an MPI communicator) makes
// a stepper's decisions global: the steppers sum and compare over their own part of the state, and every sum or
// decision that concerns the whole state (a negative radicand anywhere, the remedy's defect and Gram sums, a
// non-finite update) is passed through the model's reduce_sums / reduce_max before it is used. A model on one
// process declares neither, and for it nothing changes: the hook is empty and costs a test of a null pointer.
#pragma once

#include <cstddef>
#include <span>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "../concepts.hpp"

namespace eci::detail {

/// A model whose state is spread over processes: reduce_sums(v) replaces each v[i] by its sum over every process
/// (in an order fixed for a given process count, so a run repeats bit for bit) and reduce_max(v) by its maximum;
/// both are collective (every process calls them at the same point with the same v.size()). F may be a wrapper
/// of the model (the drivers' evaluation counter): the model is found through model_of.
template <class F>
concept distributed_model = requires(const F& f, std::span<double> v) {
    model_of(f).reduce_sums(v);
    model_of(f).reduce_max(v);
};

/// The reductions of a model, type-erased so that a stepper's non-template helpers can call them; empty (every
/// call a no-op) for a model on one process.
struct reducer {
    const void* model = nullptr;
    void (*sums)(const void*, std::span<double>) = nullptr;
    void (*maxes)(const void*, std::span<double>) = nullptr;

    explicit operator bool() const { return sums != nullptr; }
    void sum(std::span<double> v) const {
        if (sums) sums(model, v);
    }
    void max(std::span<double> v) const {
        if (maxes) maxes(model, v);
    }
    /// Sums over every process, in one collective, each of `parts` in place: a double& or a std::span<double>,
    /// so that the quantities one decision needs travel together (collective when the reducer is not empty).
    template <class... Parts>
    void sum_all(Parts&&... parts) const {
        if (!sums) return;
        std::vector<double> all;
        all.reserve((size_of(parts) + ...));
        (append(all, parts), ...);
        sums(model, all);
        std::size_t j = 0;
        (extract(all, j, parts), ...);
    }
    /// Whether `b` holds on any process (collective when the reducer is not empty).
    bool any(bool b) const {
        if (!sums) return b;
        double v = b ? 1.0 : 0.0;
        sums(model, {&v, 1});
        return v != 0.0;
    }

private:
    static std::size_t size_of(const double&) { return 1; }
    static std::size_t size_of(std::span<double> v) { return v.size(); }
    static void append(std::vector<double>& all, double v) { all.push_back(v); }
    static void append(std::vector<double>& all, std::span<double> v) { all.insert(all.end(), v.begin(), v.end()); }
    static void extract(const std::vector<double>& all, std::size_t& j, double& v) { v = all[j++]; }
    static void extract(const std::vector<double>& all, std::size_t& j, std::span<double> v) {
        for (double& e : v) e = all[j++];
    }

public:
    template <class F>
    static reducer of(const F& system) {
        if constexpr (distributed_model<F>) {
            const auto& f = model_of(system);
            using M = std::remove_cvref_t<decltype(f)>;
            // a model that can be spread but is not (spread() false: one process) is a serial model
            if constexpr (requires { bool(f.spread()); })
                if (!f.spread()) return {};
            return {&f, [](const void* m, std::span<double> v) { static_cast<const M*>(m)->reduce_sums(v); },
                    [](const void* m, std::span<double> v) { static_cast<const M*>(m)->reduce_max(v); }};
        } else {
            return {};
        }
    }
};

/// For a computation whose sums and decisions are over this process's unknowns alone (the embedded pairs' error
/// norm and first step): throws std::invalid_argument, naming `what`, when f's state is spread over processes,
/// on every process alike (spread() is the same on all) and before any collective, so none is left waiting.
template <class F>
void require_one_process(const F& f, const char* what) {
    if constexpr (distributed_model<F>)
        if (reducer::of(f))
            throw std::invalid_argument(std::string(what) +
                                        " run on a state held by one process, and this state is spread over "
                                        "processes: take a fixed-step method (rk4, c-rk4, ...), whose decisions are "
                                        "taken over all of them");
}

}  // namespace eci::detail

// The hook through which a model that runs on several threads (eci::spectral::flow2d) lends them to a stepper's
// element-wise passes: the stage combinations, the finishing passes, the finiteness checks, the remedy's rescale.
// A model without it (every ODE model) runs them as before: one range [0, n) on the calling thread, the same loop.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <type_traits>

#include "../concepts.hpp"

namespace eci::detail {

/// The most ranges a model splits a pass into (a stepper keeps per-range results on the stack).
inline constexpr int max_ranges = 64;

/// A model that splits loops over its threads: range_threads() says into how many ranges at most (1 ..
/// max_ranges), for_ranges(n, body) calls body(i0, i1, r) on contiguous ranges [i0, i1) that together cover
/// 0 .. n - 1 in order (range r starts where range r - 1 ends; r < range_threads()), possibly concurrently, and
/// returns when all are done. For a given n and thread count the split is always the same, so that passes whose
/// per-range results are combined in range order repeat bit for bit. Spread over processes, n is this process's share.
template <class F>
concept splits_ranges = requires(const F& f, std::size_t n) {
    { model_of(f).range_threads() } -> std::convertible_to<int>;
    model_of(f).for_ranges(n, [](std::size_t, std::size_t, int) {});
};

/// A model's for_ranges, type-erased so that a stepper's non-template helpers can call it; empty (one range on the
/// calling thread) for a model without it or on one thread.
struct splitter {
    const void* model = nullptr;
    void (*run)(const void*, std::size_t, void (*)(void*, std::size_t, std::size_t, int), void*) = nullptr;
    int threads = 1;

    /// body(i0, i1, r) over the model's ranges of 0 .. n - 1; body(0, n, 0) when empty.
    template <class Body>
    void for_ranges(std::size_t n, Body&& body) const {
        if (threads <= 1) {
            body(std::size_t(0), n, 0);
            return;
        }
        using B = std::remove_reference_t<Body>;
        run(model, n,
            [](void* c, std::size_t i0, std::size_t i1, int r) { (*static_cast<B*>(c))(i0, i1, r); },
            const_cast<void*>(static_cast<const void*>(&body)));
    }

    /// The sum, in range order, of per_range(i0, i1) over the model's ranges of 0 .. n - 1: the element-wise passes'
    /// counts of failures (a double, or a struct of them with +=), which are whole numbers, so that any split gives
    /// the same sum.
    /// On one range it is per_range(0, n) itself: a small system's step calls it a few times, and summing all
    /// max_ranges slots (64 dependent additions, and zeroing them) cost more than the step (three-wave PC: 72 against
    /// 12 ns for odeint's Heun).
    template <class PerRange>
    auto count(std::size_t n, PerRange&& per_range) const {
        using T = decltype(per_range(std::size_t(0), n));
        if (threads <= 1) return per_range(std::size_t(0), n);
        std::array<T, max_ranges> part;
        const std::size_t used = std::size_t(threads);
        std::fill_n(part.begin(), used, T{});
        for_ranges(n, [&](std::size_t i0, std::size_t i1, int r) { part[std::size_t(r)] = per_range(i0, i1); });
        T total{};
        for (std::size_t r = 0; r < used; ++r) total += part[r];
        return total;
    }

    template <class F>
    static splitter of(const F& system) {
        if constexpr (splits_ranges<F>) {
            const auto& m = model_of(system);
            using M = std::remove_cvref_t<decltype(m)>;
            const int threads = std::clamp(int(m.range_threads()), 1, max_ranges);
            if (threads == 1) return {};
            return {&m,
                    [](const void* mp, std::size_t n, void (*fn)(void*, std::size_t, std::size_t, int), void* ctx) {
                        static_cast<const M*>(mp)->for_ranges(
                            n, [&](std::size_t i0, std::size_t i1, int r) { fn(ctx, i0, i1, r); });
                    },
                    threads};
        } else {
            return {};
        }
    }
};

}  // namespace eci::detail

// The conventional explicit Runge-Kutta engine: one loop structure that runs any Butcher tableau.
// Euler (eq. 7), the predictor-corrector (Heun, eq. 18), the midpoint rule and RK4 are its instances.
#pragma once

#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <utility>

#include "../concepts.hpp"
#include "../detail/ranges.hpp"
#include "../detail/reduce.hpp"
#include "../detail/simd.hpp"
#include "../detail/state_ops.hpp"
#include "../tableaus.hpp"

namespace eci {

namespace detail {

// The element-wise passes below are compiled twice, for the baseline (SSE2) and for AVX2, and the AVX2 copy is taken
// at run time on a processor that has it and a range of at least wide_pass elements: twice the lanes, so half the
// instructions per element. No FMA in either (AVX2 alone does not enable it, so nothing is contracted): the same IEEE
// operations in the same order, the same bits. On 3e6 independent triads (bench/step_bench.cpp, paired against
// odeint's Heun, whose loops are the baseline's) PC's step went from 1.03-1.05 to 0.97-0.99 of odeint's: even a pass
// that streams from memory lost ~3 % to the baseline loop's instruction count (the finiteness test's two operations
// per vector were the difference).
inline constexpr std::size_t wide_pass = 64;

/// A state of a few unknowns, fixed at compile time below wide_pass (the dispatchers below would never take their
/// wide pass): the engines take the always-inlined bodies directly (combine_stages_for, combine_finite_over_for).
/// Through the dispatchers, which every state type of a tableau shares, a translation unit that steps several
/// systems kept them out of line, and a three-wave RK4 step taken one call at a time cost 70 ns against 20
/// (bench/step_bench.cpp, three_wave/rk4).
template <class S>
concept narrow_state = small_real_array<S> && (std::tuple_size<S>::value < wide_pass);

/// out = x + dt * sum_j a[j] k_j over the stages J; zero coefficients are dropped at compile time.
template <auto a, std::size_t... J>
[[gnu::always_inline]] inline void combine_stages_body(double* out, const double* x,
                                                       const std::array<const double*, sizeof...(J)>& k, double dt,
                                                       std::size_t n, std::index_sequence<J...>) {
    const std::array<double, sizeof...(J)> w{(dt * a[J])...};
    for (std::size_t i = 0; i < n; ++i) {
        double acc = x[i];
        ((a[J] != 0.0 ? (acc += w[J] * k[J][i], 0) : 0), ...);
        out[i] = acc;
    }
}
#if ECI_DETAIL_X86_SIMD
template <auto a, std::size_t... J>
__attribute__((target("avx2"))) void combine_stages_avx2(double* out, const double* x,
                                                         const std::array<const double*, sizeof...(J)>& k, double dt,
                                                         std::size_t n, std::index_sequence<J...> js) {
    combine_stages_body<a>(out, x, k, dt, n, js);
}
#endif
template <auto a, std::size_t... J>
void combine_stages(double* out, const double* x, const std::array<const double*, sizeof...(J)>& k, double dt,
                    std::size_t n, std::index_sequence<J...> js) {
#if ECI_DETAIL_X86_SIMD
    if (n >= wide_pass && cpu_has_avx2()) return combine_stages_avx2<a>(out, x, k, dt, n, js);
#endif
    combine_stages_body<a>(out, x, k, dt, n, js);
}

/// combine_stages written over stage derivative `io` (k_Out, read through `io` and overwritten element by element),
/// that also reports whether every result is finite, in the same pass (an OR of the bits of acc - acc, which
/// vectorizes: non_finite_diff, two operations per vector where non_finite_bit's three cost eci's PC 1.5 % against
/// odeint's Heun on 3e3 unknowns in cache): the conventional step's blow-up check costs no second pass. k_Out is read
/// through the pointer that is written, so the compiler sees no overlap to check for and vectorizes the loop.
template <auto a, std::size_t Out, std::size_t... J>
[[gnu::always_inline]] inline bool combine_finite_over_body(double* io, const double* x,
                                                            const std::array<const double*, sizeof...(J)>& k,
                                                            double dt, std::size_t n, std::index_sequence<J...>) {
    static_assert(Out < sizeof...(J) && a[Out] != 0.0, "the update overwrites a stage derivative it reads");
    const std::array<double, sizeof...(J)> w{(dt * a[J])...};
    std::uint64_t bad = 0;
    for (std::size_t i = 0; i < n; ++i) {
        double acc = x[i];
        ((a[J] != 0.0 ? (acc += w[J] * (J == Out ? io[i] : k[J][i]), 0) : 0), ...);
        io[i] = acc;
        bad |= non_finite_diff(acc);
    }
    return none_non_finite_diff(bad);
}
#if ECI_DETAIL_X86_SIMD
template <auto a, std::size_t Out, std::size_t... J>
__attribute__((target("avx2"))) bool combine_finite_over_avx2(double* io, const double* x,
                                                              const std::array<const double*, sizeof...(J)>& k,
                                                              double dt, std::size_t n, std::index_sequence<J...> js) {
    return combine_finite_over_body<a, Out>(io, x, k, dt, n, js);
}
#endif
template <auto a, std::size_t Out, std::size_t... J>
bool combine_stages_finite_over(double* io, const double* x, const std::array<const double*, sizeof...(J)>& k,
                                double dt, std::size_t n, std::index_sequence<J...> js) {
#if ECI_DETAIL_X86_SIMD
    if (n >= wide_pass && cpu_has_avx2()) return combine_finite_over_avx2<a, Out>(io, x, k, dt, n, js);
#endif
    return combine_finite_over_body<a, Out>(io, x, k, dt, n, js);
}

/// The two passes as an engine stepping states of type S calls them: the body itself on a narrow_state, else the
/// dispatcher.
template <auto a, class S, std::size_t... J>
[[gnu::always_inline]] inline void combine_stages_for(double* out, const double* x,
                                                      const std::array<const double*, sizeof...(J)>& k, double dt,
                                                      std::size_t n, std::index_sequence<J...> js) {
    if constexpr (narrow_state<S>)
        combine_stages_body<a>(out, x, k, dt, n, js);
    else
        combine_stages<a>(out, x, k, dt, n, js);
}
template <auto a, std::size_t Out, class S, std::size_t... J>
[[gnu::always_inline]] inline bool combine_finite_over_for(double* io, const double* x,
                                                           const std::array<const double*, sizeof...(J)>& k,
                                                           double dt, std::size_t n, std::index_sequence<J...> js) {
    if constexpr (narrow_state<S>)
        return combine_finite_over_body<a, Out>(io, x, k, dt, n, js);
    else
        return combine_stages_finite_over<a, Out>(io, x, k, dt, n, js);
}

/// The stages and update of tableau T on a small real state (small_real_array), written with compile-time indices
/// and no pointer, span or closure to the state or the stages: the compiler can then keep both in registers across
/// a run, as it cannot once an element is reached through a pointer. Same operations in the same order as
/// combine_stages and combine_stages_finite_over (acc = x_i, then acc += (dt a_j) k_j,i over the nonzero a_j in
/// order), so the same bits as the general engine; the update is summed as each k_j is known, which leaves the
/// value of the sum unchanged and frees k_j's registers early.
template <const auto& T, class S>
struct register_stages {
    static constexpr std::size_t s = std::remove_cvref_t<decltype(T)>::stages;
    static constexpr std::size_t n = std::tuple_size_v<S>;
    using elements = std::make_index_sequence<n>;
    using stages = std::array<S, s>;

    /// x + dt * sum_{j < J} c_j k_j, element i
    template <auto c, std::size_t... J>
    [[gnu::always_inline]] static double combined(const S& x, const stages& k, [[maybe_unused]] double dt,
                                                  std::size_t i, std::index_sequence<J...>) {
        double acc = x[i];
        ((c[J] != 0.0 ? (void)(acc += (dt * c[J]) * k[J][i]) : void()), ...);
        return acc;
    }
    template <std::size_t I, std::size_t... i>
    [[gnu::always_inline]] static S stage_value(const S& x, const stages& k, double dt, std::index_sequence<i...>) {
        return S{combined<T.a[I]>(x, k, dt, i, std::make_index_sequence<I>{})...};
    }
    /// out += (dt b_J) k_J, as the update's sum reaches k_J
    template <std::size_t J, std::size_t... i>
    [[gnu::always_inline]] static void add_to_update(S& out, const stages& k, double dt, std::index_sequence<i...>) {
        if constexpr (T.b[J] != 0.0) ((out[i] += (dt * T.b[J]) * k[J][i]), ...);
    }
    template <std::size_t I, class F>
    [[gnu::always_inline]] static void stage(F& f, const S& x, stages& k, S& out, double t, double dt) {
        derivative<I>(f, x, k, t, dt);
        add_to_update<I>(out, k, dt, elements{});
    }
    /// All the stage derivatives k_0 .. k_{s-1} of a step from x (the conservative engine's register path).
    template <class F, std::size_t... I>
    [[gnu::always_inline]] static void derivatives(F& f, const S& x, stages& k, double t, double dt,
                                                   std::index_sequence<I...>) {
        (derivative<I>(f, x, k, t, dt), ...);
    }
    template <std::size_t I, class F>
    [[gnu::always_inline]] static void derivative(F& f, const S& x, stages& k, double t, double dt) {
        if constexpr (I == 0) {
            f(x, k[0], t);
        } else {
            const S y = stage_value<I>(x, k, dt, elements{});
            f(y, k[I], t + T.c[I] * dt);
        }
    }
    template <std::size_t... i>
    [[gnu::always_inline]] static std::size_t first_non_finite(const S& v, std::index_sequence<i...>) {
        std::size_t first = n;
        ((first == n && !std::isfinite(v[i]) ? (void)(first = i) : void()), ...);
        return first;
    }
    // (the integer test: non_finite_diff's subtractions share the floating-point ports with the step's chain of
    // dependent products, and made a three-wave PC step 2 % slower, RK4's 6 %)
    template <std::size_t... i>
    [[gnu::always_inline]] static bool all_finite(const S& v, std::index_sequence<i...>) {
        return none_non_finite((non_finite_bit(v[i]) | ...));
    }

    /// One step of x; a non-finite update fails it and leaves x as it was.
    template <class F, std::size_t... I>
    [[gnu::always_inline]] static step_result step(F& f, S& x, double t, double dt, std::index_sequence<I...>) {
        stages k;
        S out = x;
        (stage<I>(f, x, k, out, t, dt), ...);
        if (!all_finite(out, elements{})) [[unlikely]]
            return step_result::failure(first_non_finite(out, elements{}));
        x = out;
        return step_result::success();
    }
};

/// The pointers of k advanced by i0: a range's view of the stage derivatives.
template <std::size_t N>
std::array<const double*, N> offset(const std::array<const double*, N>& k, std::size_t i0) {
    std::array<const double*, N> r{};
    for (std::size_t j = 0; j < N; ++j) r[j] = k[j] + i0;
    return r;
}

/// The on_stage of a caller that needs no stage values (stage_storage::run_stages).
struct no_stage_hook {
    template <class S>
    void operator()(std::size_t, const S&, const S&) const {}
};

/// The stage buffers of an explicit tableau, and the computation of every stage's derivative.
/// After `run_stages`, k[i] holds f(Y_i) and `stage` holds the last stage value Y_{s-1} (Y_0 = x itself).
/// `on_stage(i, Y_i, k_i)` is called with the stage's state and derivative after each stage (the transformed
/// engine accumulates the rate of xi there).
template <const auto& T, state S>
struct stage_storage {
    static constexpr std::size_t s = std::remove_cvref_t<decltype(T)>::stages;
    std::array<S, s> k{};
    S stage{};

    void prepare(const S& x) {
        for (auto& ki : k) resize_like(ki, x);
        if constexpr (s > 1) resize_like(stage, x);
    }

    /// Runs the first N stages (all by default; a caller that uses no later k_i may stop early). All of them, with
    /// no_stage_hook, on a system that runs a step's stages itself (runs_stages: a spectral flow's fused column
    /// passes) are run there, with the same bits.
    template <std::size_t N = s, class F, class OnStage>
    void run_stages(F& f, const S& x, double t, double dt, OnStage&& on_stage) {
        static_assert(N >= 1 && N <= s, "run between one stage and all of them");
        if constexpr (N == s && std::is_same_v<std::remove_cvref_t<OnStage>, no_stage_hook> && runs_stages<F, S>) {
            if (f.run_stages(int(s), a_flat.data(), dt, x, k.data(), stage, t)) return;
        }
        [&]<std::size_t... I>(std::index_sequence<I...>) {
            (run_stage<I>(f, x, t, dt, on_stage), ...);
        }(std::make_index_sequence<N>{});
    }

   private:
    template <std::size_t I, class F, class OnStage>
    void run_stage(F& f, const S& x, double t, double dt, OnStage& on_stage) {
        if constexpr (I == 0) {
            f(x, k[0], t);
            on_stage(I, x, std::as_const(k[0]));
        } else {
            std::array<const double*, I> kp{};
            for (std::size_t j = 0; j < I; ++j) kp[j] = reals(std::as_const(k[j])).data();
            const auto xr = reals(x);
            double* out = reals(stage).data();
            // element-wise, so over the model's threads (detail/ranges.hpp) with the same bits
            splitter::of(f).for_ranges(xr.size(), [&](std::size_t i0, std::size_t i1, int) {
                combine_stages_for<row<I>, S>(out + i0, xr.data() + i0, offset(kp, i0), dt, i1 - i0,
                                              std::make_index_sequence<I>{});
            });
            f(std::as_const(stage), k[I], t + T.c[I] * dt);
            on_stage(I, std::as_const(stage), std::as_const(k[I]));
        }
    }

    // a, row-major (run_stages on a system that runs the stages)
    static constexpr std::array<double, s * s> a_flat = [] {
        std::array<double, s * s> r{};
        for (std::size_t i = 0; i < s; ++i)
            for (std::size_t j = 0; j < s; ++j) r[i * s + j] = T.a[i][j];
        return r;
    }();
    // Row I of a, truncated to its I explicit entries, as constexpr data usable as a template argument.
    template <std::size_t I>
    static constexpr std::array<double, I> row = [] {
        std::array<double, I> r{};
        for (std::size_t j = 0; j < I; ++j) r[j] = T.a[I][j];
        return r;
    }();
};

}  // namespace detail

/// A conventional explicit Runge-Kutta stepper for any tableau T (see tableaus.hpp).
template <const auto& T, state S>
class explicit_rk {
   public:
    static constexpr const auto& tableau = T;  ///< the tableau it runs (a run's stage hooks weigh with its b)
    static constexpr int order = T.order;
    static constexpr bool checks_finite = true;  ///< a non-finite update fails the step
    static constexpr bool fixed_evaluations = true;  ///< T.stages evaluations per step, no iteration
    /// Whether step_local keeps the state and the stages in registers (detail::register_stages): a few real
    /// unknowns of one process (a state spread over processes takes the general engine, with its reduction).
    template <class F>
    static constexpr bool in_registers = detail::small_real_array<S> && !detail::distributed_model<F>;

    template <system<S> F>
    step_result step(F& f, S& x, double t, double dt) {
        // A fixed-size state (std::array: a few unknowns) takes its stage buffers on the stack, where the compiler
        // keeps them in registers across an inlined right-hand side. Held in the stepper, every stage went through
        // memory, its scalar stores read back by vector loads that cannot be forwarded: in a run of three-wave
        // (bench/step_bench.cpp, three_wave_run) PC took 27 ns per step and RK4 50, against odeint's 6.7 and 15.
        if constexpr (on_stack) {
            detail::stage_storage<T, S> local;
            return step_in(local, f, x, t, dt);
        } else {
            return step_in(st_, f, x, t, dt);
        }
    }

    /// step() on a state its caller holds in a local across steps (the fixed-step run's working copy,
    /// detail::working_state): the same bits, with the state and the stages kept in registers. Not step() itself:
    /// on a state in memory between steps the compiler pairs the register path's loads and stores differently
    /// (SLP), and a 16-byte load of a state written by two stores the step before cannot be forwarded: one step
    /// per call took 16.5 ns against 10 (bench/step_bench.cpp, three_wave/pc).
    template <system<S> F>
        requires in_registers<F>
    [[gnu::always_inline]] step_result step_local(F& f, S& x, double t, double dt) {
        return detail::register_stages<T, S>::step(f, x, t, dt, std::make_index_sequence<T.stages>{});
    }

    /// How many state-sized buffers this stepper holds (stage derivatives and one stage value).
    static constexpr std::size_t buffer_count() { return T.stages + (T.stages > 1 ? 1 : 0); }

   private:
    template <system<S> F>
    step_result step_in(detail::stage_storage<T, S>& st, F& f, S& x, double t, double dt) {
        st.prepare(x);
        st.run_stages(f, x, t, dt, detail::no_stage_hook{});
        std::array<const double*, T.stages> kp{};
        for (std::size_t j = 0; j < T.stages; ++j) kp[j] = detail::reals(std::as_const(st.k[j])).data();
        auto xr = detail::reals(x);
        const std::size_t n = xr.size();
        // A non-finite update (a blow-up) fails the step and leaves x as it was, like every other failure. The
        // update goes to a buffer that is free once the stages are done, is checked in the same pass, then swaps
        // in. That buffer is a stage derivative the update reads (b_j != 0), element by element before overwriting
        // it: its lines are in the cache when they are written. Written to the stage value instead, a state larger
        // than the caches costs one more read of the whole state per step (the write-allocate of a cold line): 6 %
        // of PC's step on 3e6 independent triads (bench/step_bench.cpp), where odeint updates x in place.
        S& spare = st.k[update_buffer];
        double* o = detail::reals(spare).data();
        // over the model's threads (detail/ranges.hpp): the ranges that met a non-finite value, counted
        bool finite = detail::splitter::of(f).count(n, [&](std::size_t i0, std::size_t i1) {
                          const bool ok = detail::combine_finite_over_for<T.b, update_buffer, S>(
                              o + i0, xr.data() + i0, detail::offset(kp, i0), dt, i1 - i0,
                              std::make_index_sequence<T.stages>{});
                          return ok ? 0.0 : 1.0;
                      }) == 0.0;
        // a state spread over processes fails the step on every process when it fails on one (detail/reduce.hpp)
        if constexpr (detail::distributed_model<F>) finite = !detail::reducer::of(f).any(!finite);
        if (!finite)
            return step_result::failure(detail::first_index(n, [&](std::size_t i) { return !std::isfinite(o[i]); }));
        using std::swap;
        swap(x, spare);
        return step_result::success();
    }

    /// The last stage whose derivative the update reads (a tableau has one: sum b_j = 1).
    static constexpr std::size_t update_buffer = [] {
        std::size_t j = T.stages - 1;
        while (T.b[j] == 0.0) --j;
        return j;
    }();
    static constexpr bool on_stack = detail::small_fixed_state<S>;
    struct none {};
    // the stage buffers of a state too large for the stack (a small fixed-size one's live in step)
    [[no_unique_address]] std::conditional_t<on_stack, none, detail::stage_storage<T, S>> st_;
};

template <state S> using euler = explicit_rk<tableaus::euler, S>;
template <state S> using pc = explicit_rk<tableaus::heun, S>;
template <state S> using rk2 = explicit_rk<tableaus::midpoint, S>;
template <state S> using rk4 = explicit_rk<tableaus::rk4, S>;

}  // namespace eci

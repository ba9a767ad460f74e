// The conservative Runge-Kutta engine (errata item 9): any explicit tableau applied to the augmented system
// dpsi/dt = S, d(psi^2)/dt = 2 psi S; psi(t+tau) = sign * sqrt(psi^2(t+tau)). Every invariant sum_k w_k psi_k^2
// with sum_k w_k psi_k S_k = 0 is then conserved to round-off, all at once, and the method keeps its order.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <ranges>
#include <span>
#include <utility>

#include "../detail/simd.hpp"
#include "explicit_rk.hpp"
#include "radicand_remedy.hpp"

namespace eci {

/// Whose sign the new amplitude takes: the conventional update's (errata 9), or the last stage value's, which
/// for Heun's tableau is the predictor psi~ of eq. (30b).
enum class sign_rule { of_update, of_last_stage };

/// The conservative version of the explicit tableau T. Negative radicands in isolated components are remedied
/// exactly when the model's quadratic invariants are known (radicand_remedy.hpp); otherwise they fail the step
/// (x is unchanged) and the driver halves it.
template <const auto& T, state S, sign_rule Sign = sign_rule::of_update>
class conservative_rk : public radicand_remedy {
    static constexpr std::size_t s = T.stages;
    // Heun with the predictor's sign is C-PC, eq. (30). Its radicand factorises,
    // psi^2 + tau (psi S + psi~ S~) = psi~ (psi + tau S~) since psi~ = psi + tau S,
    // so it needs neither the accumulator nor k_0 at the end: no buffer beyond those of PC.
    static constexpr bool is_c_pc = s == 2 && T.a[1][0] == 1.0 && T.b[0] == 0.5 && T.b[1] == 0.5 &&
                                    Sign == sign_rule::of_last_stage;

   public:
    static constexpr const auto& tableau = T;  ///< the tableau it runs (a run's stage hooks weigh with its b)
    static constexpr int order = T.order;
    static constexpr bool checks_finite = true;  ///< a non-finite update fails the step
    static constexpr bool fixed_evaluations = true;  ///< s evaluations per step (the remedy evaluates nothing)

    template <system<S> F>
    step_result step(F& f, S& x, double t, double dt) {
        st_.prepare(x);
        reduce_ = detail::reducer::of(f);  // empty unless the model's state is spread over processes
        split_ = detail::splitter::of(f);  // empty unless the model lends its threads (detail/ranges.hpp)
        if constexpr (s == 1) detail::resize_like(result_, x);
        st_.run_stages(f, x, t, dt, detail::no_stage_hook{});
        return finish<F>(x, dt);
    }

    /// Whether step_local keeps the state and the stages in registers: a few real unknowns of one process.
    template <class F>
    static constexpr bool in_registers = detail::small_real_array<S> && !detail::distributed_model<F>;

    /// step() on a state its caller holds in a local across steps (the fixed-step run's working copy): the stages
    /// and the paper's update in registers (as explicit_rk::step_local), the same operations in the same order, so
    /// the same bits. A step whose update needs more (a negative radicand or a non-finite value: the remedy or a
    /// failure), or a system the conditioned update applies to, finishes as step() does, from the same stages.
    template <system<S> F>
        requires in_registers<F>
    [[gnu::always_inline]] step_result step_local(F& f, S& x, double t, double dt) {
        reduce_ = detail::reducer::of(f);  // this system's (empty: one process), not a system stepped before
        if (conditioned_update_applies(std::tuple_size_v<S>)) [[unlikely]]
            return apart(x, step_apart(f, x, t, dt));
        using regs = detail::register_stages<T, S>;
        typename regs::stages k;
        regs::derivatives(f, std::as_const(x), k, t, dt, std::make_index_sequence<s>{});
        S out;
        double bad = 0.0;
        update_in_registers(out, x, k, dt, bad, std::make_index_sequence<std::tuple_size_v<S>>{});
        if (bad == 0.0 && regs::all_finite(out, typename regs::elements{})) [[likely]] {
            x = out;
            return step_result::success();
        }
        return apart(x, finish_apart(x, k, t, dt));
    }

    /// How many state-sized buffers this stepper holds: the conventional method's (a failed step leaves x untouched:
    /// the new state is written to the stage value's buffer, or for Euler's tableau to one of its own).
    static constexpr std::size_t buffer_count() { return s + 1; }

   private:
    // The finishing passes of step() from the stages taken, and the remedy; on success the new state is swapped
    // into x.
    template <class F>
    step_result finish(S& x, double dt) {
        rescaled_ = rescaled::no;
        const auto xr = detail::reals(std::as_const(x));
        const std::size_t n = xr.size();
        // the paper's update's counts (doubles keep the loops vectorizable): negative radicands go to the remedy, and
        // where there are none its pass saw every new value; the conditioned update leaves them zero and unread
        detail::radicand_counts counts;
        const bool conditioned = conditioned_update_applies(n);
        // The new state goes to the stage value's buffer, free once the stages are done: the finishing passes
        // recompute each stage value from x and the k_j (C-PC's reads its predictor there, element by element before
        // overwriting it). Only Euler's tableau, with no stage value, holds a buffer of its own.
        S& out = s > 1 ? st_.stage : result_;
        double* o = detail::reals(out).data();
        if (conditioned) {
            // The conditioned update: the modulus of a complex mode, the conventional update where the square root is
            // ill-conditioned, and one exact rescale (docs/methods.md). Spread over processes, its every decision
            // is taken from sums over all of them (remedy_elements), so all take it alike.
            const std::array<const double*, s> kp = stage_pointers();
            const auto conv = [&](std::size_t e, std::array<double, per>& c) {
                std::array<double, per> rad{};
                const auto [c2, xi] = element_update(xr.data(), kp, e, dt, c, rad);
                return radicand_remedy::element_update{c2, xi, sign_of(xr.data(), kp, e, dt, c, xi)};
            };
            // Order 3 or more (remedy_options::real_by_rescale, complex_by_rescale): every element's conventional
            // update and one exact rescale, unless the rescale is refused (a step far too large: then as order 2).
            // Else the pass lumps the elements far above the previous step's cut (radicand_remedy::lump_from_);
            // where the share cap might reach them after all, it is made again with every element filed.
            if (!by_rescale() || !finish_by_rescale(o, xr.data(), kp, dt, n)) {
                finish_conditioned(o, xr.data(), kp, dt, n, true);
                bool ok = !reduce_.any(!filed_none()) || remedy_elements<per>(o, xr.data(), n, conv);
                if (!ok && refiling()) {
                    finish_conditioned(o, xr.data(), kp, dt, n, false);
                    ok = !reduce_.any(!filed_none()) || remedy_elements<per>(o, xr.data(), n, conv);
                }
                if (!ok) return step_result::failure(first_negative<per>());
            }
        } else if constexpr (is_c_pc) {
            const double* k1 = detail::reals(std::as_const(st_.k[1])).data();
            counts = split_.count(n, [&](std::size_t i0, std::size_t i1) {
                return i1 - i0 >= 64 ? detail::c_pc_finish(o + i0, xr.data() + i0, k1 + i0, dt, i1 - i0)
                                     : detail::c_pc_finish_inline(o + i0, xr.data() + i0, k1 + i0, dt, i1 - i0);
            });
        } else {
            const std::array<const double*, s> kp = stage_pointers();
            counts = split_.count(n, [&](std::size_t i0, std::size_t i1) {
                return finish_dispatched(o + i0, xr.data() + i0, detail::offset(kp, i0), dt, i1 - i0);
            });
        }
        // A negative radicand on any process is one on every process (detail/reduce.hpp).
        double bad = counts.negative;
        if constexpr (detail::distributed_model<F>) bad = reduce_.any(bad != 0.0) ? 1.0 : 0.0;
        // Only steps with failures pay for the remedy; the failed unknowns are NaN in o.
        if (bad != 0.0 && !remedy_failures(o, xr.data(), dt, n))
            return step_result::failure(first_failure(n, [&](std::size_t i) { return !(o[i] == o[i]); }));
        // An overflow (inf) fails the step as well, never passes as a result. A rescale of the whole state (the
        // remedy's, on most steps of turbulence) checked every value in its own pass; the paper's update, where no
        // radicand was negative, counted the infinite ones in its own (a second pass over the state cost 7 % of a
        // C-PC step on 3e6 unknowns, bench/step_bench.cpp); anything else is checked here.
        bool finite = rescaled_ != rescaled::no      ? rescaled_ == rescaled::finite
                      : !conditioned && bad == 0.0 ? counts.infinite == 0.0
                                                   : split_.count(n, [&](std::size_t i0, std::size_t i1) {
                                                         return detail::all_finite_reals(o + i0, i1 - i0) ? 0.0 : 1.0;
                                                     }) == 0.0;
        if constexpr (detail::distributed_model<F>) finite = !reduce_.any(!finite);
        if (!finite)
            return step_result::failure(detail::first_index(n, [&](std::size_t i) { return !std::isfinite(o[i]); }));
        using std::swap;
        swap(x, out);
        return step_result::success();
    }

    // step_local's paths out of line, given copies of the state and the stages (a reference would take the caller's
    // registers to memory on every step): step() whole, or its finish on the stages already taken.
    template <class F>
    [[gnu::noinline]] std::pair<step_result, S> step_apart(F& f, S x, double t, double dt) {
        const step_result r = step(f, x, t, dt);
        return {r, x};
    }
    [[gnu::noinline]] std::pair<step_result, S> finish_apart(S x, std::array<S, s> k, double t, double dt) {
        const replay_stages again{&k};
        const step_result r = step(again, x, t, dt);
        return {r, x};
    }
    // The stages of a step already taken, given back in order: step() finishes from them without evaluating the
    // system again (its evaluations are counted once, by the register path that took them).
    struct replay_stages {
        const std::array<S, s>* k;
        mutable std::size_t next = 0;
        void operator()(const S&, S& d, double) const { d = (*k)[next++]; }
    };
    static step_result apart(S& x, const std::pair<step_result, S>& r) {
        x = r.second;
        return r.first;
    }

    // The paper's update of every unknown of a small real state (finish_general, and eq. (30) for C-PC as
    // detail::c_pc_finish_inline forms it), element by element with the same operations; negative radicands
    // counted in `bad`.
    template <std::size_t... i>
    [[gnu::always_inline]] static void update_in_registers(S& out, const S& x, const std::array<S, s>& k, double dt,
                                                           double& bad, std::index_sequence<i...>) {
        const detail::step_split sp = detail::split_step(dt);  // once per step, as radicand() forms it
        ((out[i] = paper_update<i>(x, k, dt, sp, bad)), ...);
    }
    template <std::size_t i>
    [[gnu::always_inline]] static double paper_update(const S& x, const std::array<S, s>& k, double dt,
                                                      [[maybe_unused]] detail::step_split sp, double& bad) {
        if constexpr (is_c_pc) {  // the predictor o = Y_1, rad = o (x + dt k_1)
            const double o = stage_at<1, i>(x, k, dt);
            const double rad = o * (x[i] + dt * k[1][i]);
            bad += rad >= 0.0 ? 0.0 : 1.0;
            return std::copysign(std::sqrt(rad), o);
        } else {
            return [&]<std::size_t... J>(std::index_sequence<J...>) {
                const std::array<double, s> w{(dt * T.b[J])...};
                double conv = x[i];
                ((T.b[J] != 0.0 ? (conv += w[J] * k[J][i], 0) : 0), ...);
                double rate = 2.0 * T.b[0] * sp.p * x[i] * k[0][i];  // Y_0 = x
                ((J > 0 && T.b[J] != 0.0 ? (rate += 2.0 * T.b[J] * sp.p * stage_at<J, i>(x, k, dt) * k[J][i], 0) : 0),
                 ...);
                const double rad = x[i] * x[i] + sp.m * rate;
                bad += rad >= 0.0 ? 0.0 : 1.0;
                const double sign = Sign == sign_rule::of_update ? conv : stage_at<s - 1, i>(x, k, dt);
                return std::copysign(std::sqrt(rad), sign);
            }(std::make_index_sequence<s>{});
        }
    }
    // the stage value Y_J at unknown i (Y_0 is x itself), as the stages formed it
    template <std::size_t J, std::size_t i>
    [[gnu::always_inline]] static double stage_at(const S& x, const std::array<S, s>& k, double dt) {
        return detail::register_stages<T, S>::template combined<T.a[J]>(x, k, dt, i, std::make_index_sequence<J>{});
    }

    // Stage value Y_J = x + dt sum_m a[J][m] k_m at one unknown, recomputed exactly as stage_storage formed it
    // (same operations in the same order, so the same bits): the stages need not be kept for the end.
    template <std::size_t J>
    [[gnu::always_inline]] static double stage_value(double x, const std::array<const double*, s>& k, std::size_t i,
                                                     double dt) {
        double acc = x;
        [&]<std::size_t... M>(std::index_sequence<M...>) {
            ((T.a[J][M] != 0.0 ? (acc += (dt * T.a[J][M]) * k[M][i], 0) : 0), ...);
        }(std::make_index_sequence<J>{});
        return acc;
    }

    static constexpr std::size_t per = sizeof(std::ranges::range_value_t<S>) / sizeof(double);

    // The conditioned update needs the declared weights (the rescale restores them, and they say the
    // invariants of a complex state are sums w_k |psi_k|^2, phase-free), the remedy policy, and a system of at least
    // min_unknowns real unknowns. Otherwise: the paper's per-unknown update (and eq. (30) for C-PC).
    // Spread over processes, n is this process's share: the size and the weights' fit are decided over all.
    bool conditioned_update_applies(std::size_t n) const {
        const auto& w = quadratic_invariants();
        if (remedy.update != update_kind::conditioned || remedy.policy != radicand_policy::remedy || w.empty())
            return false;
        std::array<double, 2> whole{double(n), w.front().size() * per == n ? 0.0 : 1.0};
        reduce_.sum(whole);
        return whole[1] == 0.0 && whole[0] >= double(remedy.min_unknowns);
    }

    // Element e (one real unknown, or the two parts of a complex mode): its conventional update into c, and
    // {sum_p c_p^2, xi_e} with xi_e = sum_p (psi_p^2 + dt sum_j 2 b_j Y_jp k_jp), the tableau applied to |psi_e|^2.
    // For a complex mode xi_e is the modulus squared: every invariant sum_k w_k |psi_k|^2 is linear in it.
    static std::pair<double, double> element_update(const double* x, const std::array<const double*, s>& k,
                                                    std::size_t e, double dt, std::array<double, per>& c,
                                                    std::array<double, per>& rad) {
        const detail::step_split sp = detail::split_step(dt);
        double xi = 0.0, c2 = 0.0;
        for (std::size_t p = 0; p < per; ++p) {
            const std::size_t i = e * per + p;
            const double conv = conventional(x, k, i, dt, std::make_index_sequence<s>{});
            c[p] = conv;
            c2 += conv * conv;
            rad[p] = radicand(x, k, i, dt, sp, std::make_index_sequence<s>{});
            xi += rad[p];
        }
        return {c2, xi};
    }

    // The sign a real unknown's conservative value takes (the sign rule): the conventional update's, or for C-PC
    // the predictor's where xi >= 0.
    static double sign_of(const double* x, const std::array<const double*, s>& k, std::size_t e, double dt,
                          const std::array<double, per>& c, double xi) {
        double sign = c[0];
        if constexpr (per == 1 && Sign == sign_rule::of_last_stage)
            if (xi >= 0.0) sign = stage_value<s - 1>(x[e], k, e, dt);
        return sign;
    }

    // Whether the conditioned update is every element's conventional update and one exact rescale (tableaux of
    // order 3 or more; remedy_options::real_by_rescale, complex_by_rescale).
    bool by_rescale() const {
        return T.order >= 3 && (per == 1 ? remedy.real_by_rescale : remedy.complex_by_rescale);
    }

    // The rescale finish: one pass writes every element's conventional update into o and sums what the rescale
    // needs (each invariant's defect sum_e w_je (|c_e|^2 - xi_e), and with two invariants the Gram sums of
    // |c_e|^2, as the conditioned pass sums them), then radicand_remedy::rescale_conventional restores every
    // invariant. Split over the model's threads, each range sums apart and the ranges are merged in range order
    // (the sums of a given split repeat bit for bit). false: refused (o is then written again by the conditioned
    // pass).
    bool finish_by_rescale(double* o, const double* x, const std::array<const double*, s>& k, double dt,
                           std::size_t n) {
        constexpr std::size_t M = max_invariants;
        const std::size_t ne = n / per, m = quadratic_invariants().size();
        struct range_sums {
            conditioned_pass gram;
            std::array<double, M> defect{};
            double negatives = 0.0;
        };
        const conditioned_pass start = begin_rescale();
        std::array<range_sums, detail::max_ranges> ranges{};
        split_.for_ranges(ne, [&](std::size_t e_begin, std::size_t e_end, int r) {
            range_sums sum{start, {}, 0.0};
            constexpr std::size_t B = block_elements;
            std::array<double, B * per> rv;
            std::array<double, B> c2v, xiv, sg;
            const detail::step_split sp = detail::split_step(dt);
            const auto& w = quadratic_invariants();
            for (std::size_t e0 = e_begin; e0 < e_end; e0 += B) {
                const std::size_t nb = std::min(B, e_end - e0);
                double* cv = o + e0 * per;  // the conventional update, written in place
#if ECI_DETAIL_X86_SIMD
                if (detail::cpu_has_avx2())
                    block_updates_avx2(cv, rv.data(), c2v.data(), xiv.data(), sg.data(), x, k, e0, nb, dt, sp);
                else
#endif
                    block_updates(cv, rv.data(), c2v.data(), xiv.data(), sg.data(), x, k, e0, nb, dt, sp);
                if (m == 2) {  // E and Z (every spectral model, n-wave): the loop below, the Gram sums beside it
                    std::array<double, 3> d;
                    defect_gram_block(sum.gram, e0, c2v.data(), xiv.data(), nb, d);
                    sum.defect[0] += d[0], sum.defect[1] += d[1], sum.negatives += d[2];
                } else {
                    for (std::size_t b = 0; b < nb; ++b) {
                        const double d = c2v[b] - xiv[b];
                        for (std::size_t a = 0; a < m; ++a) sum.defect[a] += w[a][e0 + b] * d;
                        sum.negatives += xiv[b] < 0.0 ? 1.0 : 0.0;
                    }
                }
            }
            ranges[std::size_t(r)] = sum;
        });
        range_sums total = ranges[0];
        for (int r = 1; r < split_.threads; ++r) {
            const range_sums& p = ranges[std::size_t(r)];
            for (std::size_t a = 0; a < m; ++a) total.defect[a] += p.defect[a];
            total.negatives += p.negatives;
            merge_gram(total.gram, p.gram);
        }
        return rescale_conventional<per>(o, n, total.gram, total.defect, total.negatives);
    }

    // The conditioned finishing pass: each element's conventional update and xi, filed by the remedy's
    // condition_element (radicand_remedy.hpp): the sign rule as in the paper's update for a real unknown, the
    // conventional phase for a complex mode; remedy_elements then decides.
    // Split over the model's threads (detail/ranges.hpp), each range of elements files into its own lists,
    // histogram and Gram sums, merged in range order (end_split_conditioned): the elements are filed in element
    // order whatever the split, and the sums of a given split repeat bit for bit. One range is the unsplit pass.
    void finish_conditioned(double* o, const double* x, const std::array<const double*, s>& k, double dt,
                            std::size_t n, bool lump) {
        const std::size_t ne = n / per;
        // real unknowns of a tableau of order 3 or more: every one conventional, and the rescale (real_by_rescale);
        // nothing lumped then (the cut takes every element, so a lumped pass would be made again)
        const bool every = per == 1 && T.order >= 3 && remedy.real_by_rescale;
        const conditioned_pass start = begin_conditioned(ne, true, split_.threads, lump && !every, every);
        std::array<conditioned_pass, detail::max_ranges> passes{};
        split_.for_ranges(ne, [&](std::size_t e_begin, std::size_t e_end, int r) {
            const filing into = range_filing(r, e_begin, e_end);
            conditioned_pass pass = start;
            constexpr std::size_t B = block_elements;
            // per block: the conventional update and radicand of each real unknown (vectorized: the operations of
            // element_update, one unknown at a time), then each element's |c|^2, xi and sign, then the filing
            std::array<double, B * per> cv, rv;
            std::array<double, B> c2v, xiv, sg;
            const detail::step_split sp = detail::split_step(dt);
            for (std::size_t e0 = e_begin; e0 < e_end; e0 += B) {
                const std::size_t nb = std::min(B, e_end - e0);
#if ECI_DETAIL_X86_SIMD
                if (detail::cpu_has_avx2())
                    block_updates_avx2(cv.data(), rv.data(), c2v.data(), xiv.data(), sg.data(), x, k, e0, nb, dt, sp);
                else
#endif
                    block_updates(cv.data(), rv.data(), c2v.data(), xiv.data(), sg.data(), x, k, e0, nb, dt, sp);
                condition_block<per>(o, x, e0, nb, cv.data(), c2v.data(), xiv.data(), sg.data(), pass, into);
            }
            passes[std::size_t(r)] = pass;
        });
        end_split_conditioned(std::span(passes.data(), std::size_t(split_.threads)));
    }

    // A block of the conditioned pass (elements e0 .. e0 + nb): the conventional update and radicand of each real
    // unknown (the operations of element_update, one unknown at a time), then each element's |c|^2, xi and sign.
    // Always inlined, so that each caller below compiles it for its own instruction set.
    [[gnu::always_inline]] static void block_body(double* __restrict cv, double* __restrict rv, double* __restrict c2v,
                                                  double* __restrict xiv, double* __restrict sg, const double* x,
                                                  const std::array<const double*, s>& k, std::size_t e0,
                                                  std::size_t nb, double dt, detail::step_split sp) {
        constexpr auto J = std::make_index_sequence<s>{};
        const std::size_t i0 = e0 * per;
        for (std::size_t j = 0; j < nb * per; ++j) {
            cv[j] = conventional(x, k, i0 + j, dt, J);
            rv[j] = radicand(x, k, i0 + j, dt, sp, J);
        }
        for (std::size_t b = 0; b < nb; ++b) {
            double c2 = 0.0, xi = 0.0;
            for (std::size_t p = 0; p < per; ++p) c2 += cv[b * per + p] * cv[b * per + p], xi += rv[b * per + p];
            c2v[b] = c2, xiv[b] = xi;
            sg[b] = cv[b * per];
            if constexpr (per == 1 && Sign == sign_rule::of_last_stage)
                if (xi >= 0.0) sg[b] = stage_value<s - 1>(x[i0 + b], k, i0 + b, dt);
        }
    }
    static void block_updates(double* cv, double* rv, double* c2v, double* xiv, double* sg, const double* x,
                              const std::array<const double*, s>& k, std::size_t e0, std::size_t nb, double dt,
                              detail::step_split sp) {
        block_body(cv, rv, c2v, xiv, sg, x, k, e0, nb, dt, sp);
    }
#if ECI_DETAIL_X86_SIMD
    // The same compiled for AVX2 (twice the lanes of the baseline's SSE2; no FMA, so it rounds alike), picked at
    // run time: the pass is compute-bound (a dozen products per unknown for the radicand's recomputed stages).
    __attribute__((target("avx2"))) static void block_updates_avx2(double* cv, double* rv, double* c2v, double* xiv,
                                                                   double* sg, const double* x,
                                                                   const std::array<const double*, s>& k,
                                                                   std::size_t e0, std::size_t nb, double dt,
                                                                   detail::step_split sp) {
        block_body(cv, rv, c2v, xiv, sg, x, k, e0, nb, dt, sp);
    }
#endif

    // The conventional update x + dt sum_j b_j k_j at unknown i: the one fold of element_update, the conditioned
    // pass and the remedy (finish_general forms the same products with dt b_j hoisted out of its loop).
    template <std::size_t... J>
    [[gnu::always_inline]] static double conventional(const double* x, const std::array<const double*, s>& k,
                                                      std::size_t i, double dt, std::index_sequence<J...>) {
        double conv = x[i];
        ((T.b[J] != 0.0 ? (conv += (dt * T.b[J]) * k[J][i], 0) : 0), ...);
        return conv;
    }

    // The stage derivatives k_j of the step just taken, as arrays of real unknowns.
    std::array<const double*, s> stage_pointers() const {
        std::array<const double*, s> kp{};
        for (std::size_t j = 0; j < s; ++j) kp[j] = detail::reals(std::as_const(st_.k[j])).data();
        return kp;
    }

    // The remedy (radicand_remedy.hpp) for the unknowns whose radicand is negative (NaN in o): their conventional
    // update, recomputed with the very operations of the stage and finishing passes, and their radicand.
    bool remedy_failures(double* o, const double* x, double dt, std::size_t n) {
        const std::array<const double*, s> kp = stage_pointers();
        auto failed = [&](std::size_t i) { return !(o[i] == o[i]); };
        const detail::step_split sp = detail::split_step(dt);
        auto fix = [&](std::size_t i) -> std::pair<double, double> {
            const double conv = conventional(x, kp, i, dt, std::make_index_sequence<s>{});
            if constexpr (is_c_pc) {
                const double pred = stage_value<1>(x[i], kp, i, dt);  // psi~, eq. (30a)
                return {conv, pred * (x[i] + dt * kp[1][i])};         // eq. (30b), factorised
            } else {
                return {conv, radicand(x, kp, i, dt, sp, std::make_index_sequence<s>{})};
            }
        };
        return try_remedy<per>(o, x, n, failed, fix, [&](const auto& c) { rescale<per>(o, n, c); });
    }

    // psi^2 + dt sum_j 2 b_j Y_j k_j at unknown i (every finishing path forms it here), with dt = p m
    // (detail::split_step): the rate sum_j (2 b_j p Y_j) k_j is p times the rate, of the size of the increment, so
    // that it neither overflows nor underflows where psi^2 and the update are representable (the rate alone is
    // cubic in the state's scale for a quadratic S), and has the bits of the unscaled form wherever that is.
    // Always inlined, as conventional and stage_value: GCC 12 had left it a call per unknown, out of line and
    // scalar, inside the AVX2 block kernels (session 50).
    template <std::size_t... J>
    [[gnu::always_inline]] static double radicand(const double* x, const std::array<const double*, s>& k,
                                                  std::size_t i, double dt, detail::step_split sp,
                                                  std::index_sequence<J...>) {
        double rate = 2.0 * T.b[0] * sp.p * x[i] * k[0][i];  // Y_0 = x
        ((J > 0 && T.b[J] != 0.0 ? (rate += 2.0 * T.b[J] * sp.p * stage_value<J>(x[i], k, i, dt) * k[J][i], 0) : 0),
         ...);
        return x[i] * x[i] + sp.m * rate;
    }
    // finish_general, also compiled for AVX2 and taken at run time for ranges of detail::wide_pass values or more (as
    // the conventional engine's passes): the same IEEE operations (no FMA), the same bits, half the instructions of
    // the baseline's loop, which is compute-bound (a dozen products per unknown for the recomputed stages).
    static detail::radicand_counts finish_dispatched(double* o, const double* x, const std::array<const double*, s>& k,
                                                     double dt, std::size_t n) {
#if ECI_DETAIL_X86_SIMD
        if (n >= detail::wide_pass && detail::cpu_has_avx2()) return finish_avx2(o, x, k, dt, n);
#endif
        return finish_general(o, x, k, dt, n, std::make_index_sequence<s>{});
    }
#if ECI_DETAIL_X86_SIMD
    __attribute__((target("avx2"))) static detail::radicand_counts finish_avx2(double* o, const double* x,
                                                                               const std::array<const double*, s>& k,
                                                                               double dt, std::size_t n) {
        return finish_general(o, x, k, dt, n, std::make_index_sequence<s>{});
    }
#endif
    // One pass over x and the k_j: the conventional update (for the sign), the radicand from recomputed stages (no
    // per-stage pass, no stored stages), and the new amplitude. Returns the counts of negative (or NaN) and of
    // infinite radicands. Always inlined, so that each caller above compiles it for its own instruction set. o is
    // none of x and the k_j (the stage buffer or result_): said, so that GCC vectorizes the loop without checking
    // o against each of them (with 13 stages it made no such checks and left the loop scalar; vectorized_kernels.py).
    template <std::size_t... J>
    [[gnu::always_inline]] static detail::radicand_counts finish_general(double* __restrict o, const double* x,
                                                                         const std::array<const double*, s>& k,
                                                                         double dt, std::size_t n,
                                                                         std::index_sequence<J...>) {
        const std::array<double, s> w{(dt * T.b[J])...};
        const detail::step_split sp = detail::split_step(dt);
        constexpr double most = std::numeric_limits<double>::max();
        double bad = 0.0, inf = 0.0;
        for (std::size_t i = 0; i < n; ++i) {
            double conv = x[i];
            ((T.b[J] != 0.0 ? (conv += w[J] * k[J][i], 0) : 0), ...);
            const double rad = radicand(x, k, i, dt, sp, std::index_sequence<J...>{});
            bad += rad >= 0.0 ? 0.0 : 1.0;
            inf += rad > most ? 1.0 : 0.0;
            const double sign = Sign == sign_rule::of_update ? conv : stage_value<s - 1>(x[i], k, i, dt);
            o[i] = std::copysign(std::sqrt(rad), sign);
        }
        return {bad, inf};
    }

    detail::stage_storage<T, S> st_;
    S result_{};  // Euler's tableau: the new state until the step is known to succeed (others use the stage buffer)
};

/// C-PC, eq. (30): Heun's tableau, the new amplitude takes the predictor's sign.
template <state S> using c_pc = conservative_rk<tableaus::heun, S, sign_rule::of_last_stage>;
/// Conservative midpoint rule (second order).
template <state S> using c_rk2 = conservative_rk<tableaus::midpoint, S>;
/// Conservative classical Runge-Kutta (fourth order).
template <state S> using c_rk4 = conservative_rk<tableaus::rk4, S>;

}  // namespace eci

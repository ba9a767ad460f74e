// Internals shared by the steppers on the flat array of a state's real unknowns (eci::reals, state.hpp): sizing
// buffers, finiteness checks.
#pragma once

#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <span>
#include <type_traits>
#include <vector>

#include "../concepts.hpp"
#include "../state.hpp"

namespace eci::detail {

using eci::reals;  // the public name, for the engines written against detail::reals

/// A state whose size is fixed by its type (std::array: a few unknowns), not resizable like std::vector.
template <class S>
concept fixed_size_state = !requires(S& v) { v.resize(std::size_t{}); };

/// A fixed-size state small enough that a stepper's stage buffers may live on the stack, in registers.
template <class S>
concept small_fixed_state = fixed_size_state<S> && sizeof(S) <= 64 * sizeof(double);

/// A few real unknowns, std::array<double, n> with n <= 64: the conventional steppers take such a state through
/// compile-time indices alone, so that it and the stages stay in registers over a run (explicit_rk.hpp).
template <class S>
concept small_real_array =
    std::is_same_v<S, std::array<double, std::tuple_size<S>::value>> && std::tuple_size<S>::value <= 64;

/// Make `buffer` the same size as `like` (a no-op for fixed-size states such as std::array).
template <state S>
void resize_like(S& buffer, const S& like) {
    if constexpr (!fixed_size_state<S>) {
        if (std::ranges::size(buffer) != std::ranges::size(like)) buffer.resize(std::ranges::size(like));
    }
}

/// What a finishing pass of the paper's update counted among its radicands, as doubles (whole numbers, so that the
/// ranges of a split pass sum to the same counts): the negative or NaN ones (their unknowns are NaN, for the remedy)
/// and the infinite ones (an overflow). Where both are zero every new value is the root of a finite radicand >= 0,
/// finite: the step needs no second pass to check it.
struct radicand_counts {
    double negative = 0.0;
    double infinite = 0.0;
    radicand_counts& operator+=(const radicand_counts& o) {
        negative += o.negative, infinite += o.infinite;
        return *this;
    }
};

/// Bit 63 set iff v is infinite or NaN (its exponent field all ones), for OR-accumulation over a loop. Written
/// as an add, not a compare: adding one to the exponent field carries into bit 63 exactly when the field is all
/// ones, and a 64-bit add and OR vectorize with baseline x86-64 (SSE2), where the 64-bit compare of
/// `(bits & exponent) == exponent` does not (SSE4.1) and left the whole loop scalar.
inline std::uint64_t non_finite_bit(double v) {
    constexpr std::uint64_t exponent = 0x7ff0000000000000ull, one = 0x0010000000000000ull;
    return (std::bit_cast<std::uint64_t>(v) & exponent) + one;
}
/// Whether an OR of non_finite_bit() values saw no infinite or NaN value.
inline bool none_non_finite(std::uint64_t accumulated) { return (accumulated >> 63) == 0; }

/// The same test in two vector operations instead of three, for the vectorized update loops: v - v is +-0 for every
/// finite v (-0 only under downward rounding) and NaN for an infinity or a NaN, so the OR of its bits over a loop has
/// a nonzero exponent field iff some value was not finite (none_non_finite_diff). A build that assumes finite math
/// (-ffast-math, -ffinite-math-only) may fold v - v to zero: there it is the integer test, whose bits no
/// floating-point assumption touches.
inline std::uint64_t non_finite_diff(double v) {
#if defined(__FINITE_MATH_ONLY__) && __FINITE_MATH_ONLY__
    return non_finite_bit(v) >> 11;  // bit 63 moved into the exponent field
#else
    return std::bit_cast<std::uint64_t>(v - v);
#endif
}
/// Whether an OR of non_finite_diff() values saw no infinite or NaN value.
inline bool none_non_finite_diff(std::uint64_t accumulated) { return (accumulated & 0x7ff0000000000000ull) == 0; }

/// Whether all n values are finite: one vectorized pass over the exponent bits.
inline bool all_finite_reals(const double* v, std::size_t n) {
    std::uint64_t bad = 0;
    for (std::size_t i = 0; i < n; ++i) bad |= non_finite_bit(v[i]);
    return none_non_finite(bad);
}

/// A step tau as p m with p a power of two and m in [1, 2): multiplying by p is exact (short of the ends of the
/// range) and m is tau / p exactly. The rate of psi^2, sum_j 2 b_j Y_j S_j, is cubic in the state's scale for a
/// quadratic system and over- or underflows within the cube root of the range (|psi| beyond 2^341 or below
/// 2^-341) while psi^2 and its increment tau 2 b_j Y_j S_j are representable. Formed as sum_j (2 b_j p Y_j) S_j and
/// multiplied by m, it is of the increment's size, and since every product is the old one times p exactly, the same
/// bits wherever the old form was representable: a run of the state scaled by 2^k and the step by 2^-k then equals
/// the unscaled run scaled, bit for bit, across the range.
struct step_split {
    double p;  ///< the power of two
    double m;  ///< tau / p, in [1, 2)
};
inline step_split split_step(double tau) {
    constexpr std::uint64_t exponent = 0x7ff0000000000000u, one = 0x3ff0000000000000u;
    const std::uint64_t b = std::bit_cast<std::uint64_t>(tau);
    const std::uint64_t e = b & exponent;
    // tau = 2^e' 1.f: p = 2^e' (the exponent field alone), m = +-1.f (the sign and fraction with 1's exponent).
    // Zero, subnormal and non-finite tau are left as they are (p = 1, m = tau): the unscaled form.
    const bool normal = e != 0 && e != exponent;
    return {normal ? std::bit_cast<double>(e) : 1.0, normal ? std::bit_cast<double>((b & ~exponent) | one) : tau};
}

/// Index of the first real unknown for which `bad(i)` holds; called only after a step has failed.
template <class Pred>
std::size_t first_index(std::size_t n, Pred bad) {
    for (std::size_t i = 0; i < n; ++i)
        if (bad(i)) return i;
    return 0;
}

}  // namespace eci::detail

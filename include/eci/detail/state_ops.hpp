// Internals shared by the steppers on the flat array of a state's real unknowns (eci::reals, state.hpp): sizing
// buffers, finiteness checks.
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "../concepts.hpp"
#include "../state.hpp"

namespace eci::detail {

using eci::reals;  // the public name, for the engines written against detail::reals

/// Make `buffer` the same size as `like` (a no-op for fixed-size states such as std::array).
template <state S>
void resize_like(S& buffer, const S& like) {
    if constexpr (requires { buffer.resize(std::ranges::size(like)); }) {
        if (std::ranges::size(buffer) != std::ranges::size(like)) buffer.resize(std::ranges::size(like));
    }
}

/// Whether all n values are finite: one pass over the exponent bits that the compiler vectorizes.
inline bool all_finite_reals(const double* v, std::size_t n) {
    constexpr std::uint64_t exponent = 0x7ff0000000000000ull;
    std::uint64_t bad = 0;
    for (std::size_t i = 0; i < n; ++i) bad |= (std::bit_cast<std::uint64_t>(v[i]) & exponent) == exponent;
    return bad == 0;
}

/// Index of the first real unknown for which `bad(i)` holds; called only after a step has failed.
template <class Pred>
std::size_t first_index(std::size_t n, Pred bad) {
    for (std::size_t i = 0; i < n; ++i)
        if (bad(i)) return i;
    return 0;
}

}  // namespace eci::detail

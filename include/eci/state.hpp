// A state as the flat array of its real unknowns: how the steppers, the invariant sets and the front ends read
// and write any state, real or complex, fixed-size or not.
#pragma once

#include <cstddef>
#include <ranges>
#include <span>

#include "concepts.hpp"

namespace eci {

/// The real unknowns of a state: n doubles for a real state, 2n (re, im interleaved) for a complex one
/// (std::complex<double> is layout-compatible with double[2], [complex.numbers]).
template <state S>
std::span<double> reals(S& x) {
    using value = std::ranges::range_value_t<S>;
    constexpr std::size_t per = sizeof(value) / sizeof(double);
    return {reinterpret_cast<double*>(std::ranges::data(x)), std::ranges::size(x) * per};
}

/// The same, read-only.
template <state S>
std::span<const double> reals(const S& x) {
    using value = std::ranges::range_value_t<S>;
    constexpr std::size_t per = sizeof(value) / sizeof(double);
    return {reinterpret_cast<const double*>(std::ranges::data(x)), std::ranges::size(x) * per};
}

}  // namespace eci

// A named invariant of a model: the CLI, the tests and the benchmarks all measure through these.
#pragma once

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "../detail/format.hpp"

namespace eci {

/// An invariant's name (a CSV column) and the model's member function that computes it.
template <class Model>
struct named_invariant {
    const char* name;
    double (Model::*value)(const typename Model::state_type&) const;
};

namespace detail {

/// The text of a check's subject: a string, or a callable that makes one (only when a check fails, so that
/// validating 10^7 triads builds no strings).
template <class What>
std::string describe(const What& what) {
    if constexpr (std::is_invocable_v<const What&>)
        return std::string(what());
    else
        return std::string(what);
}

/// Throw std::invalid_argument("<what> ...") unless |sum| is round-off relative to the sum of magnitudes.
template <class What>
void require_cancellation(double sum, double magnitude, const What& what_) {
    // Each term carries at most one rounding, so the sum of n terms is off by about n eps * magnitude.
    const double tol = 16.0 * std::numeric_limits<double>::epsilon() * magnitude;
    if (std::abs(sum) <= tol) return;
    throw std::invalid_argument(describe(what_) + " is " + shortest_text(sum) +
                                ", not zero to round-off (the terms are " + shortest_text(magnitude) + " in magnitude)");
}

/// Throw std::invalid_argument unless v is finite.
template <class What>
void require_finite(double v, const What& what) {
    if (!std::isfinite(v)) throw std::invalid_argument(describe(what) + " must be finite, got " + shortest_text(v));
}

/// Throw std::invalid_argument unless v is finite and either 0 or a normal number: a subnormal one
/// (below 2.2e-308) has lost precision already and its products underflow to 0.
template <class What>
void require_normal(double v, const What& what) {
    require_finite(v, what);
    if (v != 0.0 && std::abs(v) < std::numeric_limits<double>::min())
        throw std::invalid_argument(describe(what) + " = " + shortest_text(v) +
                                    " is subnormal (below 2.2e-308): its products underflow to 0; give 0 or a "
                                    "normal number");
}

/// Throw std::invalid_argument unless a product or power computed from the inputs (`value`, described by
/// `what`) is finite and, when it should not vanish, normal: the inputs' scale is beyond double precision.
template <class What>
void require_representable(double value, const What& what, bool must_be_nonzero = true) {
    if (!std::isfinite(value))
        throw std::invalid_argument(describe(what) + " overflows double precision (" + shortest_text(value) + ")");
    if (must_be_nonzero && std::abs(value) < std::numeric_limits<double>::min())
        throw std::invalid_argument(describe(what) + " underflows double precision (" + shortest_text(value) + ")");
}

}  // namespace detail
}  // namespace eci

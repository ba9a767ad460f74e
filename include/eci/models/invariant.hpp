// A named invariant of a model: the CLI, the tests and the benchmarks all measure through these.
#pragma once

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace eci {

/// An invariant's name (a CSV column) and the model's member function that computes it.
template <class Model>
struct named_invariant {
    const char* name;
    double (Model::*value)(const typename Model::state_type&) const;
};

namespace detail {

/// Throw std::invalid_argument("<what> ...") unless |sum| is round-off relative to the sum of magnitudes.
inline void require_cancellation(double sum, double magnitude, const std::string& what) {
    // Each term carries at most one rounding, so the sum of n terms is off by about n eps * magnitude.
    const double tol = 16.0 * std::numeric_limits<double>::epsilon() * magnitude;
    if (!(std::abs(sum) <= tol))
        throw std::invalid_argument(what + " is " + std::to_string(sum) + ", not zero to round-off");
}

/// Throw std::invalid_argument unless v is finite.
inline void require_finite(double v, const std::string& what) {
    if (!std::isfinite(v)) throw std::invalid_argument(what + " must be finite");
}

}  // namespace detail
}  // namespace eci

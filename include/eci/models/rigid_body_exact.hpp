// The exact solution of Biswas & Ketcheson's rigid body in Jacobi elliptic functions (Boost.Math), m = 0.51:
// u(t) = (sqrt(1.51) sn(t, m), cn(t, m), dn(t, m)) for the default parameters and u(0) = (0, 1, 1).
#pragma once

#include <cmath>
#include <stdexcept>

#include <boost/math/special_functions/jacobi_elliptic.hpp>

#include "rigid_body.hpp"

namespace eci {

/// The exact state of the default rigid body from (0, 1, 1) at time t; Boost.Math's parameter is the modulus
/// k = sqrt(m).
inline rigid_body::state_type rigid_body_exact(double t) {
    if (!std::isfinite(t)) throw std::invalid_argument("rigid body exact solution: t must be finite");
    double cn = 0.0, dn = 0.0;
    const double sn = boost::math::jacobi_elliptic(std::sqrt(0.51), t, &cn, &dn);
    return {std::sqrt(1.51) * sn, cn, dn};
}

}  // namespace eci

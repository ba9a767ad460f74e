// A sum with its rounding error carried: what the remedy's Gram matrices and a weighted invariant of many terms
// (sum_k w_k |x_k|^2 over a large state) need to be accurate whatever the order and sizes of the terms.
#pragma once

namespace eci {

/// A running sum with its rounding error carried (Knuth's TwoSum per addition, branch-free): `add(v)` for each
/// term, then `value()`, accurate to about one rounding of the result whatever the order and sizes of the terms.
struct compensated_sum {
    double s = 0.0, err = 0.0;
    /// Adds v.
    void add(double v) {
        const double t = s + v, z = t - s;
        err += (s - (t - z)) + (v - z);
        s = t;
    }
    /// The sum.
    double value() const { return s + err; }
};

}  // namespace eci

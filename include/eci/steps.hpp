// How many fixed steps span an interval: the one rule the drivers, the models' presets and the front ends share.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace eci {

/// The most fixed steps a run takes: the grid t0 + k dt is exact up to k = 2^53 (k converts to a double exactly),
/// and a run of more steps would not end in a lifetime. The library refuses more (solve's check_config, run_grid),
/// and so do the front ends, under their own option names.
inline constexpr std::uint64_t max_grid_steps = std::uint64_t(1) << 53;

/// The number of steps of size dt that reach t_end from t0: at least one whenever t_end > t0, however short
/// the span (a shorter last step, see integrate_to). Only a remainder at round-off level, the few eps of q
/// that (t_end - t0) / dt carries, is not a step of its own (3 * 0.1 reaches 0.3 in 3 steps). More than 2^64 - 1
/// steps (or no count at all: dt zero or NaN) read as 2^64 - 1.
inline std::uint64_t steps_to_reach(double t0, double t_end, double dt) {
    if (!(t_end > t0)) return 0;
    const double q = (t_end - t0) / dt;
    // (under half a step: beyond 2^49 steps 8 eps q is a whole step or more, and a step of the grid was dropped)
    const double slack = std::min(0.5, 8.0 * std::numeric_limits<double>::epsilon() * std::max(1.0, q));
    const double n = std::ceil(q - slack);
    // (a count beyond the integers, or a NaN from a zero or NaN dt, saturates: converting it is undefined)
    if (!(n < 0x1p64)) return std::numeric_limits<std::uint64_t>::max();
    return std::max<std::uint64_t>(1, static_cast<std::uint64_t>(n));
}

/// The largest step of at most dt that divides h into whole steps: h / ceil(h / dt). For a step the front end
/// chose itself (the spectral equations' CFL step) when the outputs are every h of time, so that they fall on the
/// grid, every k = h / step steps. A step the user gives is not changed: resolve_output_dt checks that h is a
/// multiple of it. An h or dt that is not positive and finite, or more than max_grid_steps steps in h, leaves dt as
/// it is (for the checks to refuse).
inline double step_dividing(double h, double dt) {
    if (!(h > 0.0) || !(dt > 0.0) || !std::isfinite(h) || !std::isfinite(dt)) return dt;
    const double k = std::ceil(h / dt);
    return k <= double(max_grid_steps) ? h / k : dt;
}

/// The size of the last of the n = steps_to_reach(t0, t_end, dt) steps that land on t_end (n >= 1): dt when
/// t0 + n dt misses t_end by round-off only (3 * 0.1 != 0.3), else the shorter remainder (integrate_to's last step).
inline double last_step_to_reach(double t0, double t_end, double dt, std::uint64_t n) {
    const double gap = t_end - (t0 + double(n - 1) * dt);
    return std::abs(gap - dt) <= 1e-12 * dt ? dt : gap;
}

}  // namespace eci

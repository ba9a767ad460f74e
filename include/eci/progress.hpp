// The progress line of a long run as both front ends draw it (`eci run`'s bar on stderr, `eci.solve(progress=)`'s
// on sys.stderr): when it is drawn and what it says, written once.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>

namespace eci {

/// When a progress line is drawn: from a second into the run (a short run shows nothing), then at most ten times a
/// second.
class progress_pace {
   public:
    progress_pace() : start_(std::chrono::steady_clock::now()) {}
    /// Whether a line is due now; if so it counts as drawn now.
    bool due() {
        using namespace std::chrono;
        const auto now = steady_clock::now();
        if (now - start_ < seconds(1) || (drawn_ && now - last_draw_ < milliseconds(100))) return false;
        drawn_ = true;
        last_draw_ = now;
        return true;
    }
    /// Seconds from the start to the last line drawn.
    double elapsed() const { return std::chrono::duration<double>(last_draw_ - start_).count(); }

   private:
    std::chrono::steady_clock::time_point start_, last_draw_;
    bool drawn_ = false;
};

/// "[##########..............................]  25.3%  t = 2.53          14 s left": a bar of 40 marks for the
/// `fraction` of the run done (taken within [0, 1]; NaN as 0) at time t, and the seconds left at the pace of
/// `elapsed` seconds so far.
inline std::string progress_text(double fraction, double t, double elapsed) {
    fraction = fraction >= 0.0 ? std::min(fraction, 1.0) : 0.0;
    constexpr int width = 40;
    std::string bar(width, '.');
    std::fill_n(bar.begin(), static_cast<int>(fraction * width), '#');
    const double left = fraction > 0.0 ? elapsed * (1.0 - fraction) / fraction : 0.0;
    char text[96];
    std::snprintf(text, sizeof text, "] %5.1f%%  t = %-12.6g  %.0f s left", 100.0 * fraction, t, left);
    return "[" + bar + text;
}

}  // namespace eci

// Figure 7 (Lotka-Volterra) and Figures 8, 9 (Kepler): placeholder until the models land.
#include "figures_common.hpp"

namespace eci::cli::detail {

static figure_result unavailable(int n) {
    figure_result r;
    r.number = n;
    r.available = false;
    r.unavailable_reason = "model not yet in the library";
    return r;
}
figure_result make_figure_7() { return unavailable(7); }
figure_result make_figure_8() { return unavailable(8); }
figure_result make_figure_9() { return unavailable(9); }

}  // namespace eci::cli::detail

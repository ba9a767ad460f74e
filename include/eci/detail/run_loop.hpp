// The one run loop: every run, fixed steps or adaptive, takes its attempts here. A controller decides where each
// attempt goes and what its outcome means:
//
//   c.more()              whether the run has a step left to take
//   c.propose()           the next attempt (its time and step); polls, hooks and budgets that precede an attempt
//   c.attempt(a)          takes it with the stepper
//   c.acceptable(r)       whether the attempt's result is accepted
//   c.accept(a, r)        takes the accepted attempt into the run; true when a step of the run is complete
//   c.reject(a, r)        a failed or rejected attempt: the controller shrinks the step, or throws to stop the run
//
// The fixed-step controller (integrate.hpp) walks the grid t0 + k dt, halving a failed step; the error controller
// (adaptive.hpp) sizes the steps from the embedded error estimate. on_step() is called after every complete step
// of the run (a step of the grid, or an accepted adaptive step): outputs, monitors and sinks hang there.
#pragma once

namespace eci::detail {

template <class Controller, class OnStep>
void run_loop(Controller& c, OnStep&& on_step) {
    while (c.more()) {
        const auto a = c.propose();
        const auto r = c.attempt(a);
        if (!c.acceptable(r))
            c.reject(a, r);
        else if (c.accept(a, r))
            on_step();
    }
}

}  // namespace eci::detail

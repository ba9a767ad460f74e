// The one run loop: every run, fixed steps or adaptive, takes its attempts here. A controller decides where each
// attempt goes and what its outcome means:
//
//   c.start()             where the run is (the position at): what changes at every step, held by the loop
//   c.more(at)            whether the run has a step left to take
//   c.propose(at)         the next attempt (its time and step); polls, hooks and budgets that precede an attempt
//   c.attempt(a, at)      takes it with the stepper
//   c.acceptable(r)       whether the attempt's result is accepted
//   c.accept(a, r, at)    takes the accepted attempt into the run; true when a step of the run is complete
//   c.reject(a, r, at)    a failed or rejected attempt: the controller shrinks the step, or throws to stop the run
//   c.leave(at)           the run ended: what the position counted is stored where the run's statistics read it
//
// The fixed-step controller (integrate.hpp) walks the grid t0 + k dt, halving a failed step; the error controller
// (adaptive.hpp) sizes the steps from the embedded error estimate. on_step(at) is called after every complete step
// of the run (a step of the grid, or an accepted adaptive step): outputs, monitors and sinks hang there.
//
// The position is a local of the loop, not a member of the controller, and a failed attempt is the unlikely branch:
// a run's per-step state (and a small state itself, fixed_control) then stays in registers across a run of a
// small system, where a member of a controller whose address escapes to its cold paths is stored and loaded at
// every step (on three-wave, a PC step 9.5 ns against 6.6: bench/step_bench.cpp, three_wave_run). The fixed-step
// position also counts the evaluations and steps, stored only where they are read (leave, an observer that takes
// the statistics, a failed attempt): counted through references they were stored at every evaluation. The loop has
// no catch: a handler reading the position kept it in memory (10 more instructions per three-wave PC step).
#pragma once

namespace eci::detail {

/// The loop from position `at` on (run_loop's body; a controller that has settled a first attempt itself goes on
/// here: fixed_control::run_after_failed).
template <class Controller, class Position, class OnStep>
[[gnu::always_inline]] inline void run_loop_from(Controller& c, Position& at, OnStep& on_step) {
    while (c.more(at)) {
        const auto a = c.propose(at);
        const auto r = c.attempt(a, at);
        if (!c.acceptable(r)) [[unlikely]]
            c.reject(a, r, at);
        else if (c.accept(a, r, at))
            on_step(at);
    }
    c.leave(at);
}

template <class Controller, class OnStep>
void run_loop(Controller& c, OnStep&& on_step) {
    auto at = c.start();
    run_loop_from(c, at, on_step);
}

}  // namespace eci::detail

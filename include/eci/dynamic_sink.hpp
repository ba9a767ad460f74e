// A run's sink behind virtual calls, so that a model's runs compile once and serve every front end: the CLI's CSV
// writer and Python's arrays call the same compiled solve_model<Model> (one translation unit per model of the list,
// built once and linked into both). The sink is called at outputs and between steps, never inside one, so the
// virtual calls cost nothing a step would notice.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>
#include <vector>

#include "solve.hpp"

namespace eci {

/// An accepted step of an adaptive run (eci::accepted_step) behind virtual calls: its ends and its dense output.
template <class S>
class step_view {
   public:
    virtual double t_start() const = 0;
    virtual double t_end() const = 0;
    virtual const S& start_state() const = 0;
    virtual const S& end_state() const = 0;
    /// The state at time t of the step (accepted_step::at), and with `conventional` the conventional interpolant
    /// whose sign a conservative one takes.
    virtual void at(double t, S& out, S* conventional = nullptr) = 0;
    /// Whether the dense output interpolates every real unknown's square (a conservative pair).
    virtual bool dense_of_squares() const = 0;
    /// The degree of the dense output's interpolant (4 where the stepper does not say).
    virtual int dense_degree() const = 0;

   protected:
    ~step_view() = default;
};

namespace detail {

template <class S, class Step>
class step_view_of final : public step_view<S> {
    using St = typename Step::stepper_type;

   public:
    explicit step_view_of(Step& s) : s_(s) {}
    double t_start() const override { return s_.t_start(); }
    double t_end() const override { return s_.t_end(); }
    const S& start_state() const override { return s_.start_state(); }
    const S& end_state() const override { return s_.end_state(); }
    void at(double t, S& out, S* conventional) override { s_.at(t, out, conventional); }
    bool dense_of_squares() const override {
        if constexpr (requires { St::dense_of_squares; })
            return St::dense_of_squares;
        else
            return false;
    }
    int dense_degree() const override {
        if constexpr (requires { St::dense_degree; })
            return St::dense_degree;
        else
            return 4;
    }

   private:
    Step& s_;
};

}  // namespace detail

/// A sink (solve.hpp's protocol) whose calls are virtual: output at every output; progress after every step (or
/// before every adaptive attempt), which may throw to stop the run; with observes_steps(), accepted() for every
/// accepted step of an adaptive run, returning a time within it at which to stop (an event) or none.
template <class S>
class dynamic_sink {
   public:
    virtual ~dynamic_sink() = default;
    virtual void output(const S& x, const output_point& p) = 0;
    virtual void progress(double /*t*/, std::uint64_t /*steps*/) {}
    virtual bool observes_steps() const { return false; }
    virtual std::optional<double> accepted(step_view<S>& /*step*/) { return std::nullopt; }

    /// The run's call for an accepted step of any stepper: accepted() on its view.
    template <class Step>
    std::optional<double> step(Step& s) {
        detail::step_view_of<S, Step> view(s);
        return accepted(view);
    }
};

/// solve<Model>(model, x, method, cfg, sink, extra, what), compiled where eci/solve_model.hpp instantiates it
/// (ECI_INSTANTIATE_SOLVE_MODEL): a caller that sees this declaration alone compiles none of the model's runs.
template <class Model>
solve_report solve_model(const Model& model, typename Model::state_type& x, std::string_view method,
                         const run_config& cfg, dynamic_sink<typename Model::state_type>& sink,
                         std::vector<extra_invariant<typename Model::state_type>> extra = {},
                         std::string_view what = "this system");

}  // namespace eci

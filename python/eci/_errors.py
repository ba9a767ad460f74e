"""eci's exceptions (bad input is ValueError or TypeError, as in NumPy and SciPy)."""


class _RunFailure(RuntimeError):
    """Common part of eci's run failures: where the run stopped and its statistics up to there."""

    def __init__(self, message, t, component, component_name, dt, cause, stats):
        super().__init__(message)
        self.t = t
        self.component = component
        self.component_name = component_name
        self.dt = dt
        self.cause = cause
        self.stats = stats

    def __reduce__(self):
        return (type(self), (str(self), self.t, self.component, self.component_name, self.dt, self.cause,
                             self.stats))


class StepSizeUnderflow(_RunFailure):
    """A step failed at every size allowed.

    Fixed steps (dt): a step failed even after halving it max_halvings times (default 40: dt * 2**-40). A step fails
    on a negative radicand, a transform that cannot be inverted, an implicit solve that does not converge, or a
    non-finite value returned by fun; eci retries it as two half steps, and gives up here.
    Adaptive control (rtol/atol): the step the controller asked for fell below min_step (default 64 eps |t|).

    Attributes: t (start of the failed step), component (index of the real unknown that failed, or with the largest
    error; for complex y, 2 i is Re y[i] and 2 i + 1 is Im y[i]), component_name, dt (the last step size tried),
    cause ("step_failed", "non_finite_fun", or for adaptive runs also "error_estimate": the last rejection's cause)
    and stats (the run's statistics up to the failure, as SolveResult.stats).
    """


class TooManySteps(_RunFailure):
    """An adaptive run took max_steps attempts (accepted and rejected) without reaching the end.

    Attributes as StepSizeUnderflow (cause "too_many_steps").
    """


class NonFiniteSolution(_RunFailure):
    """The solution blew up: a step left a non-finite state (cause "non_finite_state"), or an invariant that was
    finite at the start became inf or nan (cause "invariant_overflow"), or, on a spectral flow, its energy grew a
    thousandfold beyond the initial energy and what the forcing injected (cause "blow_up"), as `eci run` stops on
    them.

    Attributes as StepSizeUnderflow (component: the real unknown, or for invariant_overflow the invariant's index).
    """

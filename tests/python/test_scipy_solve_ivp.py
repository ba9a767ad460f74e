# SciPy's own tests of solve_ivp (scipy/integrate/_ivp/tests/test_ivp.py of the installed SciPy, Debian's
# python3-scipy 1.10.1) run against eci.solve, with only the method names mapped: RK23 -> bs32, RK45 -> dp54,
# DOP853 -> dp853 and, a second time, RK23 -> c-bs32, RK45 -> c-dp54, DOP853 -> c-dp853.
#
# The test module is read and rewritten in memory exactly as test_scipy_suite.py does for the OdeSolver classes
# (each test function runs once per explicit method it covers); here its `solve_ivp` is replaced by an adapter
# that only maps the method (a name or one of the classes RK23, RK45, DOP853) to eci's name and calls eci.solve
# with every other argument unchanged. The module's RK23/RK45/DOP853 are eci.scipy's classes (some tests also build
# the solver directly). Only the test functions that call solve_ivp are cases; those of the classes alone are
# test_scipy_suite.py's.
#
# The cases that cannot pass are strict xfails, each with the convention that does not apply and why;
# docs/python.md has the counts.
import ast

import pytest

pytest.importorskip("scipy.integrate")

import eci  # noqa: E402
import eci.scipy  # noqa: E402
from test_scipy_suite import MODULES, SCIPY_EXPLICIT, VARIANTS  # noqa: E402

NAMES = {
    "conventional": {"RK23": "bs32", "RK45": "dp54", "DOP853": "dp853"},
    "conservative": {"RK23": "c-bs32", "RK45": "c-dp54", "DOP853": "c-dp853"},
}

LANDING = ("t_eval with and without dense_output must give the same y (assert_equal); eci serves t_eval from "
           "the dense output only where it is as accurate as the steps (dp54's and dp853's continuous extensions, "
           "bs32's Hermite) and lands steps on the times otherwise ({}), while dense_output=True takes every output "
           "from the dense output, as SciPy: the two differ by less than the tolerance, not bit for bit")
# (test, eci method) -> why it cannot pass; each reason checked by hand on the failing run.
KNOWN = {
    ("test_t_eval_dense_output", "c-dp54"): LANDING.format("c-dp54: the conservative continuous extension errs up "
                                                          "to 9x the steps near a zero of y"),
    ("test_integration_complex", "c-dp54"): (
        "a work bound of RK45 (nfev < 25 on y' = -y): the conservative pair's error estimate measures its own "
        "solution (psi from the tableau applied to psi^2), which rejects the long second step RK45 takes (as for "
        "eci.scipy.CDP54 in test_scipy_suite.py)"),
}
INFINITE = ("integrates over t_span [0, inf] (an empty y0): eci's run needs a finite end time (its step floor, "
            "output times and the CLI's --t-end are all relative to it)")
for m in NAMES["conventional"].values():
    KNOWN[("test_empty", m)] = INFINITE
    KNOWN[("test_empty", "c-" + m)] = INFINITE


def _calls_solve_ivp(module_name, test_name):
    path = MODULES[module_name][0]["__file__"]
    tree = ast.parse(open(path).read())
    fn = next(f for f in tree.body if isinstance(f, ast.FunctionDef) and f.name == test_name)
    # a call of solve_ivp, or solve_ivp passed to one (assert_no_warnings(solve_ivp, ...))
    return any(isinstance(n, ast.Name) and n.id == "solve_ivp" for n in ast.walk(fn))


CASES = []
namespace, cases = MODULES["test_ivp"]
for variant, names in NAMES.items():
    for test_name, methods in cases.items():
        if not _calls_solve_ivp("test_ivp", test_name):
            continue
        for scipy_name, param in methods:
            key = (test_name, names[scipy_name])
            marks = [pytest.mark.xfail(reason=KNOWN[key], strict=True)] if key in KNOWN else []
            CASES.append(pytest.param(variant, test_name, scipy_name, param, marks=marks,
                                      id=f"{test_name}[{scipy_name}->{names[scipy_name]}]"))


def test_case_count():
    # test_ivp's 13 functions that call solve_ivp with an explicit method, times their explicit methods (31 cases),
    # for each of the two mappings
    assert len(CASES) == 2 * 31, len(CASES)


@pytest.mark.parametrize("variant, test_name, scipy_name, param", CASES)
def test_scipy_solve_ivp(variant, test_name, scipy_name, param, monkeypatch):
    names, classes = NAMES[variant], VARIANTS[variant]
    ran = []

    def solve_ivp(fun, t_span, y0, method="RK45", **kwargs):
        if isinstance(method, type):
            method = next(k for k, c in classes.items() if c is method)
        ran.append(method)
        return eci.solve(fun, t_span, y0, method=names[method], **kwargs)

    monkeypatch.setitem(namespace, "solve_ivp", solve_ivp)
    for name, cls in classes.items():
        monkeypatch.setitem(namespace, name, cls)
    monkeypatch.setitem(namespace, "__eci_name__", scipy_name)
    monkeypatch.setitem(namespace, "__eci_class__", classes[scipy_name])
    kwargs = {}
    if param is not None:
        arg, kind = param
        kwargs[arg] = scipy_name if kind == "name" else classes[scipy_name]
    namespace[test_name](**kwargs)
    assert ran and set(ran) == {scipy_name}, ran  # eci.solve ran, with the method under test only

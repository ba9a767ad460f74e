"""Built-in models whose right-hand side and whole integration run in C++ (eci.solve(model, t_span)).

Each is callable as model(t, y) (SciPy's fun, so it can be compared with scipy.integrate.solve_ivp directly),
evaluates its invariants with model.invariants(y), and carries the CLI's defaults: default_y0, default_dt,
default_t_end and the methods it accepts. Invalid parameters raise ValueError with the CLI's message. The paper's
set-ups are named presets: ThreeWave.preset("fig2").solve() is `eci run three-wave --preset fig2`.
"""

import numbers as _numbers
import re as _re
import weakref as _weakref
from collections import namedtuple as _namedtuple

import numpy as _np

from . import _eci
from ._eci import Model

# One class per model of the C++ model list (include/eci/models/list.hpp), in `eci list` order, each named after
# its CLI name in CamelCase (three-wave: ThreeWave) and built from the model's own description: its parameters
# as constructor keywords with the CLI's defaults, read-only properties, presets. NWave (below) picks n-wave's
# real or complex class.
ode_models = tuple(_eci._ode_models)
for _cls in ode_models:
    globals()[_cls.__name__] = _cls
_NWaveReal, _NWaveComplex = _eci.NWave, _eci.NWaveComplex

__all__ = ["Model", "Preset", "ode_models"] + [c.__name__ for c in ode_models]

# One class per spectral equation of eci::spectral::equations() (built with eci::spectral, FFTW3, only), named as
# the equation module says (navier-stokes-2d: NavierStokes2D), in `eci list` order.
flow_models = tuple(getattr(_eci, "_flow_models", ()))
for _cls in flow_models:
    globals()[_cls.__name__] = _cls
__all__ += ["flow_models"] + [c.__name__ for c in flow_models]


class Preset(_namedtuple("Preset", "name description model y0 method dt t_end")):
    """A named set-up of a model (the paper's figures): the model with its parameters, the initial state y0, the
    method, the step dt and the span [0, t_end], as `eci run MODEL --preset NAME` runs it."""

    __slots__ = ()

    def solve(self, **overrides):
        """eci.solve on this set-up; keyword arguments (method, dt, t_eval, rtol, ...) override its settings (with
        rtol/atol and no method, the model's default adaptive method, as `eci run MODEL --preset NAME --rtol R`)."""
        from . import solve

        settings = {"method": self.method, "dt": self.dt}
        if "rtol" in overrides or "atol" in overrides:
            # the preset's step is the first step, as `--preset NAME --rtol R` takes its --dt (shortened to a span
            # shorter than it, as the CLI's default --dt is); first_step= overrides it
            dt = settings.pop("dt")
            if dt is not None and self.t_end > 0.0:
                settings["first_step"] = min(dt, self.t_end)
            if self.method not in self.model.adaptive_methods:  # the model's default adaptive method, as the CLI's
                settings.pop("method")                           # `--preset NAME --rtol R` without --method
        settings.update(overrides)
        return solve(self.model, (0.0, self.t_end), self.y0, **settings)


# How each model object was made, so that it can be pickled and copied (its class is compiled and keeps no such
# record): the constructor's arguments, or the preset it is the model of. Weak: the record goes with the object.
_made = _weakref.WeakKeyDictionary()


def _rebuild(cls, args, kwargs):
    """A model made again by its constructor (unpickling, copy.copy and copy.deepcopy)."""
    return cls(*args, **kwargs)


def _rebuild_preset(cls, name):
    """The model of preset `name` of cls, made again."""
    return _preset(cls, name).model


def _rebuild_flow(cls, args, kwargs, rng_state):
    """A spectral model made again, its stochastic forcing's generator where the original's stood."""
    m = cls(*args, **kwargs)
    m._rng_state = rng_state
    return m


def _reduce(self):
    made = _made.get(self)
    if made is None:
        raise TypeError(f"cannot pickle this {type(self).__name__}: it was not made by its constructor or a preset")
    if hasattr(self, "_rng_state"):  # a spectral model: its generator has moved on with every solve
        return (_rebuild_flow, made[1] + (self._rng_state,))
    return made


def _presets(cls):
    """Every preset of the model class cls, in the CLI's order (the first is what `eci run MODEL` does)."""
    presets = [Preset(*p) for p in cls._presets()]
    for p in presets:
        _made[p.model] = (_rebuild_preset, (cls, p.name))
    return presets


def _preset(cls, name):
    """The preset of the model class cls called name; ValueError naming the presets there are."""
    presets = _presets(cls)
    for p in presets:
        if p.name == name:
            return p
    raise ValueError(f"unknown preset {name!r} (presets: {', '.join(p.name for p in presets)})")


for _cls in ode_models:
    _cls.presets = classmethod(_presets)
    _cls.preset = classmethod(_preset)


def _is_bool(v):
    if isinstance(v, (bool, _np.bool_)):
        return True
    if isinstance(v, (list, tuple)):
        return any(_is_bool(x) for x in v)
    return isinstance(v, _np.ndarray) and v.dtype.kind == "b"


def _keywords(init, types=False):
    """The keyword parameters of a compiled constructor, from its signature (pybind11's first line of help)."""
    head = (init.__doc__ or "").split("\n", 1)[0]
    params = _re.findall(r"(\w+): ([^=,]+?)(?: = [^,]*)?(?:,|\) ->)", head.split(",", 1)[1] if "," in head else "")
    return params if types else [name for name, _ in params]


def _fits(v, t):
    """Whether v is a value of the compiled signature's type t (float, int, str, bool, Optional[...]; others: yes)."""
    optional = _re.fullmatch(r"Optional\[(.+)\]", t)
    if optional:
        return v is None or _fits(v, optional.group(1))
    if t == "float":
        return isinstance(v, _numbers.Real) and not _is_bool(v)
    if t == "int":
        return isinstance(v, _numbers.Integral) and not _is_bool(v)
    if t == "str":
        return isinstance(v, str)
    if t == "bool":
        return isinstance(v, (bool, _np.bool_))
    return True


def _type_text(t):
    optional = _re.fullmatch(r"Optional\[(.+)\]", t)
    if optional:
        return _type_text(optional.group(1)) + " or None"
    return {"float": "a real number", "int": "a whole number", "str": "a string", "bool": "True or False"}.get(t, t)


def _wrong_argument(what, function, args, kwargs):
    """The one-line TypeError of a call pybind11 refused ("incompatible function arguments" and the signature over
    many lines): the first argument that is not of its type, by name, or None where none is found."""
    params = _keywords(function, types=True)
    given = list(zip(params, args)) + [((k, dict(params).get(k)), v) for k, v in kwargs.items()]
    for (name, t), v in given:
        if t is not None and not _fits(v, t.strip()):
            return TypeError(f"{what}: {name} must be {_type_text(t.strip())}, not {type(v).__name__} {v!r}")
    return None


def _one_line_type_errors(cls, names):
    """Wraps the compiled methods `names` of cls so that an argument of the wrong type is one line naming it."""
    def wrapped(name, method):
        def call(self, *args, **kwargs):
            try:
                return method(self, *args, **kwargs)
            except TypeError as e:
                if "incompatible function arguments" not in str(e):
                    raise
                wrong = _wrong_argument(f"{type(self).__name__}.{name}()", method, args, kwargs)
                if wrong is None:
                    raise
                raise wrong from None

        call.__name__, call.__qualname__, call.__doc__ = name, f"{cls.__name__}.{name}", method.__doc__
        return call

    for name in names:
        setattr(cls, name, wrapped(name, cls.__dict__[name]))


def _refuse_bools(cls, flags=()):
    """A parameter given as True or False is a mistake the compiled constructor would read as 1 or 0 (nu=True as
    a viscosity of 1, threads=True as one thread): refused with TypeError naming it. `flags` are the parameters
    that are booleans (fftw_measure, full_transforms), and only True or False is taken for them (the compiled
    constructor read any object with a truth value, 1.5 or "no", as True); with flags, positional arguments are not
    checked (their names are unknown)."""
    init = cls.__init__

    def __init__(self, *args, **kwargs):
        given = ([] if flags else list(enumerate(args))) + [(k, v) for k, v in kwargs.items() if k not in flags]
        for name, v in given:
            if _is_bool(v):
                what = f"argument {name + 1}" if isinstance(name, int) else name
                raise TypeError(f"{cls.__name__}: {what} must be a number, not bool")
        for name in flags:
            if name in kwargs and not isinstance(kwargs[name], (bool, _np.bool_)):
                raise TypeError(f"{cls.__name__}: {name} must be True or False, not {type(kwargs[name]).__name__}")
        try:
            init(self, *args, **kwargs)
        except TypeError as e:  # pybind11's many lines ("incompatible constructor arguments", the signature): one
            if "incompatible constructor arguments" not in str(e):
                raise
            known = _keywords(init)
            unknown = [k for k in kwargs if k not in known]
            if unknown:
                raise TypeError(f"{cls.__name__}() got an unexpected keyword argument {unknown[0]!r} (it takes: "
                                f"{', '.join(known)})") from None
            if len(args) > len(known):
                raise TypeError(f"{cls.__name__}() takes at most {len(known)} arguments ({len(args)} given)") from None
            wrong = _wrong_argument(f"{cls.__name__}()", init, args, kwargs)
            if wrong is not None:
                raise wrong from None
            raise TypeError(f"{cls.__name__}(): an argument of the wrong type (it takes: "
                            f"{', '.join(f'{k}: {t}' for k, t in _keywords(init, types=True))})") from None
        _made[self] = (_rebuild, (cls, args, dict(kwargs)))

    __init__.__doc__ = init.__doc__
    cls.__init__ = __init__
    cls.__reduce__ = _reduce


def _generated_repr(compiled):
    """The repr of a model generated from its constructor's arguments (n-wave: modes, triads_per_mode, seed make the
    triads, which the model holds instead): the constructor call that made it, as a spectral model's repr is, or
    the preset it is the model of; the compiled description where the object has no such record."""
    def __repr__(self):
        made = _made.get(self)
        if made is None:
            return compiled(self)
        cls = type(self)
        if made[0] is _rebuild_preset:
            return f"{cls.__name__}.preset({made[1][1]!r}).model"
        _, args, kwargs = made[1]
        names = [p[1] for p in cls._parameters()]
        given = [f"{names[i]}={v!r}" if i < len(names) else repr(v) for i, v in enumerate(args)]
        return f"{cls.__name__}({', '.join(given + [f'{k}={v!r}' for k, v in kwargs.items()])})"
    return __repr__


for _cls in ode_models:
    _refuse_bools(_cls)
    if hasattr(_cls, "triads"):
        _cls.__repr__ = _generated_repr(_cls.__repr__)
for _cls in flow_models:
    _refuse_bools(_cls, flags=("fftw_measure", "full_transforms"))
    _one_line_type_errors(_cls, [k for k, v in vars(_cls).items() if type(v).__name__ == "instancemethod"
                                 and not k.startswith("_")])


def NWave(*args, complex=False, **kwargs):
    """NWave(modes, triads_per_mode, seed, complex=False): a random n-wave system (paper §III.C): `modes` real (or,
    with complex=True, complex) modes, each in about `triads_per_mode` triads obeying eqs. (2)-(3);
    triads_per_mode=1 gives independent triads. The system and its default initial condition are drawn from `seed`
    by a portable generator: the same as `eci run n-wave --seed`, with the same defaults."""
    return (_NWaveComplex if complex else _NWaveReal)(*args, **kwargs)


NWave.presets = lambda complex=False: _presets(_NWaveComplex if complex else _NWaveReal)
NWave.preset = lambda name, complex=False: _preset(_NWaveComplex if complex else _NWaveReal, name)

# Model objects pickle, copy and deep-copy (multiprocessing pools and copy.deepcopy need it): each is made again the
# way it was made, by its constructor's arguments or as its preset's model, and runs to the same bits.
import copy
import pickle

import numpy as np
import pytest

import eci

M = eci.models


def made():
    models = [M.ThreeWave(), M.NWave(modes=30, seed=7), M.NWave(modes=12, complex=True), M.LotkaVolterra(mu=1.2),
              M.Kepler(K=2.0), M.RigidBody(), M.ExpEntropy(), M.ThreeWave.preset("fig5").model,
              M.NWave.preset("standard").model]
    for cls in M.flow_models:  # every spectral equation, with settings that must travel too
        models.append(cls(n=16, nu=1e-3, forcing="stochastic", injection_rate=0.5, forcing_seed=3))
    return models


@pytest.mark.parametrize("index", range(len(made())), ids=lambda i: type(made()[i]).__name__)
@pytest.mark.parametrize("how", ["pickle", "copy", "deepcopy"])
@pytest.mark.parametrize("used", [False, True], ids=["new", "after-a-solve"])
def test_a_model_is_made_again_as_it_was_made(index, how, used):
    model = made()[index]
    if used:  # a spectral model's stochastic forcing has moved on: the copy continues where the original stands
        eci.solve(model, (0.0, 0.02), dt=0.01)
    again = {"pickle": lambda m: pickle.loads(pickle.dumps(m)), "copy": copy.copy, "deepcopy": copy.deepcopy}[how](model)
    assert type(again) is type(model) and again is not model
    assert repr(again) == repr(model)
    assert np.array_equal(again.default_y0, model.default_y0)  # (a preset's own initial state too: fig5's)
    dt = None if type(model) in M.flow_models else 0.01
    a = eci.solve(model, (0.0, 0.05), dt=dt)
    b = eci.solve(again, (0.0, 0.05), dt=dt)
    assert np.array_equal(a.y, b.y) and np.array_equal(a.t, b.t)

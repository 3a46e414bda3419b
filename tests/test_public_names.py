"""Each public name has one home: no name is listed in the ``__all__`` of two public modules."""

import importlib
import pkgutil
from collections import defaultdict

import pytest

import sindybench


def _public_modules():
    names = ["sindybench"]
    for info in pkgutil.walk_packages(sindybench.__path__, "sindybench."):
        if not any(part.startswith("_") for part in info.name.split(".")):
            names.append(info.name)
    return names


def _homes():
    homes = defaultdict(list)
    for name in _public_modules():
        for public in getattr(importlib.import_module(name), "__all__", ()):
            homes[public].append(name)
    return homes


def test_the_walk_sees_the_public_modules():
    modules = _public_modules()
    assert {"sindybench.dynamics", "sindybench.search", "sindybench.libraries", "sindybench.simulate"} <= set(modules)
    assert not any(".\x5f" in m for m in modules)


def test_no_name_is_exported_from_two_public_modules():
    twice = {name: where for name, where in _homes().items() if len(where) > 1}
    assert twice == {}


@pytest.mark.parametrize("name, home", [("STLS", "sindybench"), ("SEARCH_PENALTY", "sindybench.search"),
                                        ("Uniform", "sindybench.search"), ("evaluate_terms", "sindybench.dynamics"),
                                        ("simulate", "sindybench.simulate")])
def test_moved_names_keep_their_old_import_paths(name, home):
    old = {"STLS": "sindybench.optimizers", "SEARCH_PENALTY": "sindybench.hidden", "Uniform": "sindybench.model_selection",
           "evaluate_terms": "sindybench.libraries", "simulate": "sindybench.dynamics"}[name]
    assert _homes()[name] == [home]
    assert getattr(importlib.import_module(old), name) is getattr(importlib.import_module(home), name)


def test_kernel_internals_are_not_public():
    from sindybench import dynamics

    internals = {"step_into", "step_workspace", "jacobian_workspace", "step_jacobian_into", "sensitivity_arrays",
                 "coefficient_directions", "user_table", "terms_to_arrays", "simulation_settings", "Settings"}
    assert internals.isdisjoint(dynamics.__all__)


def test_the_version_has_its_own_module():
    from sindybench._version import __version__

    assert sindybench.__version__ == __version__
    assert __version__.count(".") >= 2

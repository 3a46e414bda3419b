"""benchmarks/bench_emps_candidates.py: its probes are order-2 candidates of the identified row, one change each."""

import numpy as np
import pytest

from _benchmarks import benchmark_script


@pytest.fixture(scope="module")
def bench():
    with benchmark_script("bench_emps_candidates") as module:
        yield module


def test_every_probe_changes_one_setting_of_the_row(bench):
    probes = bench.candidates()
    labels = [label for label, *_ in probes]
    assert len(set(labels)) == len(labels) and labels[0] == "the pick"
    z = np.array([[1.0, -2.0, 0.5]])  # Z = [y, y', u] of the order-2 family
    for label, struct, library, refine in probes:
        if struct is None:  # the input lag: Z = [y, y', z, u]
            names = library.fit(np.zeros((1, 4))).get_feature_names_out(["y0", "y0'", "z0", "u0"]).tolist()
            assert "sign(y0')" in names and "z0" in names, label
            continue
        changed = {k for k in bench.ROW if struct[k] != bench.ROW[k]}
        names = library.fit(z).get_feature_names_out(["y0", "y0'", "u0"]).tolist()
        assert len(changed) + (names != bench._pick().fit(z).get_feature_names_out(["y0", "y0'", "u0"]).tolist()) \
            + bool(refine) <= 1, label
    delays = [struct["input_delay"] for _, struct, _, _ in probes if struct is not None]
    assert sorted(set(delays)) == [0, 1, 2, 3, 4, 5, 6, 8, 10, 15]

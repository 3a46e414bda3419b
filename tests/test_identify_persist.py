"""An identified model's file keeps its ``identification_`` record (``records.identification_`` of the envelope)."""

import json

import numpy as np
import pytest

from sindybench import identify, load_model
from sindybench.identify import DataAdvice, ProposedTerm
from sindybench.identify._persist import identification_from_data, identification_to_data
from sindybench.io import model_from_dict, model_to_dict
from sindybench.simulate import simulate


@pytest.fixture(scope="module")
def model():
    t = np.arange(1200) * 0.01
    u = (np.sin(t) + np.sin(2.3 * t))[:, None]
    y = simulate(lambda x, u: np.array([-2.0 * x[0] + u[0]]), [0.0], u, dt=0.01, input_hold="linear")
    return identify(u, y, dt=0.01, families=["first_order"], libraries=["linear", "poly2"],
                    derivatives=["finite_difference"], n_refine=1, show_progress_bar=False)


def _same(a, b, where="record"):
    """``a`` and ``b`` are the same structure: types, keys, values (arrays by dtype, shape and value, nan = nan)."""
    assert type(a) is type(b), f"{where}: {type(a).__name__} != {type(b).__name__}"
    if isinstance(a, dict):
        assert list(a) == list(b), where
        for k in a:
            _same(a[k], b[k], f"{where}[{k!r}]")
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b)):
            _same(x, y, f"{where}[{i}]")
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape, where
        assert np.array_equal(a, b, equal_nan=a.dtype.kind in "fc"), where
    elif isinstance(a, (DataAdvice, ProposedTerm)):
        for name in a.__dataclass_fields__:
            _same(getattr(a, name), getattr(b, name), f"{where}.{name}")
    elif isinstance(a, float) and np.isnan(a):
        assert np.isnan(b), where
    else:
        assert a == b, where


def test_model_file_keeps_the_identification_record(model, tmp_path):
    model.to_json(tmp_path / "model.json")
    loaded = load_model(tmp_path / "model.json")
    record = model.identification_
    assert isinstance(record["data"]["advice"], DataAdvice) and record["data"]["advice"].delay_losses
    _same(record, loaded.identification_)
    assert str(loaded.identification_["data"]["advice"]) == str(record["data"]["advice"])
    assert loaded.equations() == model.equations()
    data = json.loads((tmp_path / "model.json").read_text())  # plain JSON, beside the fitted state
    assert set(data["records"]) == {"identification_"}


def test_a_file_without_the_record_still_loads(model):
    data = model_to_dict(model)
    del data["records"]  # as files written before the record was kept
    loaded = model_from_dict(json.loads(json.dumps(data)))
    assert not hasattr(loaded, "identification_")
    assert loaded.equations() == model.equations()


def test_the_record_of_other_values_round_trips():
    advice = DataAdvice(n_samples=10, n_inputs=1, n_outputs=1, dt=0.1, delay_losses={0: 0.5, 3: np.inf},
                        output_mean=np.array([1.0]), proposed_terms=[ProposedTerm("sqrt", "y0", 0, 0, 0.0, np.inf, "x")])
    record = {"data": {"advice": advice, "poles": [np.array([0.5 + 0.1j, 0.5 - 0.1j])], "gain": 1 + 2j},
              "blocks": [(0, 5), (5, 10)], "cv_results": {"fit_time": [0.1, None], "err": np.array([np.nan, 1.0])}}
    data = json.loads(json.dumps(identification_to_data(record), allow_nan=False))
    _same(record, identification_from_data(data, "records.identification_"))


@pytest.mark.parametrize("records, match", [
    ([1, 2], r"records: expected an object"),
    ({"origin_": {}}, r"records: unknown record 'origin_'"),
    ({"identification_": [1]}, r"records.identification_: expected the identification record"),
    ({"identification_": {"dict": {"a": {"dict": {"__complex__": [1]}}}}}, r"__complex__: expected \[real part"),
    ({"identification_": {"dict": {"a": {"dict": {"__DataAdvice__": {"dict": {"dt": 1.0}}}}}}},
     r"not a DataAdvice"),
])
def test_a_malformed_record_is_refused(model, records, match):
    data = model_to_dict(model)
    data["records"] = records
    with pytest.raises(ValueError, match=match):
        model_from_dict(data)

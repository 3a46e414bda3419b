import json

import numpy as np
import pytest

from sindybench._json import jsonable


@pytest.mark.parametrize(
    ("value", "expected"),
    [(np.bool_(True), True), (np.int64(3), 3), (np.float32(0.5), 0.5), (None, None), ("tanh", "tanh"),
     ((16,), "(16,)"), ([1, 2], "[1, 2]")],
)
def test_jsonable_labels(value, expected):
    out = jsonable(value)
    assert out == expected and type(out) is type(expected)
    assert json.loads(json.dumps(out)) == expected

"""identify._run_stages: what a search keeps of its repeated work is dropped when the search ends."""

import numpy as np
import pytest

from sindybench.hidden import _latent, _regressions
from sindybench.identify._run_stages import _search_memory
from sindybench.optimizers import _forward


@pytest.mark.parametrize("fails", [False, True])
def test_a_search_drops_what_it_kept_when_it_ends(fails):
    # run all's workers run several searches in one process: a search must not carry its kept
    # designs and lag chains (tens of MB on long records) into the next one
    with pytest.raises(RuntimeError) if fails else np.errstate():
        with _search_memory():
            assert _regressions._KEPT is not None  # the regressions are reused inside the search
            _latent._LAG_CHAINS["chain"] = np.zeros(3)
            _forward._LAST.value = {"theta": np.zeros((3, 2))}
            if fails:
                raise RuntimeError("the search failed")
    assert not _latent._LAG_CHAINS
    assert _forward._LAST.value is None
    assert _regressions._KEPT is None

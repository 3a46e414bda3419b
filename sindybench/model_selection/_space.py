"""The search-space dimensions, defined in :mod:`sindybench.search` (kept here for old imports and pickles)."""

from ..search._space import *  # noqa: F401,F403
from ..search._space import __all__  # noqa: F401

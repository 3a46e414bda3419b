"""Old import path of :mod:`sindybench.optimizers._stls` (``from sindybench._stls import STLS`` keeps working)."""

from .optimizers._stls import STLS, GramCache, _shared, clear_stls_cache, stls

__all__ = ["GramCache", "STLS", "clear_stls_cache", "stls"]
__all__ += ["_shared"]  # the shared cache, read by tests and benchmarks

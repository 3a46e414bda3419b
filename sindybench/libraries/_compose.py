"""Old import path of the compositions, which live beside the base class in :mod:`sindybench.libraries._base`."""

from ._base import ConcatLibrary, ProductLibrary

__all__ = ["ConcatLibrary", "ProductLibrary"]

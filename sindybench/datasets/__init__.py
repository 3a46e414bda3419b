"""Benchmark records with the study's splits, data home and checksummed downloads."""

from ._base import DownloadError, RemoteFile, extract_zip, fetch_file, fetch_files, get_data_home, sha256sum
from ._bouc_wen import load_bouc_wen
from ._cascaded_tanks import load_cascaded_tanks
from ._emps import load_emps
from ._interop import as_input_output
from ._pick_and_place import load_pick_and_place
from ._silverbox import load_silverbox

__all__ = [
    "DownloadError",
    "RemoteFile",
    "as_input_output",
    "extract_zip",
    "fetch_file",
    "fetch_files",
    "get_data_home",
    "load_bouc_wen",
    "load_cascaded_tanks",
    "load_emps",
    "load_pick_and_place",
    "load_silverbox",
    "sha256sum",
]

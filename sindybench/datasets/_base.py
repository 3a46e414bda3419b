"""Data home, checksummed downloads and safe archive extraction.

Every remote file is declared as a :class:`RemoteFile`: where it lives in the
data home, the URL it comes from (a plain file or a zip archive, possibly
nested, holding it) and the sha256 of the file itself. A download is written
to a temporary file inside the target folder, verified, and only then moved
into place with :func:`os.replace`; on any failure nothing is left behind.
"""

import hashlib
import http.client
import logging
import os
import shutil
import tempfile
import urllib.error
import urllib.request
import zipfile
from collections import namedtuple
from pathlib import Path, PurePosixPath

__all__ = [
    "DownloadError",
    "RemoteFile",
    "extract_zip",
    "fetch_file",
    "fetch_files",
    "get_data_home",
    "sha256sum",
]

logger = logging.getLogger(__name__)

_CHUNK = 1 << 16

RemoteFile = namedtuple("RemoteFile", ["filename", "url", "sha256", "member"], defaults=(None,))
RemoteFile.__doc__ = """A file of a benchmark record and where to fetch it.

filename : str
    Path relative to the data home, with ``/`` separators
    (e.g. ``"cascaded_tanks/dataBenchmark.mat"``).
url : str or None
    Public address of the file, or of a zip archive holding it (``None`` when
    no public source is known: the file must then be copied by hand).
sha256 : str
    Hex digest of the file itself (not of the archive).
member : str or tuple of str, optional
    Path of the file inside the zip archive at ``url``; a tuple walks through
    nested archives (``("Outer.zip", "inner/file.mat")``).
"""


class DownloadError(OSError):
    """A download failed: transfer interrupted, checksum mismatch or bad archive."""


def get_data_home(data_home=None):
    """Return the folder holding the benchmark records, creating it if needed.

    Parameters
    ----------
    data_home : str or path-like, optional
        Folder to use. Default: the ``SINDYBENCH_DATA`` environment variable,
        else ``~/sindybench_data``. ``~`` is expanded.

    Returns
    -------
    pathlib.Path

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     get_data_home(tmp) == Path(tmp)
    True
    """
    path = _data_home_path(data_home)
    path.mkdir(parents=True, exist_ok=True)
    return path


def _data_home_path(data_home):
    """The data home :func:`get_data_home` would return, without creating it."""
    if data_home is None:
        data_home = os.environ.get("SINDYBENCH_DATA") or os.path.join("~", "sindybench_data")
    return Path(data_home).expanduser()


def sha256sum(path):
    """Hex sha256 digest of a file, read in chunks."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(_CHUNK), b""):
            digest.update(chunk)
    return digest.hexdigest()


def _remove(path):
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass


def _make_folder(folder):
    """Create ``folder`` and its missing parents; return the ones created, deepest first."""
    created = []
    for parent in (folder, *folder.parents):
        if parent.exists():
            break
        created.append(parent)
    folder.mkdir(parents=True, exist_ok=True)
    return created


def _remove_empty(folders):
    for folder in folders:
        try:
            folder.rmdir()
        except OSError:  # not empty (another file landed there) or already gone
            return


def _temp_path(folder, suffix):
    fd, name = tempfile.mkstemp(prefix=".sindybench-", suffix=suffix, dir=folder)
    os.close(fd)
    return name


def _download(url, folder, *, timeout):
    """Stream ``url`` into a temporary file in ``folder``; return (path, sha256).

    Raises DownloadError (and removes the partial file) when the transfer fails
    or ends before the announced Content-Length.
    """
    tmp = _temp_path(folder, ".part")
    received = 0
    digest = hashlib.sha256()
    try:
        with urllib.request.urlopen(url, timeout=timeout) as response, open(tmp, "wb") as out:
            expected = response.headers.get("Content-Length")
            for chunk in iter(lambda: response.read(_CHUNK), b""):
                out.write(chunk)
                digest.update(chunk)
                received += len(chunk)
        if expected is not None and received != int(expected):
            raise DownloadError(
                f"download of {url} was interrupted: received {received} of {int(expected)} bytes; nothing was saved."
            )
    except DownloadError:
        _remove(tmp)
        raise
    except (OSError, http.client.HTTPException, ValueError) as exc:
        _remove(tmp)
        if isinstance(exc, urllib.error.HTTPError):
            reason = f"HTTP {exc.code} {exc.reason}"
        else:
            reason = f"{type(exc).__name__}: {exc}"
        raise DownloadError(
            f"download of {url} failed after {received} bytes ({reason}); nothing was saved."
        ) from exc
    except BaseException:
        _remove(tmp)
        raise
    return tmp, digest.hexdigest()


def _check_member_names(archive, root):
    """Raise DownloadError if any member of ``archive`` would land outside ``root``."""
    root = Path(root).resolve()
    for name in archive.namelist():
        pure = PurePosixPath(name.replace("\\", "/"))
        target = (root / pure).resolve()
        if pure.is_absolute() or ".." in pure.parts or (target != root and root not in target.parents):
            raise DownloadError(f"archive member {name!r} would be extracted outside {root}; refusing the archive.")


def extract_zip(path, target_dir, *, members=None):
    """Extract a zip archive into ``target_dir``, refusing members that escape it.

    Every member name is checked before anything is written: absolute paths,
    ``..`` components and names resolving outside ``target_dir`` make the whole
    archive rejected with :class:`DownloadError`.

    Parameters
    ----------
    path : str or path-like
        The zip archive.
    target_dir : str or path-like
        Destination folder (created if needed).
    members : list of str, optional
        Extract only these members (default all).

    Returns
    -------
    list of pathlib.Path
        The extracted files.
    """
    target_dir = Path(target_dir)
    target_dir.mkdir(parents=True, exist_ok=True)
    try:
        with zipfile.ZipFile(path) as archive:
            _check_member_names(archive, target_dir)
            names = archive.namelist() if members is None else list(members)
            missing = sorted(set(names) - set(archive.namelist()))
            if missing:
                raise DownloadError(f"archive {path} has no member(s) {missing}.")
            out = []
            for name in names:
                if not name.endswith("/"):
                    out.append(Path(archive.extract(name, target_dir)))
            return out
    except zipfile.BadZipFile as exc:
        raise DownloadError(f"{path} is not a valid zip archive: {exc}") from exc


def _extract_member(archive_path, member, folder, url):
    """Copy one member (walking nested archives) into a temporary file in ``folder``."""
    chain = (member,) if isinstance(member, str) else tuple(member)
    current = archive_path
    owned = []
    try:
        for depth, name in enumerate(chain):
            try:
                with zipfile.ZipFile(current) as archive:
                    _check_member_names(archive, folder)
                    if name not in archive.namelist():
                        raise DownloadError(f"the archive from {url} has no member {name!r}.")
                    tmp = _temp_path(folder, ".member")
                    owned.append(tmp)
                    with archive.open(name) as src, open(tmp, "wb") as dst:
                        shutil.copyfileobj(src, dst, _CHUNK)
            except zipfile.BadZipFile as exc:
                raise DownloadError(f"the file from {url} (level {depth}) is not a valid zip archive: {exc}") from exc
            current = tmp
        for tmp in owned[:-1]:
            _remove(tmp)
        return owned[-1]
    except BaseException:
        for tmp in owned:
            _remove(tmp)
        raise


def _verify(digest, remote, origin):
    if digest != remote.sha256:
        raise DownloadError(
            f"checksum mismatch for {remote.filename} from {origin}: sha256 {digest}, expected {remote.sha256}; "
            "the file was not saved."
        )


def _fetch_group(group, source, folder, *, timeout):
    """Download ``source`` once and move each verified file of ``group`` into place."""
    archive, digest = _download(source, folder, timeout=timeout)
    try:
        for remote, path in group:
            path.parent.mkdir(parents=True, exist_ok=True)
            if remote.member is None:
                _verify(digest, remote, source)
                tmp = archive
            else:
                tmp = _extract_member(archive, remote.member, path.parent, source)
                try:
                    _verify(sha256sum(tmp), remote, source)
                except BaseException:
                    _remove(tmp)
                    raise
            os.replace(tmp, path)
    finally:
        _remove(archive)


def fetch_files(remotes, *, data_home=None, download_if_missing=True, urls=None, timeout=60.0):
    """Return the local paths of ``remotes``, downloading the missing ones.

    Files sharing a URL (members of one archive) are fetched with a single
    download. A file already present is checked against its sha256.

    Parameters
    ----------
    remotes : sequence of RemoteFile
    data_home : str or path-like, optional
        See :func:`get_data_home`.
    download_if_missing : bool, default=True
        If False, a missing file raises :class:`FileNotFoundError` naming the
        file and the folder searched.
    urls : dict, optional
        Overrides ``{original_url: replacement_url}`` (mirrors, tests).
    timeout : float, default=60.0
        Socket timeout in seconds.

    Returns
    -------
    list of pathlib.Path
    """
    home = _data_home_path(data_home)  # created only when something is downloaded into it
    urls = dict(urls or {})
    paths = [home / PurePosixPath(r.filename) for r in remotes]
    missing = {}
    for remote, path in zip(remotes, paths):
        if path.exists():
            digest = sha256sum(path)
            if digest != remote.sha256:
                raise DownloadError(
                    f"the existing file {path} has sha256 {digest}, expected {remote.sha256}; "
                    "it is not the published record: delete it to download it again."
                )
        else:
            missing.setdefault(remote.url, []).append((remote, path))
    sources = {}
    for url, group in missing.items():  # every missing file must be obtainable before anything is downloaded
        names = ", ".join(r.filename for r, _ in group)
        if not download_if_missing:
            raise FileNotFoundError(
                f"{names} not found in the data home {home} (download_if_missing=False); "
                "set SINDYBENCH_DATA or data_home= to the folder holding it, or allow the download."
            )
        source = urls.get(url, url)
        if source is None:
            raise FileNotFoundError(
                f"{names} not found in the data home {home}, and no public download address is known for it; "
                f"copy the file to {group[0][1]}."
            )
        sources[url] = source
    for url, group in missing.items():
        folder = group[0][1].parent
        created = _make_folder(folder)
        logger.info("downloading %s from %s", ", ".join(r.filename for r, _ in group), sources[url])
        try:
            _fetch_group(group, sources[url], folder, timeout=timeout)
        except BaseException:
            _remove_empty(created)  # a failed download leaves no empty folders either
            raise
    return paths


def fetch_file(remote, *, data_home=None, download_if_missing=True, url=None, timeout=60.0):
    """Return the local path of one :class:`RemoteFile`, downloading it if missing.

    Parameters
    ----------
    remote : RemoteFile
    data_home : str or path-like, optional
    download_if_missing : bool, default=True
    url : str, optional
        Fetch from this address instead of ``remote.url`` (a mirror, or a local
        test server).
    timeout : float, default=60.0

    Returns
    -------
    pathlib.Path

    Examples
    --------
    >>> import tempfile
    >>> remote = RemoteFile("demo/x.bin", None, "0" * 64)
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     fetch_file(remote, data_home=tmp, download_if_missing=False)
    Traceback (most recent call last):
    ...
    FileNotFoundError: demo/x.bin not found in the data home ... (download_if_missing=False); ...
    """
    urls = None if url is None else {remote.url: url}
    return fetch_files([remote], data_home=data_home, download_if_missing=download_if_missing, urls=urls,
                       timeout=timeout)[0]

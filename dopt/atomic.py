"""Files written whole or not at all: every result, summary, CSV, checkpoint, pack and figure
the project writes goes through here.

A file is written beside its destination (a temporary ``.tmp-*`` file in the same folder,
with the same suffix), flushed and ``os.fsync``-ed, then renamed over the destination
(``os.replace``: atomic within one file system), so that a reader, a killed writer or a full
disk never leaves half a file where a whole one was. A write that fails (no space left, a
file-size limit, a read-only folder) leaves the old file as it was, removes the temporary
file and raises an OSError that names the destination::

    OSError: [Errno 27] File too large (nothing written: the file is as it was):
    '/runs/a/summary.json'

(a killed process cannot remove its temporary file: it is hidden, and every reader skips
it). The new file gets the old one's permissions, or the usual ones (0666 less the umask)
when there was none. Standard library only.

``replace_atomic`` writes bytes, ``write_text`` text, ``copy_file`` a copy; ``writing`` is a
context manager giving the temporary path to a writer that wants a file name
(``fig.savefig``, ``imageio``, ``Image.save``; they pick the format by its suffix).
"""

from __future__ import annotations

import contextlib
import os
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path

#: the start of the temporary files' names (hidden: readers of a folder skip them)
TMP_PREFIX = ".tmp-"


def _umask() -> int:
    """This process's umask (read by setting it and setting it back, once at import)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


_UMASK = _umask()


def _mode(path: Path) -> int:
    """The permissions a new file at ``path`` gets: the old file's, else 0666 less the
    umask (what ``open`` would give it; ``mkstemp`` alone gives 0600)."""
    try:
        return stat.S_IMODE(path.stat().st_mode)
    except OSError:
        return 0o666 & ~_UMASK


def named_error(e: OSError, path: Path | str) -> OSError:
    """An OSError of the same kind as ``e`` that names ``path`` and says that nothing was
    written there."""
    note = f"{e.strerror or e} (nothing written: the file is as it was)"
    if e.errno is None:
        return OSError(f"cannot write {path}: {note}")
    return OSError(e.errno, note, str(path))


@contextlib.contextmanager
def writing(path: Path | str, *, fsync: bool = True) -> Iterator[Path]:
    """A temporary path beside ``path`` (same folder, same suffix) for the block to write;
    when the block ends normally the file is fsync-ed (with ``fsync``) and renamed over
    ``path``, else it is removed and ``path`` left as it was. The folder is created. An
    OSError inside (the block's writes or the rename) is raised naming ``path``; any other
    exception (an interrupt) propagates as itself, and the file then holds the old or the
    new bytes, whole."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, name = tempfile.mkstemp(dir=path.parent, prefix=TMP_PREFIX, suffix=path.suffix)
        os.close(fd)
    except OSError as e:
        raise named_error(e, path) from e
    tmp = Path(name)
    try:
        yield tmp
        _finish(tmp, path, fsync)
    except OSError as e:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise named_error(e, path) from e
    except BaseException:
        # an interrupt may land after the rename: the temporary file is gone, not an error
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


def _finish(tmp: Path, path: Path, fsync: bool) -> None:
    """Give ``tmp`` the permissions of ``path``, sync it and rename it over ``path``."""
    os.chmod(tmp, _mode(path))
    if fsync:
        fd = os.open(tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
    os.replace(tmp, path)


def replace_atomic(path: Path | str, data: bytes, *, suffix: str = "", fsync: bool = True
                   ) -> None:
    """Write the bytes ``data`` to ``path`` atomically (``writing``). ``suffix``: ignored
    (the temporary file takes ``path``'s own; kept for the callers that name it)."""
    del suffix
    with writing(path, fsync=fsync) as tmp:
        with open(tmp, "wb") as f:
            f.write(data)
            f.flush()


def write_text(path: Path | str, text: str, *, fsync: bool = True) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically (``writing``)."""
    replace_atomic(path, text.encode("utf-8"), fsync=fsync)


def copy_file(src: Path | str, dest: Path | str) -> None:
    """Copy the file ``src`` to ``dest`` atomically (``writing``; an error reading ``src`` is
    raised as it is)."""
    with open(src, "rb") as f:
        data = f.read()
    replace_atomic(dest, data)


__all__ = ["TMP_PREFIX", "copy_file", "named_error", "replace_atomic", "write_text",
           "writing"]

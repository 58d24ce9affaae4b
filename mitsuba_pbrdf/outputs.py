"""Output files: checked before the work starts, written atomically.

Every file the package writes (EXR, PNG, JSON, tables) goes through
:func:`atomic_path`: the writer fills a temporary file in the destination's
folder, which replaces the destination (``os.replace``) only once it is
complete. A failed or interrupted write (Ctrl-C included) removes the
temporary file and leaves the previous file, if any, untouched; a reader never
sees a truncated file. An existing file is replaced, as Mitsuba does; the new
file gets the permissions a new file gets (the umask's), or those of the file
it replaces.

Commands call :func:`check_writable` on each output before any long work
(rendering, fitting), so that an unwritable path fails at once::

    check_writable("out/a.exr")            # OSError naming the path, or nothing
    with atomic_path("out/a.exr") as tmp:  # tmp: out/.a.exr.<random>.tmp.exr
        writer(tmp)
    write_text("out/fit.json", text)

Errors are :class:`OutputError` (an ``OSError``) with ``filename`` set (so a command can print
"cannot write PATH: REASON" on one line). Standard library only.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import stat
import tempfile

from . import interrupts

__all__ = ["OutputError", "check_writable", "atomic_path", "together", "write_bytes",
           "write_text", "write_json"]


class OutputError(OSError):
    """An output file cannot be written (``filename`` is its path)."""


def _error(code: int, path, reason: str = None) -> OutputError:
    return OutputError(code, reason or os.strerror(code), os.fspath(path))


def check_writable(path) -> bool:
    """Raise ``OSError`` (naming *path*) unless *path* can be written: it is not
    a folder, and the nearest existing folder above it is a folder where a file
    can be created (tried for real: a temporary file is created and removed, so
    read-only file systems such as ``/sys`` are caught too). Folders that do not
    exist yet are created later, by :func:`atomic_path`. Returns whether *path*
    already exists (it will be replaced)."""
    path = os.path.abspath(os.fspath(path))
    if os.path.isdir(path):
        raise _error(errno.EISDIR, path)
    folder = os.path.dirname(path)
    while not os.path.exists(folder):
        parent = os.path.dirname(folder)
        if parent == folder:
            break
        folder = parent
    if not os.path.isdir(folder):
        raise _error(errno.ENOTDIR, path, f"{folder} is not a folder")
    try:
        fd, probe = tempfile.mkstemp(prefix=".write-test.", dir=folder)
    except OSError as e:
        raise _error(e.errno or errno.EACCES, path) from None
    os.close(fd)
    os.unlink(probe)
    return os.path.exists(path)


def _new_file_mode(existing: str) -> int:
    try:
        return stat.S_IMODE(os.stat(existing).st_mode)
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


@contextlib.contextmanager
def atomic_path(path):
    """A temporary path in *path*'s folder (created if missing) with the same
    extension, for a writer to fill; on success it replaces *path*, on any
    exception (KeyboardInterrupt included) it is removed. Yields the temporary
    path as a string."""
    path = os.fspath(path)
    folder, name = os.path.split(os.path.abspath(path))
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError as e:
        raise _error(e.errno or errno.EACCES, path, f"cannot create folder {folder}: "
                                                    f"{e.strerror}") from None
    if os.path.isdir(path):
        raise _error(errno.EISDIR, path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{name}.", suffix=".tmp" + os.path.splitext(name)[1],
                                   dir=folder)
    except OSError as e:
        raise _error(e.errno or errno.EACCES, path) from None
    os.close(fd)
    try:
        yield tmp
        if _together["on"]:  # replaced with the others at the end of together()
            _together["files"].append((tmp, path))
            return
        interrupts.before_replace()  # Ctrl-C came while held: never replace the output
        os.chmod(tmp, _new_file_mode(path))
        os.replace(tmp, path)
    except BaseException as e:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if isinstance(e, OSError) and not isinstance(e, OutputError) \
                and e.filename in (None, tmp, path):  # e.g. a full disk: name the output
            raise _error(e.errno or errno.EIO, path, e.strerror) from e
        raise


_together = {"on": False, "files": []}


@contextlib.contextmanager
def together():
    """Outputs that belong together (a render's EXR and PNG, a camera's
    frames): each :func:`atomic_path` inside fills its temporary file, and
    all of them replace their destinations at the end, at once. An error, or a
    Ctrl-C before that end (SIGINT is held meanwhile:
    :mod:`mitsuba_pbrdf.interrupts`), removes them all and replaces nothing.
    Nested, the outer one decides."""
    if _together["on"]:
        yield
        return
    outer_hold = interrupts.is_held()
    interrupts.before_replace()       # a SIGINT that came already: nothing is written
    interrupts.hold()
    _together["on"], committed = True, False
    try:
        yield
        interrupts.before_replace()   # one that came while writing: nothing is replaced
        for tmp, path in _together["files"]:
            os.chmod(tmp, _new_file_mode(path))
            os.replace(tmp, path)
        committed = True
        interrupts.discard()          # one during the renames (microseconds) changes nothing
    finally:
        if not committed:
            for tmp, _ in _together["files"]:
                with contextlib.suppress(OSError):
                    os.unlink(tmp)
        _together["on"], _together["files"] = False, []
        if not outer_hold and not (committed and interrupts.is_command_line()):
            interrupts.release()  # on the command line the outputs are its last act: still held


def write_bytes(path, data: bytes) -> str:
    """Write *data* to *path* atomically; returns the path."""
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as f:
            f.write(data)
    return os.fspath(path)


def write_text(path, text: str, encoding: str = "utf-8") -> str:
    """Write *text* to *path* atomically; returns the path."""
    return write_bytes(path, text.encode(encoding))


def write_json(path, value, indent: int = 1) -> str:
    """Write *value* as JSON to *path* atomically; returns the path."""
    return write_text(path, json.dumps(value, indent=indent) + "\n")

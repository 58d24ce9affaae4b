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

One rule for the outputs of every command, checked by :func:`check_plan`
before any work: each output has a format its writer gives (by extension,
``formats``), and is a file of its own: not one of the command's inputs, not
another output (paths compared resolved: symlinks, ``./x`` and ``x``, hard
links). Its :class:`OutputPlanError` names both options::

    check_plan([("--json", "a.json", None), ("--plot", "a.png", ("png",))],
               inputs=[("FILE", "data.csv")])

Text a user gave (a file name, a title, a material's name) enters a file only
through :func:`escape_text`, which knows each kind of file's rules.
"""

from __future__ import annotations

import contextlib
import errno
import json
import math
import os
import stat
import tempfile

from . import interrupts

__all__ = ["OutputError", "OutputPlanError", "check_writable", "check_plan", "same_file",
           "escape_text", "utf8_text", "atomic_path", "together", "write_bytes", "write_text", "write_json"]


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


class OutputPlanError(ValueError):
    """Outputs that cannot be written as asked, found before any work (an
    output that is an input or another output, a format its writer does not
    give); the message opens with the output's option."""


def same_file(a, b) -> bool:
    """Whether paths *a* and *b* name one file: equal once resolved (symlinks,
    ``..``, ``./``), or the same file on disk (hard links)."""
    a, b = os.fspath(a), os.fspath(b)
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def check_plan(outputs, inputs=()) -> None:
    """Raise :class:`OutputPlanError` unless every output of *outputs*
    (``(name, path, formats)``: the option that gives it, its path, and the
    extensions its writer gives, lower case without the dot, or None for any)
    has one of its *formats* and names a file of its own: none of *inputs*
    (``(name, path)``) and no other output. Entries with path None are
    skipped. Nothing is read or written."""
    outputs = [(name, os.fspath(path), formats) for name, path, formats in outputs
               if path is not None]
    for name, path, formats in outputs:
        if formats:
            extension = os.path.splitext(os.path.basename(path))[1].lower().lstrip(".")
            wanted = " or ".join("." + f for f in formats)
            if not extension:
                raise OutputPlanError(f"{name}: {escape_text(path, 'line')} has no extension; "
                                      f"give a {wanted} file name")
            if extension not in formats:
                raise OutputPlanError(f"{name}: cannot write a .{escape_text(extension, 'line')}"
                                      f" file ({escape_text(path, 'line')}); it writes {wanted}")
    done = []
    for name, path, _ in outputs:
        for what, (other, other_path) in ([("input", i) for i in inputs if i[1] is not None]
                                          + [("output", o) for o in done]):
            if same_file(path, other_path):
                shown = escape_text(path, "line")
                if name == other:
                    raise OutputPlanError(f"{name}: two of its outputs are the same file {shown}")
                raise OutputPlanError(
                    f"{name} and {other} name the same file {shown}: an output never "
                    f"replaces {'an input' if what == 'input' else 'another output'}; give "
                    f"{name} another path")
        done.append((name, path))


def _visible(char: str) -> str:
    """A character no text file should hold, as a backslash escape: a lone
    surrogate (a byte of a file name that is not UTF-8, as Python decodes it:
    ``\\xff``), a control character or a non-character (``\\x1b``, ``\\ufffe``)."""
    code = ord(char)
    if 0xDC80 <= code <= 0xDCFF:
        return f"\\x{code - 0xDC00:02x}"
    return f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}"


def _hidden(char: str) -> bool:
    code = ord(char)
    return ((code < 0x20 and char not in "\t\n\r") or 0x7F <= code <= 0x9F
            or 0xD800 <= code <= 0xDFFF or code in (0xFFFE, 0xFFFF))


def utf8_text(text) -> bool:
    """Whether *text* encodes as UTF-8: not a name holding bytes that are not
    (which Python decodes as lone surrogates, and which libraries that take
    paths as UTF-8 text, OpenEXR among them, refuse)."""
    try:
        os.fspath(text).encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


def escape_text(text, context: str) -> str:
    """*text* (anything a user gave: a file name, a title, a material's name)
    as it may enter a file of kind *context*. In every context, characters no
    text file should hold (lone surrogates from undecodable file names, control
    characters but tab and newline, U+FFFE/U+FFFF) become backslash escapes
    (``\\xff``), so the file encodes as UTF-8 and parses; then:

    * ``"text"``: nothing more (a picture's title, where line breaks are kept);
    * ``"line"``: one line (an OpenEXR string attribute, a message, a ``#``
      comment line of a CSV): tabs and newlines become spaces;
    * ``"xml"``: an XML attribute value or text: ``& < > " '`` and tab and
      newline as character references;
    * ``"xml-comment"``: the body of ``<!-- -->``, which XML forbids to hold
      ``--`` or to end in ``-``: a space goes between;
    * ``"csv"``: one CSV field, quoted (RFC 4180) when it holds a comma, a
      quote or a line break, or starts with ``#`` (this package's comment lines).
    """
    text = "".join(_visible(c) if _hidden(c) else c for c in str(text))
    if context == "text":
        return text
    if context == "line":
        return " ".join(text.replace("\t", " ").splitlines())
    if context == "xml":
        return (text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
                .replace('"', "&quot;").replace("'", "&apos;").replace("\t", "&#9;")
                .replace("\n", "&#10;").replace("\r", "&#13;"))
    if context == "xml-comment":
        while "--" in text:
            text = text.replace("--", "- -")
        return text + " " if text.endswith("-") else text
    if context == "csv":
        if any(c in text for c in ',"\n\r') or text.startswith("#"):
            return '"' + text.replace('"', '""') + '"'
        return text
    raise ValueError(f"escape_text: unknown context {context!r}")


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


def _strict_json(value):
    """*value* with every NaN or infinity (which ``json.dumps`` writes as
    ``NaN``/``Infinity``, not JSON: strict parsers, ``jq`` and browsers refuse
    the file) as ``None`` (``null``)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _strict_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_strict_json(v) for v in value]
    return value


def write_json(path, value, indent: int = 1) -> str:
    """Write *value* as JSON to *path* atomically, strict JSON (non-finite
    numbers as ``null``; strings escaped by ``json.dumps``, which writes any
    character, lone surrogates too, as ``\\uXXXX``); returns the path."""
    return write_text(path, json.dumps(_strict_json(value), indent=indent, allow_nan=False)
                      + "\n")

"""Reading the user's text files (scenes, YAML inputs, lift tables) with one-line errors."""
from __future__ import annotations

import os
from pathlib import Path
from typing import Any, Literal

from cam_design.errors import InputError


#: largest text file read (scenes, YAML inputs, lift tables) [bytes]: a bigger one is
#: refused before it is read, so a wrong path to a huge file cannot exhaust the memory
MAX_TEXT_BYTES = 64 * 1024 * 1024


def read_text_file(path: str | Path, what: str, key: str | None = None, *,
                   max_bytes: int = MAX_TEXT_BYTES) -> str:
    """The UTF-8 text of the file at ``path`` (a leading byte-order mark, as Windows
    editors and spreadsheets write, is dropped); ``'-'``: standard input.

    A missing file, a directory, binary data, a file above ``max_bytes`` or an
    unreadable file raise InputError with ``key`` (default: the path) naming the file,
    what was found ('no such file', 'a directory', 'binary data', the size, the OS
    reason) and the ``what`` expected, e.g. ``what='scene file'`` gives 'an existing
    scene file'.
    """
    name = str(path) if key is None else key
    if str(path) == '-':
        import sys

        raw = getattr(sys.stdin, 'buffer', None)   # a text stream (tests) has none
        data = raw.read(max_bytes + 1) if raw is not None else \
            sys.stdin.read(max_bytes + 1).encode('utf-8', errors='surrogateescape')
        if len(data) > max_bytes:
            raise InputError(name, f'more than {max_bytes} bytes on standard input',
                             f'a {what} of at most {max_bytes} bytes')
        return decode_text(data, what, name)
    p = Path(path)
    try:
        with open(p, 'rb') as f:
            size = os.fstat(f.fileno()).st_size
            if size > max_bytes:
                raise InputError(name, f'a file of {size} bytes',
                                 f'a {what} of at most {max_bytes} bytes')
            data = f.read(max_bytes + 1)
    except FileNotFoundError:
        raise InputError(name, 'no such file', f'an existing {what}') from None
    except IsADirectoryError:
        raise InputError(name, 'a directory', f'a {what}, not a directory') from None
    except OSError as exc:
        raise InputError(name, exc.strerror or type(exc).__name__,
                         f'a readable {what}') from None
    if len(data) > max_bytes:   # a device or a file that grew while read
        raise InputError(name, f'more than {max_bytes} bytes',
                         f'a {what} of at most {max_bytes} bytes')
    return decode_text(data, what, name)


def decode_text(data: bytes, what: str, key: str) -> str:
    """``data`` as UTF-8 text without a leading byte-order mark; InputError naming
    ``key`` ('binary data') when it is not UTF-8 or holds NUL bytes."""
    try:
        text = data.decode('utf-8-sig')
    except UnicodeDecodeError:
        raise InputError(key, 'binary data', f'a UTF-8 {what}') from None
    if '\x00' in text:
        raise InputError(key, 'binary data (NUL bytes)', f'a UTF-8 {what}')
    return text


# --------------------------------------------------------------------------- writing
def _os_reason(exc: OSError) -> str:
    import errno

    reasons = {errno.ENOSPC: 'the disk is full', errno.EROFS: 'a read-only file system',
               errno.EACCES: 'permission denied', errno.EISDIR: 'a directory',
               errno.ENOTDIR: 'a folder in the path is a file',
               errno.ENOENT: 'its folder does not exist', errno.EDQUOT: 'the disk quota is full',
               errno.EFBIG: 'the file is too large for the file system'}
    return reasons.get(exc.errno or 0, exc.strerror or type(exc).__name__)


def write_error(key: str, target: str | Path, exc: OSError, what: str = 'file') -> InputError:
    """The one-line error of a failed write: the option ``key``, the path and the reason,
    e.g. ``--json: got '/x/r.json'; expected a writable file (the disk is full)``."""
    return InputError(key, Path(target), f'a writable {what} ({_os_reason(exc)})')


def _partial(target: Path) -> Path:
    return target.with_name(f'.{target.name}.partial-{os.getpid()}')


def discard(path: Path) -> None:
    """Remove a temporary file or folder, ignoring every error (a read-only or vanished
    folder: there is nothing more to do, and the first error is the one to report)."""
    import shutil

    try:
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path, ignore_errors=True)
        else:
            path.unlink(missing_ok=True)
    except OSError:
        pass


def fsync_path(path: Path) -> None:
    """Flush a written file, or every file under a folder and the folders, to the disk
    (a full disk or an I/O error shows here rather than after a rename)."""
    paths = [path] if not path.is_dir() else [path] + sorted(path.rglob('*'))
    for p in paths:
        flags = os.O_RDONLY | (os.O_DIRECTORY if p.is_dir() else 0)
        fd = os.open(p, flags)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def interrupted_note(exc: BaseException | None, key: str, target: Path) -> None:
    """On Ctrl-C or SIGTERM (``KeyboardInterrupt``), note on the exception that the
    output ``key`` was not written (the CLI's interruption line lists the notes)."""
    if isinstance(exc, KeyboardInterrupt):
        exc.add_note(f'{key} {target} not written (nothing left of it)')


class atomic_file:
    """Context manager for one output file that must appear complete or not at all:
    ``with atomic_file(target, key) as tmp:`` write the file ``tmp`` (a hidden name in
    the same folder) by any means; on success it is flushed to the disk and renamed over
    ``target`` (an older file is replaced whole), on any error or signal it is removed.
    An OSError (disk full, read-only, vanished folder) becomes ``write_error(key, ...)``."""

    what = 'file'

    def __init__(self, target: str | Path, key: str) -> None:
        self.target = Path(target)
        self.key = key
        if self.target.is_dir():
            raise InputError(key, self.target, 'a file name, not a directory')
        self.tmp = _partial(self.target)
        self.leftover = self.tmp   # what a failure removes

    def __enter__(self) -> Path:
        return self.tmp

    def _commit(self) -> None:
        fsync_path(self.tmp)
        os.replace(self.tmp, self.target)

    def __exit__(self, kind: object, exc: BaseException | None, tb: object) -> Literal[False]:
        if exc is None:
            try:
                self._commit()
            except OSError as err:
                discard(self.leftover)
                raise write_error(self.key, self.target, err, self.what) from None
            return False
        discard(self.leftover)
        if isinstance(exc, OSError):
            raise write_error(self.key, self.target, exc, self.what) from None
        interrupted_note(exc, self.key, self.target)
        return False


def write_output(target: str | Path, data: str | bytes, key: str) -> None:
    """Write ``data`` to the file ``target`` ('-': standard output, flushed at once).

    The file appears complete or not at all (``atomic_file``): on any failure (disk
    full, read-only, vanished folder, interrupted) nothing new is left, an older file
    stays whole, and InputError(``key``, target, reason) is raised."""
    import sys

    raw = data.encode('utf-8') if isinstance(data, str) else data
    if str(target) == '-':
        try:
            sys.stdout.flush()
            sys.stdout.buffer.write(raw)
            sys.stdout.flush()
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise write_error(key, '-', exc, 'standard output') from None
        return
    with atomic_file(target, key) as tmp:
        with open(tmp, 'wb') as f:
            f.write(raw)


class CheckedStdout:
    """Standard output whose failed writes (redirected to a full disk, ``> /dev/full``)
    raise ``write_error('stdout', ...)`` instead of an OSError from a ``print`` deep in a
    command; a closed pipe stays BrokenPipeError. Everything else is delegated."""

    def __init__(self, stream: Any) -> None:
        self._stream = stream

    def _checked(self, call: Any, *args: Any) -> Any:
        try:
            return call(*args)
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise write_error('stdout', '-', exc, 'standard output') from None

    def write(self, text: str) -> int:
        return int(self._checked(self._stream.write, text))

    def flush(self) -> None:
        self._checked(self._stream.flush)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


def output_dir(folder: str | Path, key: str) -> Path:
    """The folder ``folder``, created if needed (InputError naming ``key`` if impossible)."""
    path = Path(folder)
    if path.exists() and not path.is_dir():
        raise InputError(key, Path(folder), 'a folder (a file of that name exists)')
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(key, Path(folder), f'a folder that can be created '
                         f'({_os_reason(exc)})') from None
    return path


def save_figure(fig: Any, target: str | Path, key: str, **kwargs: Any) -> Path:
    """``fig.savefig`` to ``target`` with the same all-or-nothing rule as
    ``write_output`` (PNG, SVG or PDF by the suffix)."""
    import io

    buf = io.BytesIO()
    path = Path(target)
    fig.savefig(buf, format=path.suffix.lstrip('.') or 'png', **kwargs)
    write_output(path, buf.getvalue(), key)
    return path


def safe_name(text: str, limit: int = 100) -> str:
    """A file name made from ``text`` (a feature id, a label from a bag): letters,
    digits, '.', '-', '_' kept, everything else (path separators included) replaced by
    '_', no leading dot, at most ``limit`` characters; never empty, never '.' or '..'."""
    import re

    name = re.sub(r'[^A-Za-z0-9._-]', '_', str(text))[:limit].lstrip('.')
    return name or '_'


class atomic_dir(atomic_file):
    """Context manager for an output folder that must appear complete or not at all:
    ``with atomic_dir(target, key) as tmp:`` create and fill the folder ``tmp`` (same
    name as ``target``, inside a hidden holder folder next to it); on success it is
    flushed to the disk and renamed to ``target``, on any error (or Ctrl-C) the holder
    is removed. ``target`` must not exist."""

    what = 'folder'

    def __init__(self, target: str | Path, key: str) -> None:
        self.target = Path(target)
        self.key = key
        if self.target.exists():
            raise InputError(key, Path(target), 'a path that does not exist yet (outputs are '
                             'never overwritten)')
        parent = self.target.parent
        if not parent.is_dir():
            raise InputError(key, Path(target), f'a path in an existing folder ({parent} '
                             'does not exist)')
        self.holder = _partial(self.target)
        self.tmp = self.holder / self.target.name
        self.leftover = self.holder

    def __enter__(self) -> Path:
        try:
            self.holder.mkdir()
        except OSError as err:
            raise write_error(self.key, self.target, err, self.what) from None
        except BaseException as exc:
            # a signal handled as the mkdir returns is raised here, before the with
            # statement would call __exit__: the holder may exist, remove it and say so
            discard(self.holder)
            interrupted_note(exc, self.key, self.target)
            raise
        return self.tmp

    def _commit(self) -> None:
        super()._commit()
        self.holder.rmdir()

"""Reading the user's text files (scenes, YAML inputs, lift tables) with one-line errors."""
from __future__ import annotations

from pathlib import Path

from cam_design.errors import InputError


def read_text_file(path: str | Path, what: str, key: str | None = None) -> str:
    """The UTF-8 text of the file at ``path`` (a leading byte-order mark, as Windows
    editors and spreadsheets write, is dropped).

    A missing file, a directory, binary data or an unreadable file raise InputError
    with ``key`` (default: the path) naming the file, what was found ('no such file',
    'a directory', 'binary data', the OS reason) and the ``what`` expected, e.g.
    ``what='scene file'`` gives 'an existing scene file'.
    """
    p = Path(path)
    name = str(p) if key is None else key
    try:
        return p.read_text(encoding='utf-8-sig')
    except FileNotFoundError:
        raise InputError(name, 'no such file', f'an existing {what}') from None
    except IsADirectoryError:
        raise InputError(name, 'a directory', f'a {what}, not a directory') from None
    except UnicodeDecodeError:
        raise InputError(name, 'binary data', f'a UTF-8 {what}') from None
    except OSError as exc:
        raise InputError(name, exc.strerror or type(exc).__name__,
                         f'a readable {what}') from None


# --------------------------------------------------------------------------- writing
def _os_reason(exc: OSError) -> str:
    import errno

    reasons = {errno.ENOSPC: 'the disk is full', errno.EROFS: 'a read-only file system',
               errno.EACCES: 'permission denied', errno.EISDIR: 'a directory',
               errno.ENOTDIR: 'a folder in the path is a file',
               errno.ENOENT: 'its folder does not exist', errno.EDQUOT: 'the disk quota is full'}
    return reasons.get(exc.errno, exc.strerror or type(exc).__name__)


def _partial(target: Path) -> Path:
    import os

    return target.with_name(f'.{target.name}.partial-{os.getpid()}')


def write_output(target: str | Path, data: str | bytes, key: str) -> None:
    """Write ``data`` to the file ``target`` ('-': standard output).

    The file appears complete or not at all: the data goes to a hidden temporary file in
    the same folder, which is renamed over ``target`` only after everything was written;
    on any failure (disk full, read-only, interrupted) the temporary file is removed and
    InputError(``key``, target, reason) is raised."""
    import os
    import sys

    if str(target) == '-':
        if isinstance(data, bytes):
            sys.stdout.buffer.write(data)
        else:
            sys.stdout.write(data)
        return
    path = Path(target)
    if path.is_dir():
        raise InputError(key, Path(target), 'a file name, not a directory')
    tmp = _partial(path)
    try:
        with open(tmp, 'wb') as f:
            f.write(data.encode('utf-8') if isinstance(data, str) else data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise InputError(key, Path(target), f'a writable file ({_os_reason(exc)})') from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


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


def save_figure(fig: object, target: str | Path, key: str, **kwargs: object) -> Path:
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


class atomic_dir:
    """Context manager for an output folder that must appear complete or not at all:
    ``with atomic_dir(target, key) as tmp:`` create and fill the folder ``tmp`` (same
    name as ``target``, inside a hidden holder folder next to it); on success it is
    renamed to ``target``, on any error (or Ctrl-C) the holder is removed. ``target``
    must not exist."""

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

    def __enter__(self) -> Path:
        try:
            self.holder.mkdir()
        except OSError as err:
            raise InputError(self.key, self.target,
                             f'a writable folder ({_os_reason(err)})') from None
        return self.tmp

    def __exit__(self, kind: object, exc: BaseException | None, tb: object) -> bool:
        import os
        import shutil

        if exc is None:
            try:
                os.replace(self.tmp, self.target)
                self.holder.rmdir()
            except OSError as err:
                shutil.rmtree(self.holder, ignore_errors=True)
                raise InputError(self.key, self.target,
                                 f'a writable folder ({_os_reason(err)})') from None
            return False
        shutil.rmtree(self.holder, ignore_errors=True)
        if isinstance(exc, OSError):
            raise InputError(self.key, self.target,
                             f'a writable folder ({_os_reason(exc)})') from None
        return False

"""Reading the user's text files (scenes, YAML inputs, lift tables) with one-line errors."""
from __future__ import annotations

from pathlib import Path

from cam_design.errors import InputError


def read_text_file(path: str | Path, what: str, key: str | None = None) -> str:
    """The UTF-8 text of the file at ``path``.

    A missing file, a directory, binary data or an unreadable file raise InputError
    with ``key`` (default: the path) naming the file, what was found ('no such file',
    'a directory', 'binary data', the OS reason) and the ``what`` expected, e.g.
    ``what='scene file'`` gives 'an existing scene file'.
    """
    p = Path(path)
    name = str(p) if key is None else key
    try:
        return p.read_text(encoding='utf-8')
    except FileNotFoundError:
        raise InputError(name, 'no such file', f'an existing {what}') from None
    except IsADirectoryError:
        raise InputError(name, 'a directory', f'a {what}, not a directory') from None
    except UnicodeDecodeError:
        raise InputError(name, 'binary data', f'a UTF-8 {what}') from None
    except OSError as exc:
        raise InputError(name, exc.strerror or type(exc).__name__,
                         f'a readable {what}') from None

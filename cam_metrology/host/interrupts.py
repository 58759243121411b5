"""SIGINT and SIGTERM in the command line: one exception, one exit code per signal.

While a command runs (``catch_signals``) both signals raise ``Interrupted`` (a
``KeyboardInterrupt``, so every ``finally`` and every all-or-nothing output removes
its temporary files exactly as on Ctrl-C). A command adds what it kept to the
exception with ``add_note`` (e.g. the bags already analysed); the CLI prints one line
and exits 128 + the signal number: 130 for SIGINT, 143 for SIGTERM. A repeated signal
during that clean-up is not raised again (the clean-up finishes). A signal that arrives
after the command finished is not lost either: ``settle_signals`` reports it, the
outputs being complete by then.
"""
from __future__ import annotations

import signal
import threading
from contextlib import contextmanager
from typing import Any, Iterator

SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Interrupted(KeyboardInterrupt):
    """A command stopped by a signal; ``args[0]`` is its name ('SIGINT', 'SIGTERM')."""


def exit_code(signame: str) -> int:
    """128 + the signal number (the shell's convention): SIGINT 130, SIGTERM 143."""
    return 128 + int(getattr(signal.Signals, signame, signal.SIGINT))


class _State:
    raised: str | None = None


def _handler(signum: int, _frame: Any) -> None:
    name = signal.Signals(signum).name
    if _State.raised is not None:   # clean-up under way: let it finish
        return
    _State.raised = name
    raise Interrupted(name)


@contextmanager
def catch_signals() -> Iterator[None]:
    """Within the block SIGINT and SIGTERM raise ``Interrupted`` (main thread only; the
    previous handlers come back afterwards)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _State.raised = None
    old = {sig: signal.signal(sig, _handler) for sig in SIGNALS}
    try:
        yield
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)
        _State.raised = None


COMPLETE = 'the run had already completed: its outputs are complete and kept'


def settle_signals(keep_blocked: bool = False) -> Interrupted | None:
    """Call when the command has returned: ``Interrupted`` (with a note that the run was
    complete) if a signal arrived after it finished, else None. Signals are blocked for
    the check so that none slips between the check and the exit code; ``keep_blocked``
    (a process about to exit) leaves them blocked, so none is taken after the exit code
    was chosen."""
    if threading.current_thread() is not threading.main_thread():
        return None
    old = signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)
    try:
        pending = [s for s in SIGNALS if s in signal.sigpending()]
        if pending:
            signal.sigwait(pending)   # consumed here, not raised later
    finally:
        if not keep_blocked:
            signal.pthread_sigmask(signal.SIG_SETMASK, old)
    if not pending:
        return None
    late = Interrupted(signal.Signals(pending[0]).name)
    late.add_note(COMPLETE)
    return late

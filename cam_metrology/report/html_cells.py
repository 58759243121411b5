"""Cells of the HTML report: escaped text, numbers with '-' for none, the CSS class of a
verdict result (shared by ``html_report`` and ``form_html``)."""
from __future__ import annotations

import html
from typing import Any

__all__ = ['esc', 'number', 'result_class']


def esc(x: Any) -> str:
    """``x`` as HTML text."""
    return html.escape(str(x))


def number(x: Any, spec: str) -> str:
    """``x`` formatted by ``spec``; '-' for None; a value that rounds to zero is shown
    without a sign ('0.000', not '-0.000')."""
    if x is None:
        return '-'
    text = format(x, spec)
    if text.startswith('-') and text.split('e')[0].strip('-0.,% ') == '':
        return text[1:]
    return text


def result_class(result: str | None) -> str:
    """CSS class of a verdict result: pass, fail, or nc (not checked)."""
    return {'pass': 'pass', 'fail': 'fail'}.get(result or '', 'nc')

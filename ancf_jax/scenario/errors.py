"""Errors of scenario files: one line, ``FILE: key.path: message (accepted: ...)``."""

from __future__ import annotations

import re

from ..errors import ModelError

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def format_path(path) -> str:
    """A key path as written in TOML: ``beams.arm.section.E``; list items as ``[i]``."""
    out = ""
    for part in path:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            text = part if _BARE_KEY.match(part) else '"' + part.replace('"', '\\"') + '"'
            out += ("." if out else "") + text
    return out or "(file)"


def one_line(text: str) -> str:
    """Collapse whitespace so that a message stays on one line."""
    return " ".join(str(text).split())


class Invalid(Exception):
    """A problem at a key path, before the file name is known (internal)."""

    def __init__(self, path, message: str, accepted: str):
        super().__init__(message)
        self.path = tuple(path)
        self.message = message
        self.accepted = accepted


class ScenarioError(ModelError):
    """An invalid scenario file; the message is one line naming the file, the key path
    and what is accepted.

    Attributes:
        file: the scenario file (as given, or the shipped file's path).
        path: the key path as a tuple (empty for file-level problems).
        key: the key path as text (``beams.arm.section.E``), or where in the file
            (``line 3, column 9``) for TOML syntax errors.
        reason: what is wrong.
        accepted: what the key accepts.
    """

    def __init__(self, file, path, reason: str, accepted: str):
        self.file = str(file)
        self.path = () if isinstance(path, str) else tuple(path)
        self.key = path if isinstance(path, str) else format_path(self.path)
        self.reason = one_line(reason)
        self.accepted = one_line(accepted)
        super().__init__(f"{self.file}: {self.key}: {self.reason} (accepted: {self.accepted})")

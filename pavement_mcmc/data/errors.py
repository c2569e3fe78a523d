"""The project's error types for users: what was given (files, config, command line, a run
folder) is wrong, and the message says what and where. The command line prints such an error
as one line and exits 2; any other exception is a bug and keeps its traceback."""

from __future__ import annotations


class UserError(Exception):
    """Base of every error caused by the user's input rather than by a bug."""


class RunError(UserError, ValueError):
    """A run folder cannot be used as asked (nothing written yet, incomplete, ...)."""


class RunNotFound(UserError, FileNotFoundError):
    """No run at the path given (or a case file given where a run folder is expected)."""


class RunExists(UserError, FileExistsError):
    """A run already exists where a new one would be written."""

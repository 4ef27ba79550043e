"""The project's single error type for bad input: one class, one-line messages, exit status 2."""

__all__ = ["InputError"]


class InputError(Exception):
    """Bad input: a malformed file, a missing key, an impossible request.

    The message is one line that names the file, the row or key, and the fault. The command
    line prints it on stderr and exits with status 2; anything else that goes wrong is a bug.
    """

"""Errors that the command line turns into one line on stderr and exit status 2."""


class InputError(ValueError):
    """Bad input from a user: a config, a log file, a command-line value.

    A ValueError subclass, so library callers can catch ValueError as documented.
    """


class MissingColumn(InputError):
    """A log lacks a column the work needs: ``column`` names it, so that a command which read the log can
    say why when its reader set that column aside (fxdsp.logfile.saying_why_columns_are_missing)."""

    def __init__(self, message: str, column: str):
        super().__init__(message)
        self.column = column


class InputTypeError(InputError, TypeError):
    """Bad input of the wrong type (a config value that is not a number, a list that is not one).

    Also a TypeError, so callers that catch TypeError for a wrong type keep working."""

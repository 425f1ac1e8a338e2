"""Errors that the command line turns into one line on stderr and exit status 2."""


class InputError(ValueError):
    """Bad input from a user: a config, a log file, a command-line value.

    A ValueError subclass, so library callers can catch ValueError as documented.
    """


class InputTypeError(InputError, TypeError):
    """Bad input of the wrong type (a config value that is not a number, a list that is not one).

    Also a TypeError, so callers that catch TypeError for a wrong type keep working."""

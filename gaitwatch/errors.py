"""The project's bad-input error: a message for a person, no traceback.

Every reader and validator raises a subclass of :class:`InputError` with a one-line message
that names the file (or request field) and what is wrong. The command line prints it on stderr
and exits non-zero; the API turns it into a 4xx answer.
"""


class InputError(ValueError):
    """Bad input from the user: a file, an argument or a request that cannot be used."""

"""The one base of user-facing errors: what the command line reports as a single line.

Every error caused by what a user gave (a file, a name, a value, an output location, a cluster
address) or by the environment it runs in derives from :class:`InputError`, so a caller catches
that one class and lets anything else (a programming error) raise with its traceback. ``worlds``
is the lowest layer the harness uses, hence the base lives here.
"""

from __future__ import annotations


class InputError(ValueError):
    """A user-facing error; its message is one line naming the input and the problem."""

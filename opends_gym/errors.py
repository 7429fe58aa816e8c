"""Errors a user causes (bad id, option, path): the CLI shows them as one line."""


class UserError(Exception):
    """An error the user caused: the CLI prints str(e) as one line and exits 2."""

"""Exception types shared by the core: a user-facing input error and its kinds."""


class InputError(ValueError):
    """
    Bad user input (file, value, bag, table); the message is one line that names what is wrong.

    The CLI prints it and exits with code 2; the nodes log it and keep running.
    """

"""The one exception type for mistakes a user can make in their inputs."""


class InputError(ValueError):
    """Bad user input: a site file, a plan file, a command-line value or a dead link.

    The message is one line that names the file, field or item at fault. Command-line entry
    points print it and exit with status 2.
    """

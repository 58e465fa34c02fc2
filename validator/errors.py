"""The one exception type for mistakes a user can make in their inputs."""


class InputError(ValueError):
    """Bad user input: a site file, a plan file, a command-line value or a dead link.

    The message is one line that names the file, field or item at fault. Command-line entry
    points print it and exit with status 2. Control characters and line breaks a hostile file
    put into a key or value are shown escaped, so the message stays one line by construction.
    """

    def __init__(self, message: object = "") -> None:
        super().__init__(_one_line(str(message)))


def _one_line(text: str) -> str:
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)

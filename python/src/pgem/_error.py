"""The exception every failed pgem call raises (imported by the extension module)."""


class Error(RuntimeError):
    """A failed pgem call: ``str(error)`` is pgem's message (the one ``pgem_last_error``
    gives in C, naming the ids, the field or the file and line that were wrong); ``code`` is
    the negative ``pgem_error_t`` value and ``name`` its constant name, e.g.
    ``"PGEM_ERR_UNKNOWN_ID"``."""

    def __init__(self, code: int, name: str, message: str) -> None:
        super().__init__(message)
        self.code = code
        self.name = name
        self.message = message

    def __repr__(self) -> str:
        return f"pgem.Error({self.name}: {self.message!r})"

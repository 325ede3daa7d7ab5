"""alphainv.Error: the C++ library's alphainv::Error in Python (include/alphainv/error.hpp)."""


class Error(ValueError):
    """Bad input or set-up: which file, line and field, and what was expected versus found.

    Attributes: message (what is wrong), file ('' when none), line (1-based, 0 when none),
    field (the column, key, parameter or option concerned, '' when none). str(error) is the
    library's one readable line, e.g. "runs/a.csv:12: 'theta': expected a finite number".
    """

    def __init__(self, message, file="", line=0, field="", text=None):
        self.message = message
        self.file = file
        self.line = line
        self.field = field
        super().__init__(text if text is not None else message)

    def __reduce__(self):  # keeps the fields across processes (batch workers, Dask)
        return (Error, (self.message, self.file, self.line, self.field, str(self)))

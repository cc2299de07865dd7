"""CSV results files: the table, written atomically, and the status line read back."""
from __future__ import annotations

import pathlib

from ...atomic import atomic_write, defers_interrupts, interrupt_check
from .table import _write_table, status_line


@defers_interrupts(imports=("pandas", "h5py"))
def write_csv(results, path, *, table=None) -> pathlib.Path:
    """The results table as CSV (header row, one row per output time), written atomically.
    Results that are not complete (status failed, budget, interrupted) start with a comment
    line '# status: ...' (read them with :func:`read_results` or pandas' ``comment='#'``)."""
    path = pathlib.Path(path)
    with atomic_write(path) as tmp:
        _write_csv_to(results, tmp, table)
    return path


class _CSVSink:
    """Receives the table chunk by chunk and writes it as CSV to ``tmp``."""

    def __init__(self, results, tmp):
        self.fh = open(tmp, "w", newline="")
        self.rows, self.columns = 0, 0
        line = status_line(results)
        if line:
            self.fh.write(line + "\n")

    def add(self, df):
        interrupt_check()
        df.to_csv(self.fh, index=False, header=self.rows == 0 and self.columns == 0)
        self.rows += len(df)
        self.columns = len(df.columns)

    def close(self):
        self.fh.close()
        return self.rows, self.columns

    def abort(self):
        self.fh.close()


def _write_csv_to(results, tmp, table=None) -> tuple:
    sink = _CSVSink(results, tmp)
    try:
        _write_table(results, [sink], table)
    except BaseException:
        sink.abort()
        raise
    return sink.close()


def _csv_status(path) -> tuple:
    """(status, message) of a CSV results file from its '# status:' line, or (None, "")."""
    with open(path, "r", encoding="utf-8", errors="replace") as fh:
        first = fh.readline()
    if not first.startswith("# status:"):
        return None, ""
    status, _, message = first[len("# status:"):].strip().partition(";")
    return status.strip(), message.strip()


def _text(value) -> str:
    return value.decode("utf-8") if isinstance(value, bytes) else str(value)

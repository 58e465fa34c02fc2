"""A study directory: the log of finished trials (for resuming) and the trial table.

``DIR/trials.jsonl`` holds one JSON row per finished trial, appended and flushed to disk as each
trial ends, so an interrupted study loses at most the trials that were running. A torn last line
(the process was killed mid-write) is ignored. Re-running a study into the same directory skips
every trial whose key is in the log. Delete the log to start over.

One study at a time writes a directory: the log holds an exclusive lock (``fcntl.flock``) on
``DIR/.nfz-study.lock``, which names the PID of the run holding it; a second run on the same
directory is refused while the first one lives. The kernel drops the lock when its process
dies, however it dies, so a killed study leaves nothing to clean up: run it again to resume.

``DIR/study.json`` records the planner options the logged trials were run with; resuming with
other options is refused, so one table never mixes two planners.

``DIR/trials.csv`` (or ``.parquet``) is the table of a study's trials in the study's order,
written atomically when the study ends.
"""

from __future__ import annotations

import csv
import fcntl
import io
import json
import os
from collections.abc import Iterable, Sequence
from pathlib import Path
from types import TracebackType

from mission_planner.study.trials import TABLE_COLUMNS, Cell, Row
from validator.errors import InputError
from validator.fileio import write_atomic

LOG_NAME = "trials.jsonl"
LOCK_NAME = ".nfz-study.lock"
MANIFEST_NAME = "study.json"
FILES = (LOG_NAME, LOCK_NAME, MANIFEST_NAME)  # what every resumable study keeps in its folder
TABLE_FORMATS = ("csv", "parquet")


def read_log(directory: str | Path) -> dict[str, Row]:
    """Finished trials logged in ``directory``, by key (the last row of a key wins)."""
    path = Path(directory) / LOG_NAME
    if not path.exists():
        return {}
    rows: dict[str, Row] = {}
    with path.open(encoding="utf-8") as f:
        for line in f:
            if not line.endswith("\n"):
                break  # torn last line: that trial did not finish writing
            try:
                row = json.loads(line)
            except json.JSONDecodeError:
                continue
            if isinstance(row, dict) and isinstance(row.get("key"), str):
                rows[row["key"]] = row
    return rows


class TrialLog:
    """Append-only log of finished trials; use as a context manager.

    Entering takes the directory's lock (see the module doc; :class:`InputError` if another
    study holds it). Nothing but the lock file is written until the first row, and a study
    that ends without a row leaves no files. The first row also records ``manifest`` (see
    :func:`check_manifest`) if the directory has none.
    """

    def __init__(self, directory: str | Path, manifest: dict[str, object] | None = None) -> None:
        self.directory = Path(directory)
        self.path = self.directory / LOG_NAME
        self.manifest = manifest
        self._file: io.TextIOWrapper | None = None
        self._lock: int | None = None
        self._made_directory = False

    def __enter__(self) -> TrialLog:
        self._made_directory = not self.directory.exists()
        try:
            self.directory.mkdir(parents=True, exist_ok=True)
            fd = os.open(self.directory / LOCK_NAME, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as err:
            raise InputError(f"{self.directory}: cannot use as a study directory "
                             f"({err.strerror})") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode("ascii", "replace").strip() or "?"
            os.close(fd)
            raise InputError(f"{self.directory}: another nfz-study (pid {holder}) is writing "
                             "this directory; wait for it or use another one") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        self._lock = fd
        return self

    def _open(self) -> io.TextIOWrapper:
        self.directory.mkdir(parents=True, exist_ok=True)
        manifest_path = self.directory / MANIFEST_NAME
        if self.manifest is not None and not manifest_path.exists():
            write_atomic(manifest_path, json.dumps(_normalised(self.manifest), indent=2,
                                                   sort_keys=True) + "\n")
        torn = self.path.exists() and self.path.stat().st_size > 0 and not self._ends_in_newline()
        f = self.path.open("a", encoding="utf-8")
        if torn:
            f.write("\n")  # close a torn line so the next row starts clean
        return f

    def _ends_in_newline(self) -> bool:
        with self.path.open("rb") as f:
            f.seek(-1, os.SEEK_END)
            return f.read(1) == b"\n"

    def append(self, row: Row) -> None:
        """Log one finished trial and force it to disk."""
        if self._file is None:
            self._file = self._open()
        self._file.write(json.dumps(row, allow_nan=True) + "\n")
        self._file.flush()
        os.fsync(self._file.fileno())

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None
        if self._lock is not None:
            if self._made_directory and os.listdir(self.directory) == [LOCK_NAME]:
                (self.directory / LOCK_NAME).unlink()  # a study that never started: no files
                self.directory.rmdir()
            os.close(self._lock)  # releases the lock
            self._lock = None


def _normalised(manifest: dict[str, object]) -> dict[str, object]:
    out: dict[str, object] = json.loads(json.dumps(manifest))  # tuples as lists, as read back
    return out


def check_manifest(directory: str | Path, manifest: dict[str, object]) -> None:
    """Refuse to add trials to ``directory`` if it logged trials run with another manifest."""
    path = Path(directory) / MANIFEST_NAME
    if not path.exists():
        return
    try:
        recorded = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError):
        raise InputError(f"{path}: unreadable study manifest; delete it to start over") from None
    wanted = _normalised(manifest)
    if recorded != wanted:
        keys = sorted(k for k in set(recorded) | set(wanted) if recorded.get(k) != wanted.get(k))
        raise InputError(
            f"{path}: this directory holds trials run with other settings "
            f"({', '.join(keys)}); use another directory or delete it"
        )


def _cell(value: Cell) -> Cell:
    if value is None:
        return ""
    if isinstance(value, float):
        return repr(value)  # shortest round-tripping text, 'inf' and 'nan' included
    return value


def table_csv(rows: Iterable[Row], columns: Sequence[str] = TABLE_COLUMNS) -> str:
    """Rows as CSV text with a header; empty cells for None, floats written exactly."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(columns)
    for row in rows:
        writer.writerow([_cell(row.get(c)) for c in columns])
    return out.getvalue()


def check_table_format(table_format: str) -> None:
    """Refuse an unknown table format, or Parquet without pyarrow, before any work is done."""
    if table_format not in TABLE_FORMATS:
        raise InputError(
            f"--format: expected one of {', '.join(TABLE_FORMATS)}, got {table_format!r}"
        )
    if table_format == "parquet":
        try:
            import pyarrow  # noqa: F401
        except ImportError:
            raise InputError("--format: parquet needs pyarrow (pip install pyarrow)") from None


def write_table(
    rows: Sequence[Row],
    path: str | Path,
    table_format: str = "csv",
    columns: Sequence[str] = TABLE_COLUMNS,
) -> Path:
    """Write ``rows`` atomically as CSV or Parquet (needs pyarrow); returns the path written."""
    check_table_format(table_format)
    path = Path(path)
    if table_format == "csv":
        write_atomic(path, table_csv(rows, columns))
        return path
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pylist([{c: r.get(c) for c in columns} for r in rows])
    sink = io.BytesIO()
    pq.write_table(table, sink)
    write_atomic(path, sink.getvalue())
    return path

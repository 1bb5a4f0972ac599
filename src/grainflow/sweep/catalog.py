"""The results catalog: one SQLite row per sweep point.

The catalog lives in ``SWEEPDIR/catalog.sqlite``. Only the process driving the
sweep writes to it; every change is one transaction in WAL mode, so a Ctrl-C or a
``kill -9`` at any moment leaves either the old or the new row, never half of one,
and ``grainflow sweep-status`` can read it while the sweep runs.

A point's status moves ``pending -> running -> done | failed``. A sweep that is
started again skips ``done`` points and reruns every other one.
"""

from __future__ import annotations

import csv
import json
import os
import sqlite3
from collections.abc import Iterable
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import IO, Any

from grainflow.sweep.spec import Point, SweepError

CATALOG_NAME = "catalog.sqlite"
STATUSES = ("pending", "running", "done", "failed")
SCHEMA_VERSION = "1"

_SCHEMA = """
CREATE TABLE IF NOT EXISTS points (
    point_id    TEXT PRIMARY KEY,
    params      TEXT NOT NULL,              -- JSON {dotted field: value}, without the seed
    seed_field  TEXT NOT NULL,
    seed        INTEGER NOT NULL,
    status      TEXT NOT NULL CHECK (status IN ('pending', 'running', 'done', 'failed')),
    rundir      TEXT NOT NULL,              -- relative to the sweep directory
    summary     TEXT,                       -- JSON {name: number} from the analyses
    wall_time   REAL,                       -- seconds the result cost (all kept segments)
    error       TEXT,                       -- traceback or message of the last failure
    attempts    INTEGER NOT NULL DEFAULT 0, -- times a worker started this point
    worker      TEXT,
    started_at  TEXT,
    finished_at TEXT
);
CREATE TABLE IF NOT EXISTS meta (
    key   TEXT PRIMARY KEY,
    value TEXT NOT NULL
);
"""


@dataclass(frozen=True)
class CatalogRow:
    """One point as stored in the catalog."""

    point_id: str
    params: dict[str, Any]
    seed_field: str
    seed: int
    status: str
    rundir: str
    summary: dict[str, float]
    wall_time: float | None
    error: str | None
    attempts: int
    worker: str | None
    started_at: str | None
    finished_at: str | None


def now() -> str:
    """Current UTC time as an ISO-8601 string."""
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


def run_subdir(point_id: str) -> str:
    """Where a point's run directory lives, relative to the sweep directory."""
    return f"runs/{point_id}"


class CatalogError(SweepError):
    """The catalog file cannot be used (damaged, not a catalog, not writable)."""


def damaged_catalog_message(path: Path, problem: str) -> str:
    """What is wrong with a catalog and how to recover: the run directories are intact."""
    sweepdir = path.parent
    return (
        f"{path}: the sweep catalog is damaged ({problem}). The run directories in "
        f"{sweepdir / 'runs'} are not affected. Rebuild the catalog from them with "
        f"'grainflow sweep SWEEP.toml -o {sweepdir} --rebuild-catalog' (the damaged file is "
        "moved aside, finished runs are not repeated, only their analyses), or move "
        f"{path.name} away yourself"
    )


def damaged_target(path: Path) -> Path:
    """A free ``<name>.damaged-<UTC time>[-N]`` beside ``path`` (a file or a directory)."""
    stamp = datetime.now(timezone.utc).strftime("%Y%m%dT%H%M%S")
    target = path.with_name(f"{path.name}.damaged-{stamp}")
    n = 1
    while target.exists():
        n += 1
        target = path.with_name(f"{path.name}.damaged-{stamp}-{n}")
    return target


def move_aside(path: Path) -> Path:
    """Rename a damaged catalog (and its -wal/-shm files) to :func:`damaged_target`."""
    target = damaged_target(path)
    for suffix in ("-wal", "-shm"):
        side = path.with_name(path.name + suffix)
        if side.exists():
            side.rename(target.with_name(target.name + suffix))
    if path.exists():
        path.rename(target)
    return target


class Catalog:
    """SQLite catalog of a sweep directory. Use as a context manager or call :meth:`close`.

    Opening checks the file: a damaged or foreign file raises :class:`CatalogError` (a
    one-line reason and the way out), as does a catalog that cannot be written;
    ``readonly=True`` opens an existing catalog for reading only (``sweep-status``).
    """

    def __init__(self, path: str | Path, *, readonly: bool = False) -> None:
        self.path = Path(path)
        self._conn: sqlite3.Connection | None = None
        existed = self.path.exists()
        if existed and self.path.is_dir():
            raise CatalogError(f"{self.path} is a directory, not a sweep catalog; move it away")
        if existed and self.path.stat().st_size == 0 and not _has_content(self.path, "-wal"):
            raise CatalogError(damaged_catalog_message(self.path, "the file is empty (0 bytes)"))
        try:
            if not existed and not readonly:
                # a new catalog appears whole: SQLite creates an empty file first, which a
                # reader opening it at that instant would take for a damaged one
                _create(self.path)
            if readonly:
                uri = self.path.resolve().as_uri() + "?mode=ro"
                self._conn = sqlite3.connect(uri, uri=True, timeout=30.0, isolation_level=None)
                self._check()
                return
            self._conn = sqlite3.connect(self.path, timeout=30.0, isolation_level=None)
            self._conn.execute("PRAGMA journal_mode=WAL")
            self._conn.execute("PRAGMA synchronous=NORMAL")
            self._check()
            with self._transaction():
                _add_schema(self._conn)
        except sqlite3.Error as exc:
            self.close()
            raise self.error(exc) from None
        except CatalogError:
            self.close()
            raise

    def _check(self) -> None:
        """Raise CatalogError unless the file is a readable catalog of this version."""
        assert self._conn is not None
        result = self._conn.execute("PRAGMA quick_check").fetchone()[0]
        if result != "ok":
            raise CatalogError(damaged_catalog_message(self.path, f"integrity check: {result}"))
        tables = {r[0] for r in self._conn.execute("SELECT name FROM sqlite_master WHERE type='table'")}
        if tables and not {"points", "meta"} <= tables:
            raise CatalogError(damaged_catalog_message(
                self.path, f"an SQLite file without the catalog's tables (has {sorted(tables)})"))
        if "points" in tables:
            columns = {r[1] for r in self._conn.execute("PRAGMA table_info(points)")}
            missing = {"point_id", "params", "status", "summary"} - columns
            if missing:
                raise CatalogError(damaged_catalog_message(
                    self.path, f"table 'points' lacks the columns {sorted(missing)}"))

    def error(self, exc: sqlite3.Error) -> CatalogError:
        """A CatalogError saying what an SQLite error means for this catalog."""
        text = str(exc)
        if isinstance(exc, sqlite3.OperationalError) and (
            "readonly" in text or "read-only" in text or "unable to open" in text
            or "disk I/O" in text
        ):
            return CatalogError(
                f"{self.path}: cannot write the sweep catalog ({text}); make "
                f"{self.path.parent} and the files in it writable, or choose another "
                "sweep directory"
            )
        if isinstance(exc, sqlite3.OperationalError) and "database is locked" in text:
            return CatalogError(
                f"{self.path}: the catalog is locked by another process ({text}); wait for it "
                "and try again"
            )
        if isinstance(exc, sqlite3.OperationalError) and "disk is full" in text:
            return CatalogError(f"{self.path}: {text}; free some space and run the sweep again")
        return CatalogError(damaged_catalog_message(self.path, text))

    @classmethod
    def in_dir(cls, sweepdir: str | Path, *, readonly: bool = False) -> Catalog:
        """Open (creating if needed, unless ``readonly``) the catalog of a sweep directory."""
        return cls(Path(sweepdir) / CATALOG_NAME, readonly=readonly)

    def __enter__(self) -> Catalog:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        if self._conn is not None:
            self._conn.close()
            self._conn = None

    def _transaction(self) -> _Transaction:
        """``with self._transaction():`` runs the block as one IMMEDIATE transaction."""
        return _Transaction(self._conn)

    # -- writing ---------------------------------------------------------------------

    def register(self, points: Iterable[Point]) -> int:
        """Add points not yet in the catalog as ``pending``; returns how many were new."""
        rows = [
            (p.point_id, json.dumps(p.overrides), p.seed_field, p.seed, run_subdir(p.point_id))
            for p in points
        ]
        with self._transaction():
            before = self._count()
            self._conn.executemany(
                "INSERT OR IGNORE INTO points (point_id, params, seed_field, seed, status, rundir)"
                " VALUES (?, ?, ?, ?, 'pending', ?)",
                rows,
            )
            return self._count() - before

    def requeue(self, point_ids: Iterable[str]) -> None:
        """Set the given points back to ``pending`` unless they are ``done``."""
        with self._transaction():
            self._conn.executemany(
                "UPDATE points SET status = 'pending' WHERE point_id = ? AND status != 'done'",
                ((pid,) for pid in point_ids),
            )

    def reset_running(self) -> int:
        """Put ``running`` points back to ``pending`` (after an interrupted sweep)."""
        with self._transaction():
            cur = self._conn.execute("UPDATE points SET status = 'pending' WHERE status = 'running'")
            return cur.rowcount

    def mark_started(self, point_id: str, worker: str, started_at: str) -> None:
        """A worker started the point: count the attempt and mark it ``running``.

        A start report that arrives after the point already finished only counts
        the attempt; it does not undo the final status.
        """
        with self._transaction():
            self._conn.execute(
                "UPDATE points SET attempts = attempts + 1, worker = ?, started_at = ?,"
                " status = CASE WHEN status IN ('pending', 'running') THEN 'running'"
                " ELSE status END WHERE point_id = ?",
                (worker, started_at, point_id),
            )

    def mark_finished(
        self,
        point_id: str,
        status: str,
        *,
        summary: dict[str, float] | None = None,
        wall_time: float | None = None,
        error: str | None = None,
        worker: str | None = None,
    ) -> None:
        """Record the outcome of a point (``done`` or ``failed``)."""
        if status not in ("done", "failed"):
            raise ValueError(f"a finished point is 'done' or 'failed', not {status!r}")
        with self._transaction():
            self._conn.execute(
                "UPDATE points SET status = ?, summary = ?, wall_time = ?, error = ?,"
                " worker = COALESCE(?, worker), finished_at = ? WHERE point_id = ?",
                (status, json.dumps(summary or {}), wall_time, error, worker, now(), point_id),
            )

    def set_meta(self, key: str, value: str) -> None:
        with self._transaction():
            self._conn.execute(
                "INSERT INTO meta (key, value) VALUES (?, ?)"
                " ON CONFLICT (key) DO UPDATE SET value = excluded.value",
                (key, value),
            )

    # -- reading ---------------------------------------------------------------------

    def get_meta(self, key: str) -> str | None:
        row = self._conn.execute("SELECT value FROM meta WHERE key = ?", (key,)).fetchone()
        return row[0] if row else None

    def statuses(self) -> dict[str, str]:
        """``{point_id: status}`` for every point in the catalog."""
        return dict(self._conn.execute("SELECT point_id, status FROM points"))

    def counts(self, point_ids: Iterable[str] | None = None) -> dict[str, int]:
        """Number of points per status, over all points or over ``point_ids``."""
        statuses = self.statuses()
        ids = statuses if point_ids is None else point_ids
        counts = dict.fromkeys(STATUSES, 0)
        for pid in ids:
            counts[statuses[pid]] += 1
        return counts

    def rows(self, status: str | None = None) -> list[CatalogRow]:
        """All points (or those with ``status``) in the order they were first registered."""
        query = "SELECT * FROM points"
        args: tuple[str, ...] = ()
        if status is not None:
            query += " WHERE status = ?"
            args = (status,)
        cur = self._conn.execute(query + " ORDER BY rowid", args)
        names = [d[0] for d in cur.description]
        return [_to_row(dict(zip(names, values))) for values in cur]

    def _count(self) -> int:
        return self._conn.execute("SELECT COUNT(*) FROM points").fetchone()[0]


def _add_schema(conn: sqlite3.Connection) -> None:
    """Create the tables that do not exist yet and record the schema version."""
    for statement in _SCHEMA.split(";"):
        if statement.strip():
            conn.execute(statement)
    conn.execute("INSERT OR IGNORE INTO meta (key, value) VALUES ('schema_version', ?)",
                 (SCHEMA_VERSION,))


def _create(path: Path) -> None:
    """Write an empty catalog to a temporary file and rename it to ``path``."""
    tmp = path.with_name(path.name + ".new")
    tmp.unlink(missing_ok=True)
    conn = sqlite3.connect(tmp, isolation_level=None)
    try:
        conn.execute("BEGIN IMMEDIATE")
        _add_schema(conn)
        conn.execute("COMMIT")
    finally:
        conn.close()
    os.replace(tmp, path)


def _has_content(path: Path, suffix: str) -> bool:
    side = path.with_name(path.name + suffix)
    try:
        return side.stat().st_size > 0
    except OSError:
        return False


class _Transaction:
    """Context manager: BEGIN IMMEDIATE ... COMMIT, or ROLLBACK on any exception."""

    def __init__(self, conn: sqlite3.Connection) -> None:
        self._conn = conn

    def __enter__(self) -> sqlite3.Connection:
        self._conn.execute("BEGIN IMMEDIATE")
        return self._conn

    def __exit__(self, exc_type: type[BaseException] | None, *rest: object) -> None:
        self._conn.execute("ROLLBACK" if exc_type else "COMMIT")


def _to_row(record: dict[str, Any]) -> CatalogRow:
    record["params"] = json.loads(record["params"])
    record["summary"] = json.loads(record["summary"]) if record["summary"] else {}
    return CatalogRow(**record)


def export_csv(rows: list[CatalogRow], stream: IO[str]) -> None:
    """Write rows as CSV: identity, one column per parameter, seed, one per summary number,
    then status, timing, run directory and error."""
    param_cols = _union_keys(r.params for r in rows)
    summary_cols = _union_keys(r.summary for r in rows)
    seed_cols = _union_keys({r.seed_field: None} for r in rows)
    header = [
        "point_id", *param_cols, *seed_cols, "status", *summary_cols,
        "wall_time", "attempts", "worker", "started_at", "finished_at", "rundir", "error",
    ]
    writer = csv.writer(stream)
    writer.writerow(header)
    for r in rows:
        writer.writerow([
            r.point_id,
            *(_cell(r.params.get(c)) for c in param_cols),
            *(r.seed if c == r.seed_field else "" for c in seed_cols),
            r.status,
            *(_cell(r.summary.get(c)) for c in summary_cols),
            _cell(r.wall_time), r.attempts, r.worker or "", r.started_at or "",
            r.finished_at or "", r.rundir, r.error or "",
        ])


def _union_keys(dicts: Iterable[dict[str, Any]]) -> list[str]:
    """Keys of all dicts, in first-seen order."""
    keys: dict[str, None] = {}
    for d in dicts:
        keys.update(dict.fromkeys(d))
    return list(keys)


def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, (dict, list)):
        return json.dumps(value)
    return str(value)

"""The report file of a batch: records appended as files finish, sorted at the end, and its resume state.

A record is one file's text in the report: a CSV row with the SPEC's columns
(written by :func:`massprops.report.tables.to_csv`, the one CSV writer)
or a JSON line.  The state file next to the report (``REPORT.state.jsonl``)
holds the run's settings and each file's size and modification time, which
is what tells an unchanged file from a changed one on ``--resume``.

The ``text`` and ``json`` reports are rendered whole at the end (a JSON array
cannot be appended to, a text block is not read back): their records are JSON
lines kept in the state file, which is where ``--resume`` finds them.
"""

from __future__ import annotations

import csv
import io
import json
import os
from contextlib import contextmanager

from .. import report
from ..model.errors import OutputError

__all__ = ["record", "state_path", "file_stat", "plan", "ReportWriter", "is_error"]


def csv_line(row):
    """One CSV line (with newline) for a row dict keyed by ``report.CSV_COLUMNS`` (the one writer's line)."""
    return report.tables.csv_line(row)


def record(obj, status, message, output_format):
    """The report line of one file from its ``props`` object (just ``{"file": ...}`` on error).

    ``"csv"``: the SPEC's columns, floats as ``repr``; ``"jsonl"`` (and
    ``"json"``, ``"text"``, rendered from these at the end): the object with
    ``status`` and ``message`` first.
    """
    if output_format != "csv":
        head = {"file": obj["file"], "status": status, "message": message}
        return json.dumps({**head, **obj}, allow_nan=False) + "\n"
    return csv_line(report.csv_row(obj, status=status, message=message))


def state_path(output):
    """The resume state file kept next to the report ``output``."""
    return os.fspath(output) + ".state.jsonl"


def file_stat(path):
    """``[size, mtime_ns]`` of ``path``, or None if it cannot be read."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return [st.st_size, st.st_mtime_ns]


def _complete_text(path):
    """The report's text up to its last line feed: a record cut short by an interruption is left out."""
    with open(path, encoding="utf-8", errors="surrogateescape", newline="") as f:
        text = f.read()
    return text[:text.rfind("\n") + 1]


def rendered(output_format):
    """Whether the report is rendered whole at the end (its records kept in the state file)."""
    return output_format in ("text", "json")


def render(lines, output_format):
    """The ``text`` or ``json`` report from its JSON-line records, in the order given.

    ``json``: one array of the objects; ``text``: each file's block as ``props``
    prints it (a failed file: ``error: FILE: message``), then a count line.
    """
    objects = [json.loads(line) for line in lines]
    if output_format == "json":
        return report.to_json(objects) + "\n"
    blocks, failed = [], 0
    for obj in objects:
        if obj.get("status") == "ok":
            blocks.append(report.to_text({k: v for k, v in obj.items() if k not in ("status", "message")}))
        else:
            failed += 1
            blocks.append(f"error: {obj['file']}: {obj.get('message', '')}")
    count = f"{len(objects)} file{'' if len(objects) == 1 else 's'}: {len(objects) - failed} ok, {failed} failed"
    return "".join(block + "\n\n" for block in blocks) + count + "\n"


def _records_in(output, output_format):
    """``{file: line}`` of an existing report (empty if absent or not a batch report)."""
    if rendered(output_format):
        return _state_records(output)
    try:
        text = _complete_text(output)
    except OSError:
        return {}
    records = {}
    if output_format == "csv":
        rows = csv.reader(io.StringIO(text, newline=""))
        try:
            if next(rows, None) != list(report.CSV_COLUMNS):
                return {}
            for values in rows:
                if len(values) == len(report.CSV_COLUMNS) and values[1] in ("ok", "error"):
                    row = dict(zip(report.CSV_COLUMNS, values))
                    records[row["file"]] = csv_line(row)
        except csv.Error:
            pass                    # a record cut inside a quoted name: the rows before it stand
        return records
    for line in text.splitlines(keepends=True):
        try:
            obj = json.loads(line)
            records[obj["file"]] = line
        except (ValueError, KeyError, TypeError):
            continue
    return records


def _state_records(output):
    """``{file: line}`` of the records a ``text`` or ``json`` run kept in its state file."""
    try:
        lines = _complete_text(state_path(output)).splitlines()[1:]
        return {e["file"]: e["record"] for e in map(json.loads, lines) if "record" in e}
    except (OSError, ValueError, KeyError, TypeError):
        return {}


def _state_in(output, header):
    """``{file: (stat, retry)}`` from the state file, or None if it was made with other settings."""
    try:
        lines = _complete_text(state_path(output)).splitlines()
        if not lines or json.loads(lines[0]) != header:
            return None
        return {e["file"]: (e["stat"], e.get("retry", False)) for e in map(json.loads, lines[1:])}
    except (OSError, ValueError, KeyError, TypeError):
        return None


def plan(files, output, output_format, header, resume):
    """Split ``files`` into reused records ``{file: (line, stat)}`` and files to compute."""
    notes = []
    state = _state_in(output, header) if resume else None
    if resume and state is None and os.path.exists(output):
        notes.append("the report's state file is missing or from other settings; recomputing every file")
    records = _records_in(output, output_format) if state else {}
    kept, todo = {}, []
    for path in files:
        stat = file_stat(path)
        # a worker failure or a time-out was the run's fault, not the file's: compute it again
        if stat is not None and path in records and state.get(path) == (stat, False):
            kept[path] = (records[path], stat)
        else:
            todo.append(path)
    return kept, todo, notes


class ReportWriter:
    """Appends records as they come; :meth:`finish` rewrites the report sorted by path.

    Names with undecodable bytes (surrogate escapes) are written as those
    bytes; a write that fails (a full disk) is an :class:`OutputError`.
    """

    def __init__(self, output, output_format, header, kept):
        self.output, self.head = output, (report.to_csv([]) if output_format == "csv" else "")
        self.format, self.rendered = output_format, rendered(output_format)
        self.lines = {f: line for f, (line, _) in kept.items()}
        self.report_file = self.state_file = None
        if output is None:
            return
        with self._writing():
            if not self.rendered:
                self.report_file = _open_for_writing(output)
                self.report_file.write(self.head + "".join(self.lines.values()))
            self.state_file = _open_for_writing(state_path(output))
            self.state_file.write(json.dumps(header) + "\n")
            self.state_file.writelines(json.dumps(self._entry(f, s, line)) + "\n" for f, (line, s) in kept.items())
            self._flush()

    def _entry(self, file, stat, line, retry=False):
        """A state file line: the file's stat (and, for a rendered report, its record)."""
        return {"file": file, "stat": stat, **({"retry": True} if retry else {}),
                **({"record": line} if self.rendered else {})}

    @contextmanager
    def _writing(self, path=None):
        try:
            yield
        except OSError as exc:
            self.close(quietly=True)
            raise OutputError(f"cannot write the report ({exc.strerror or exc})", path=path or self.output,
                              fix="free space, or give a path in an existing, writable folder") from None

    def _flush(self):
        for f in (self.report_file, self.state_file):
            if f is not None:
                f.flush()

    def add(self, outcome, stat, *, retry=False):
        """Append one record; it reaches the files at the next :meth:`flush` (or sooner)."""
        self.lines[outcome.file] = outcome.line
        if self.state_file is None:
            return
        with self._writing():
            # a row without its state entry, or an entry without its row, is merely recomputed on resume
            if self.report_file is not None:
                self.report_file.write(outcome.line)
            if stat is not None:
                self.state_file.write(json.dumps(self._entry(outcome.file, stat, outcome.line, retry)) + "\n")

    def flush(self):
        """Write the records added so far to the files: once for the outcomes that arrive together."""
        if self.state_file is not None:
            with self._writing():
                self._flush()

    def close(self, *, quietly=False):
        for f in (self.report_file, self.state_file):
            if f is not None:
                try:
                    f.close()
                except OSError:
                    if not quietly:
                        raise
        self.report_file = self.state_file = None

    def finish(self):
        """Close, and write the sorted report; returns its text when there is no output file."""
        with self._writing():
            self.close()
        ordered = [self.lines[f] for f in sorted(self.lines)]
        text = render(ordered, self.format) if self.rendered else self.head + "".join(ordered)
        if self.output is None:
            return text
        partial = self.output + ".sorting"
        with self._writing(partial):
            with _open_for_writing(partial) as f:
                f.write(text)
            os.replace(partial, self.output)
        return None


def _open_for_writing(path):
    return open(path, "w", encoding="utf-8", errors="surrogateescape", newline="")


def is_error(line, output_format):
    """Whether a report line is an error record."""
    if output_format != "csv":
        return json.loads(line).get("status") != "ok"
    return next(csv.reader([line]))[1] != "ok"

"""CSV: the columns of ``props --format csv`` and ``batch``, and the one writer of them."""

from __future__ import annotations

import re

__all__ = ["CSV_COLUMNS", "csv_row", "to_csv"]

CSV_COLUMNS = ("file,status,message,triangles,volume,mass,cx,cy,cz,Ixx,Iyy,Izz,Ixy,Ixz,Iyz,I1,I2,I3,"
               "a1x,a1y,a1z,a2x,a2y,a2z,a3x,a3y,a3z,err_volume,err_inertia,elapsed_s").split(",")


_COLUMN_SET = frozenset(CSV_COLUMNS)


_CSV_HEADER = ",".join(CSV_COLUMNS) + "\n"          # no column name needs quoting


def _cell(value):
    return "" if value is None else repr(value)


def csv_row(obj, *, status="ok", message=""):
    """One batch CSV row (a dict keyed by :data:`CSV_COLUMNS`) from a result object."""
    row = dict.fromkeys(CSV_COLUMNS, "")
    row.update(file=obj["file"], status=status, message=message)
    if status != "ok":
        return row
    row.update(triangles=obj["triangles"], err_volume=_cell(obj["error"]["volume"]),
               elapsed_s=_cell(obj["elapsed_s"]))
    row.update((key, _cell(obj[key])) for key in ("volume", "mass") if key in obj)
    if "center_of_mass" in obj:
        row.update(zip(("cx", "cy", "cz"), map(_cell, obj["center_of_mass"])))
    if "inertia_com" in obj:
        j = obj["inertia_com"]
        row.update(Ixx=_cell(j[0][0]), Iyy=_cell(j[1][1]), Izz=_cell(j[2][2]), Ixy=_cell(j[0][1]),
                   Ixz=_cell(j[0][2]), Iyz=_cell(j[1][2]), err_inertia=_cell(obj["error"]["inertia_com"]))
    if "principal_moments" in obj:
        row.update(zip(("I1", "I2", "I3"), map(_cell, obj["principal_moments"])))
        for k, axis in enumerate(obj["principal_axes"]):
            row.update(zip((f"a{k + 1}x", f"a{k + 1}y", f"a{k + 1}z"), map(_cell, axis)))
    return row


def to_csv(rows, columns=None):
    """CSV text with a header for rows made by :func:`csv_row` (or any dicts keyed by ``columns``).

    ``columns`` defaults to :data:`CSV_COLUMNS`; the robot report passes its
    own.  A field holding a comma, a quote, a carriage return or a line feed is
    quoted (quotes doubled), so every record reads back whole: Python's
    csv.writer leaves a lone carriage return unquoted when lines end in a line feed.
    """
    if columns is None:
        columns, column_set, header = CSV_COLUMNS, _COLUMN_SET, _CSV_HEADER
    else:
        column_set, header = frozenset(columns), ",".join(map(_csv_field, columns)) + "\n"
    lines = [header]
    for row in rows:
        extra = row.keys() - column_set
        if extra:
            raise ValueError(f"dict contains fields not in the CSV columns: {', '.join(map(repr, extra))}")
        values = [row.get(key, "") for key in columns]
        line = _plain_csv_line(values)
        lines.append(line if line is not None else ",".join(map(_csv_field, values)) + "\n")
    return "".join(lines)


_NEEDS_QUOTES = re.compile(r'[,"\r\n]')


def _csv_field(value):
    text = "" if value is None else str(value)
    return '"' + text.replace('"', '""') + '"' if _NEEDS_QUOTES.search(text) else text


def _plain_csv_line(values):
    """The CSV line of strings and ints that need no quoting, else None."""
    if not all(type(v) is str or type(v) is int for v in values):
        return None
    line = ",".join(map(str, values))
    if line.count(",") != len(values) - 1 or '"' in line or "\r" in line or "\n" in line:
        return None
    return line + "\n"

"""CSV: the columns of ``props --format csv`` and ``batch``, and the one writer of them."""

from __future__ import annotations

import math
import re

__all__ = ["CSV_COLUMNS", "csv_row", "csv_line", "result_csv_line", "to_csv"]

CSV_COLUMNS = ("file,status,message,triangles,volume,mass,cx,cy,cz,Ixx,Iyy,Izz,Ixy,Ixz,Iyz,I1,I2,I3,"
               "a1x,a1y,a1z,a2x,a2y,a2z,a3x,a3y,a3z,err_volume,err_inertia,elapsed_s").split(",")


_COLUMN_SET = frozenset(CSV_COLUMNS)


_CSV_HEADER = ",".join(CSV_COLUMNS) + "\n"          # no column name needs quoting


def _cell(value):
    return "" if value is None else repr(value)


def _cells(values):
    return ["" if v is None else repr(v) for v in values]


def csv_row(obj, *, status="ok", message=""):
    """One batch CSV row (a dict keyed by :data:`CSV_COLUMNS`) from a result object."""
    row = dict.fromkeys(CSV_COLUMNS, "")
    row["file"], row["status"], row["message"] = obj["file"], status, message
    if status != "ok":
        return row
    error = obj["error"]
    row["triangles"], row["err_volume"], row["elapsed_s"] = obj["triangles"], _cell(error["volume"]), \
        _cell(obj["elapsed_s"])
    if "volume" in obj:
        row["volume"] = _cell(obj["volume"])
    if "mass" in obj:
        row["mass"] = _cell(obj["mass"])
    if "center_of_mass" in obj:
        row["cx"], row["cy"], row["cz"] = _cells(obj["center_of_mass"])
    if "inertia_com" in obj:
        (xx, xy, xz), (_, yy, yz), (_, _, zz) = obj["inertia_com"]
        row["Ixx"], row["Iyy"], row["Izz"], row["Ixy"], row["Ixz"], row["Iyz"], row["err_inertia"] = _cells(
            (xx, yy, zz, xy, xz, yz, error["inertia_com"]))
    if "principal_moments" in obj:
        row["I1"], row["I2"], row["I3"] = _cells(obj["principal_moments"])
        (row["a1x"], row["a1y"], row["a1z"]), (row["a2x"], row["a2y"], row["a2z"]), \
            (row["a3x"], row["a3y"], row["a3z"]) = map(_cells, obj["principal_axes"])
    return row


def result_csv_line(result):
    """The CSV line (with its line feed) of a computed :class:`massprops.result.Result`, every quantity in it.

    The same text as ``csv_line(csv_row(result_dict(result)))`` (what ``props --format csv`` writes), formed
    from the result's numbers directly: a batch writes one per file.  Only the file name can need quoting
    (a number's repr holds no comma, quote or line break).
    """
    p = result.properties
    error = p.error
    values = [float(p.volume), float(p.mass)]
    values += _NONE_3 if p.center_of_mass is None else p.center_of_mass.tolist()
    if p.inertia_com is None:
        values += _NONE_18
        err_inertia = None
    else:
        (xx, xy, xz), (_, yy, yz), (_, _, zz) = p.inertia_com.tolist()
        found = p.principal
        values += (xx, yy, zz, xy, xz, yz)
        values += found.moments.tolist()
        values += found.axes.ravel().tolist()
        err_inertia = error.inertia_com
    values += (_float_or_none(error.volume), _float_or_none(err_inertia), _float_or_none(result.elapsed_s))
    isfinite = math.isfinite
    numbers = ",".join(["" if v is None or not isfinite(v) else repr(v) for v in values])
    return f"{_csv_field(result.file)},ok,,{result.triangles},{numbers}\n"


_NONE_3, _NONE_18 = (None,) * 3, (None,) * 18


def _float_or_none(value):
    return None if value is None else float(value)


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
    return "".join([header, *(_line(row, columns, column_set) for row in rows)])


def csv_line(row):
    """The CSV line (with its line feed) of one row made by :func:`csv_row`, as :func:`to_csv` writes it."""
    return _line(row, CSV_COLUMNS, _COLUMN_SET)


def _line(row, columns, column_set):
    extra = row.keys() - column_set
    if extra:
        raise ValueError(f"dict contains fields not in the CSV columns: {', '.join(map(repr, extra))}")
    values = [row.get(key, "") for key in columns]
    line = _plain_csv_line(values)
    return line if line is not None else ",".join(map(_csv_field, values)) + "\n"


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

"""Every command's output, rendered (no click, no printing): one number policy (:mod:`.digits`), text
(:mod:`.text`), JSON (:mod:`.objects`), CSV (:mod:`.tables`), JUnit XML (:mod:`.junit`), and the scene's
(:mod:`.scene`) and robots' (:mod:`.robot`) reports built from them.

The names below are the renderings of one result that every command shares.
"""

from .digits import relative_difference, significant, vector_text
from .objects import finite_or_null, plain, result_dict, to_json, to_jsonl
from .tables import CSV_COLUMNS, csv_row, to_csv
from .text import to_text

__all__ = ["significant", "vector_text", "relative_difference", "plain", "result_dict", "finite_or_null", "to_json",
           "to_jsonl", "to_text", "csv_row", "to_csv", "CSV_COLUMNS"]

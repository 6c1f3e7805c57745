"""Exact grouping of equal keys without sorting: hash-table rounds in numpy.

Welding vertices, pairing edges and finding duplicate faces all reduce to one
question: which rows carry equal keys?  Rows are hashed to 64 bits and
scattered into a table by the hash's top bits; a row whose slot holds a row
of equal hash is resolved, the others (a different hash won the slot) retry
with a remixed slot.  Then every row's key is compared with its group's, so
the result is exact; on a genuine 64-bit collision between different keys
(never seen in practice) the grouping is redone comparing full keys in every
round.  The work is linear in the number of rows, with no sort and no Python
loop over rows.
"""

from __future__ import annotations

import numpy as np

__all__ = ["group_ids", "point_groups", "representatives", "table_rounds", "mix"]

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_BLOCK = 1 << 16      # rows per first-pass block: its table (2 slots a row) stays in cache


def mix(h, scratch=None):
    """splitmix64's finaliser, in place on a uint64 array: a bijection of 64-bit words.

    ``scratch`` (same shape, uint64) receives the shifted copies, so a caller
    looping over blocks allocates nothing.
    """
    scratch = np.empty_like(h) if scratch is None else scratch
    for shift, factor in ((30, 0xBF58476D1CE4E5B9), (27, 0x94D049BB133111EB), (31, None)):
        np.right_shift(h, np.uint64(shift), out=scratch)
        h ^= scratch
        if factor:
            h *= np.uint64(factor)
    return h


def _salted(column, salt):
    return np.bitwise_xor(column, np.uint64((salt + 1) * int(_GOLDEN) % 2 ** 64), dtype=np.uint64)


def _hash_columns(columns, salt=0):
    """A 64-bit hash per row of key columns (each (n,), any unsigned integer type).

    With one column the hash is a bijection of the key (xor with a constant,
    then the bijective finaliser), so equal hashes mean equal keys.
    """
    h = _salted(columns[0], salt)
    scratch = np.empty_like(h)
    mix(h, scratch)
    for column in columns[1:]:
        h ^= column
        mix(h, scratch)
    return h


def _key_columns(points):
    """Bit-pattern columns of points (k, 3): float32 as uint32, anything else as float64 bits."""
    if points.dtype == np.float32:
        bits = points.view(np.uint32)
        xy = bits[:, 1].astype(np.uint64)
        xy <<= np.uint64(32)
        xy |= bits[:, 0]
        return [xy, bits[:, 2]], [bits[:, 0], bits[:, 1], bits[:, 2]]
    bits = points.view(np.uint64)
    columns = [bits[:, k] for k in range(3)]
    return columns, columns


def point_groups(points):
    """Group points (k, 3) by exact coordinates: (labels (k,), first (groups,)), as :func:`group_ids`.

    ``points`` must be C-contiguous float32 or float64 with ``-0.0`` already
    made ``+0.0``.  float32 points (binary STL) are hashed on their own bit
    patterns, x and y packed in one word.  Hashing runs block by block, in
    cache.
    """
    def hash_rows(start, stop):
        return _hash_columns(_key_columns(points[start:stop])[0])

    representative = representatives(points.shape[0], hash_rows)
    if not _columns_match(_key_columns(points)[1], representative):
        bits = points.view(np.uint32 if points.dtype == np.float32 else np.uint64).astype(np.uint64)
        representative = _exact_representatives(bits)
    return _dense_labels(representative)


def representatives(n, hash_rows):
    """For each of ``n`` rows, a row with the same hash: the first such row when numpy writes in order.

    Two passes of :func:`table_rounds`: first within blocks of consecutive
    rows, whose tables fit in cache (equal keys of a mesh sit close in its
    face order), then over the first row of each block's groups.  The result
    does not depend on the blocking.

    Parameters
    ----------
    n : int
    hash_rows : callable
        ``hash_rows(start, stop)`` returns the uint64 hashes of rows
        ``start .. stop-1``, shape (stop - start,).

    Returns
    -------
    ndarray, shape (n,), intp
    """
    if n == 0:
        return np.zeros(0, dtype=np.intp)
    index_type = np.int32 if n < 2 ** 31 - 1 else np.intp     # half the memory when it fits
    h = np.empty(n, dtype=np.uint64)
    local = np.empty(n, dtype=index_type)
    table = np.empty(4 * _BLOCK, dtype=index_type)
    leaders = []
    for start in range(0, n, _BLOCK):
        block = slice(start, min(n, start + _BLOCK))
        h[block] = hash_rows(block.start, block.stop)
        rows = np.arange(block.start, block.stop, dtype=index_type)
        winner = _slot_winners(h[block], rows, 0, table)
        resolved = h[winner] == h[block]
        local[block] = np.where(resolved, winner, rows)
        leaders.append(rows[local[block] == rows])
    if len(leaders) == 1:
        return table_rounds(h)
    leaders = np.concatenate(leaders)
    leader_of = table_rounds(h[leaders], leaders)
    # Every local representative is a leader: look it up in a full-size array,
    # which reuses the hashes' memory (no longer needed).
    representative = h.view(np.int64)
    representative[leaders] = leader_of
    del h, leaders, leader_of
    return representative[local]


def table_rounds(h, rows=None):
    """Representatives among ``rows`` (ascending; default 0..n-1) with hashes ``h``: see :func:`representatives`.

    Row numbers are scattered into a table by the top bits of the hash
    (written last row first, so that in each slot the earliest row wins); a
    row whose slot holds a row of equal hash is done, the others (a different
    hash won their slot) retry with a remixed slot.  Rows of equal hash always
    share a slot, so they resolve together, to one representative.
    """
    index = np.arange(h.size, dtype=np.int32 if h.size < 2 ** 31 - 1 else np.intp)
    representative = _slot_winners(h, index, 0)
    del index
    pending = np.flatnonzero(h[representative] != h)
    salt = 1
    while pending.size:
        candidate = _slot_winners(h[pending], pending, salt)
        same = h[candidate] == h[pending]
        representative[pending[same]] = candidate[same]
        pending = pending[~same]
        salt += 1
    return representative if rows is None else rows[representative]


def _slot_winners(h, rows, salt, table=None):
    """Scatter ``rows`` into a table by hash (earliest row last written) and read each row's slot back."""
    bits = max(4, int(2 * h.size - 1).bit_length())
    if salt:
        h = mix(_salted(h, salt))
    # The shifted hash is below 2**bits, so its bits read as a valid intp index.
    slot = np.right_shift(h, np.uint64(64 - bits)).view(np.intp)
    if table is None or table.size < 1 << bits:
        # Row numbers below 2**31 fit in half the memory (and cache).
        small = rows.size == 0 or rows[-1] < 2 ** 31 - 1
        table = np.empty(1 << bits, dtype=np.int32 if small else np.intp)
    table[slot[::-1]] = rows[::-1]
    return table[slot]


def _columns_match(columns, representative):
    """Whether every row's key equals its representative's key, column by column."""
    return all(np.array_equal(column[representative], column) for column in columns)


def _exact_representatives(keys):
    """Representatives by full-key comparison in every round (the fallback on 64-bit hash collisions)."""
    n = keys.shape[0]
    representative = np.empty(n, dtype=np.intp)
    pending = np.arange(n, dtype=np.intp)
    salt = 0
    while pending.size:
        pending_keys = keys[pending]
        winner = _slot_winners(_hash_columns(list(pending_keys.T), salt), pending, 0)
        same = np.all(keys[winner] == pending_keys, axis=1)
        representative[pending[same]] = winner[same]
        pending = pending[~same]
        salt += 1
    return representative


def _dense_labels(representative):
    """Labels 0..k-1 in order of each group's first row, and those first rows."""
    n = representative.shape[0]
    is_first = np.empty(n, dtype=bool)
    earliest = True
    for start in range(0, n, _BLOCK):       # blocks: no full-size row-number array
        block = representative[start:start + _BLOCK]
        rows = np.arange(start, start + block.size, dtype=block.dtype)
        earliest &= bool(np.all(block <= rows))
        np.equal(block, rows, out=is_first[start:start + block.size])
    if not earliest:
        # Some representative is not its group's first row: take the minimum.
        first_of_group = np.full(n, n, dtype=np.intp)
        np.minimum.at(first_of_group, representative, np.arange(n, dtype=np.intp))
        return _dense_labels(first_of_group[representative])
    dense = np.cumsum(is_first, dtype=np.int64)
    dense -= 1
    return dense[representative], np.flatnonzero(is_first)


def group_ids(keys):
    """Label rows of ``keys`` so that equal rows, and only equal rows, share a label.

    Parameters
    ----------
    keys : ndarray, shape (n, w), dtype uint64
        One key per row.

    Returns
    -------
    labels : ndarray, shape (n,), int64
        Dense labels ``0 .. k-1``, numbered in order of each group's first row.
    first : ndarray, shape (k,), int64
        For each label, the index of the first row that carries it.
    """
    keys = np.ascontiguousarray(keys, dtype=np.uint64)
    if keys.shape[0] == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    columns = [keys[:, k] for k in range(keys.shape[1])]
    representative = representatives(keys.shape[0], lambda start, stop: _hash_columns(
        [column[start:stop] for column in columns]))
    if len(columns) > 1 and not _columns_match(columns, representative):
        representative = _exact_representatives(keys)
    return _dense_labels(representative)

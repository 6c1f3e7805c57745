"""Exact grouping of equal keys: hash-table rounds in numpy.

Welding vertices, pairing edges and finding duplicate faces all reduce to one
question: which rows carry equal keys?  Rows are hashed to 64 bits and
scattered into a table by the hash's top bits; a row whose slot holds a row
of equal hash is resolved, the others (a different hash won the slot) retry
with a remixed slot.  Then every row's key is compared with its group's, so
the result is exact; on a genuine 64-bit collision between different keys
(never seen in practice) the grouping is redone comparing full keys in every
round.  The work is linear in the number of rows, with no Python loop over
rows; only the last few thousand unresolved rows, where a round's per-call
overhead would dominate, are finished by a stable sort.
"""

from __future__ import annotations

import numpy as np

from .parallel import start as start_call, thread_count

__all__ = ["group_ids", "point_representatives", "first_of_groups", "labels_of", "representatives",
           "table_rounds", "mix"]

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_BLOCK = 1 << 16      # rows per first-pass block: its table (2 slots a row) stays in cache
_SORT_UP_TO = 2048    # hashes: below this a stable sort beats the hash-table rounds' per-call overhead


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


def _hash_points(points):
    """64-bit hashes of points (k, 3) from their bit patterns (float32: see _hash_float32_points)."""
    if points.dtype == np.float32:
        return _hash_float32_points(points.view(np.uint32))
    bits = points.view(np.uint64)
    return _hash_columns([bits[:, k] for k in range(3)])


def _hash_float32_points(bits):
    """Hashes of float32 points from their bits (k, 3) uint32: 12 array operations, not the 21 of _hash_columns.

    x and y packed in one word go through a bijection (odd multiply,
    xorshift), z through an injection (odd multiply) into 64 bits; their xor
    meets a final multiply whose top bits, the table's slot, depend on every
    input bit.  Distinct points share a hash only by a 64-bit coincidence,
    which the key comparison after the tables catches.
    """
    h = bits[:, 1].astype(np.uint64)
    h <<= np.uint64(32)
    h |= bits[:, 0]
    h *= _GOLDEN
    scratch = h >> np.uint64(29)
    h ^= scratch
    np.multiply(bits[:, 2], np.uint64(0xBF58476D1CE4E5B9), out=scratch, dtype=np.uint64)
    h ^= scratch
    h *= np.uint64(0x94D049BB133111EB)
    np.right_shift(h, np.uint64(32), out=scratch)
    h ^= scratch
    return h


def point_representatives(points):
    """For each point (k, 3), the first point with exactly the same coordinates.

    ``points`` must be C-contiguous float32 or float64 with ``-0.0`` already
    made ``+0.0``.  Hashing and most comparisons run block by block, in cache.
    Use :func:`first_of_groups` and :func:`labels_of` for dense labels.
    """
    bits = points.view(np.uint32 if points.dtype == np.float32 else np.uint64)
    representative = representatives(points.shape[0], lambda start, stop: _hash_points(points[start:stop]),
                                      bits)
    if representative is None:
        representative = _exact_representatives(bits.astype(np.uint64))
    return representative


def representatives(n, hash_rows, keys=None):
    """For each of ``n`` rows, the first row with the same key (when numpy writes in order).

    Two passes of :func:`table_rounds`: first within blocks of consecutive
    rows, whose tables fit in cache (equal keys of a mesh sit close in its
    face order), then over the first row of each block's groups.  The result
    does not depend on the blocking.  Rows are matched by hash; with
    ``keys`` the keys themselves are then compared (in the block, and
    between the blocks' first rows, which by transitivity covers every row).

    Parameters
    ----------
    n : int
    hash_rows : callable
        ``hash_rows(start, stop)`` returns the uint64 hashes of rows
        ``start .. stop-1``, shape (stop - start,).
    keys : ndarray, shape (n, w), optional
        The keys.  Without them the hash must be a bijection of the key.

    Returns
    -------
    ndarray, shape (n,), or None
        None if two different keys share a hash (the caller then compares
        full keys in every round).
    """
    if n == 0:
        return np.zeros(0, dtype=np.intp)
    index_type = np.int32 if n < 2 ** 31 - 1 else np.intp     # half the memory when it fits
    if n <= _BLOCK:
        # One block: the table rounds resolve every row at once, with no second pass.
        representative = table_rounds(hash_rows(0, n))
        if keys is not None and not np.array_equal(np.take(keys, representative, axis=0), keys):
            return None
        return representative
    local = np.empty(n, dtype=index_type)
    starts = range(0, n, _BLOCK)
    # The blocks are independent: with several cores, a second thread takes
    # every other block (numpy releases the GIL in each operation).
    threaded = len(starts) >= 8 and thread_count() >= 2
    other = start_call(_block_pass, starts[1::2], hash_rows, keys, local, threaded=threaded)
    found = _block_pass(starts[::2] if threaded else starts, hash_rows, keys, local)
    if threaded:
        theirs = other()
        found = None if found is None or theirs is None else {**found, **theirs}
    if found is None:
        return None
    leaders = np.concatenate([found[begin][0] for begin in starts])
    leader_of = table_rounds(np.concatenate([found[begin][1] for begin in starts]), leaders)
    del found
    if keys is not None and not all(
            np.array_equal(np.take(keys, leader_of[begin:begin + _BLOCK], axis=0),
                           np.take(keys, leaders[begin:begin + _BLOCK], axis=0))
            for begin in range(0, leaders.size, _BLOCK)):
        return None
    # Every local representative is a leader: look it up in a full-size array.
    representative = np.empty(n, dtype=index_type)
    representative[leaders] = leader_of
    del leaders, leader_of
    for begin in range(0, n, _BLOCK):          # in place, block by block: no third full-size array
        block = local[begin:begin + _BLOCK]
        block[:] = representative[block]
    return local


def _block_pass(starts, hash_rows, keys, local):
    """Hash the blocks beginning at ``starts`` and resolve each within itself (see representatives).

    Fills ``local`` for those rows; returns {block start: (the rows that are
    their own local representative, their hashes)}, or None on a hash collision.
    """
    table = np.empty(4 * _BLOCK, dtype=local.dtype)
    found = {}
    for begin in starts:
        block = slice(begin, min(local.size, begin + _BLOCK))
        h = hash_rows(block.start, block.stop)
        rows = np.arange(block.start, block.stop, dtype=local.dtype)
        winner = _slot_winners(h, rows, 0, table)
        offset = winner - begin
        np.copyto(winner, rows, where=h[offset] != h)
        if keys is not None and not np.array_equal(np.take(keys, winner, axis=0), keys[block]):
            return None
        local[block] = winner
        leader = np.flatnonzero(winner == rows)
        found[begin] = (rows[leader], h[leader])
    return found


def table_rounds(h, rows=None):
    """Representatives among ``rows`` (ascending; default 0..n-1) with hashes ``h``: see :func:`representatives`.

    Row numbers are scattered into a table by the top bits of the hash
    (written last row first, so that in each slot the earliest row wins); a
    row whose slot holds a row of equal hash is done, the others (a different
    hash won their slot) retry with a remixed slot.  Rows of equal hash always
    share a slot, so they resolve together, to one representative.
    """
    if h.size <= _SORT_UP_TO:
        representative = _sorted_representatives(h)
        return representative if rows is None else rows[representative]
    representative = _slot_winners(h, None, 0)
    pending = _unresolved(h, representative)
    salt = 1
    while pending.size:
        if pending.size <= _SORT_UP_TO:
            representative[pending] = pending[_sorted_representatives(h[pending])]
            break
        candidate = _slot_winners(h[pending], pending, salt)
        same = h[candidate] == h[pending]
        representative[pending[same]] = candidate[same]
        pending = pending[~same]
        salt += 1
    return representative if rows is None else rows[representative]


def _sorted_representatives(h):
    """For each hash, the first position holding an equal hash, by a stable sort.

    The same representatives as the table rounds give, in one numpy call
    instead of a round per remix: cheaper for a few thousand hashes.
    """
    order = np.argsort(h, kind="stable")
    ordered = h[order]
    starts = np.empty(h.size, dtype=bool)
    starts[:1] = True
    np.not_equal(ordered[1:], ordered[:-1], out=starts[1:])
    representative = np.empty(h.size, dtype=np.intp)
    # A stable sort puts each group's earliest position at its start.
    representative[order] = order[starts][np.cumsum(starts) - 1]
    return representative


def _slot_winners(h, rows, salt, table=None):
    """Scatter ``rows`` (None: 0..n-1) into a table by hash, earliest row last written; read each slot back.

    Large inputs go block by block (last block first, so the earliest row
    still wins), which keeps the temporaries small.
    """
    n = h.size
    # Two slots a row; one for very large inputs, to bound the table's memory.
    bits = max(4, int(2 * n - 1 if n <= 1 << 24 else n - 1).bit_length())
    if salt:
        h = mix(_salted(h, salt))
    shift = np.uint64(64 - bits)
    if table is None or table.size < 1 << bits:
        # Row numbers below 2**31 fit in half the memory (and cache).
        small = n == 0 or (n if rows is None else rows[-1]) < 2 ** 31 - 1
        table = np.empty(1 << bits, dtype=np.int32 if small else np.intp)
    starts = range(0, n, _BLOCK)
    for start in reversed(starts):
        # The shifted hash is below 2**bits, so its bits read as a valid intp index.
        slot = np.right_shift(h[start:start + _BLOCK], shift).view(np.intp)
        block_rows = (np.arange(start, start + slot.size, dtype=table.dtype) if rows is None
                      else rows[start:start + _BLOCK])
        table[slot[::-1]] = block_rows[::-1]
    winners = np.empty(n, dtype=table.dtype)
    for start in starts:
        slot = np.right_shift(h[start:start + _BLOCK], shift).view(np.intp)
        np.take(table, slot, out=winners[start:start + slot.size])
    return winners


def _unresolved(h, representative):
    """Rows whose representative has a different hash, block by block."""
    pending = [np.flatnonzero(h[representative[start:start + _BLOCK]] != h[start:start + _BLOCK]) + start
               for start in range(0, h.size, _BLOCK)]
    return np.concatenate(pending) if pending else np.zeros(0, dtype=np.intp)


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


def first_of_groups(representative):
    """Flags of the rows that are their group's first row, and the representatives made those rows.

    Returns
    -------
    is_first : ndarray, shape (n,), bool
    representative : ndarray, shape (n,)
        The input when every representative already is its group's first row
        (what the hash tables give when numpy writes in order), else the
        group minimum.
    """
    n = representative.shape[0]
    is_first = np.empty(n, dtype=bool)
    earliest = True
    for start in range(0, n, _BLOCK):       # blocks: no full-size row-number array
        block = representative[start:start + _BLOCK]
        rows = np.arange(start, start + block.size, dtype=block.dtype)
        earliest &= bool(np.all(block <= rows))
        np.equal(block, rows, out=is_first[start:start + block.size])
    if earliest:
        return is_first, representative
    first_of_group = np.full(n, n, dtype=np.intp)
    np.minimum.at(first_of_group, representative, np.arange(n, dtype=np.intp))
    return first_of_groups(first_of_group[representative])


def labels_of(is_first, representative):
    """Dense int64 labels 0..k-1 in order of first rows, built block by block (small temporaries)."""
    n = representative.shape[0]
    dense = np.cumsum(is_first, dtype=np.int32 if n < 2 ** 31 - 1 else np.int64)
    dense -= 1
    labels = np.empty(n, dtype=np.int64)
    for start in range(0, n, _BLOCK):
        labels[start:start + _BLOCK] = dense[representative[start:start + _BLOCK]]
    return labels


def _dense_labels(representative):
    """Labels 0..k-1 in order of each group's first row, and those first rows."""
    is_first, representative = first_of_groups(representative)
    return labels_of(is_first, representative), np.flatnonzero(is_first)


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
        [column[start:stop] for column in columns]), keys if len(columns) > 1 else None)
    if representative is None:
        representative = _exact_representatives(keys)
    return _dense_labels(representative)

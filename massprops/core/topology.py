"""Which directed edges pair up, and which faces connect: the grouping behind the mesh checks.

Edges are matched by a hash that is a bijection of the (lower, higher)
vertex pair, grouped with hash tables (:mod:`massprops.core.grouping`), and
counted per undirected edge with their direction, so a closed, consistently
wound surface shows every edge used forward as often as backward.  Shells
are the connected components of faces sharing vertices, by vectorised
hook-and-compress.  No Python loop over edges or faces.
"""

from __future__ import annotations

import numpy as np

from ..errors import MeshGeometryError
from .grouping import group_ids, table_rounds

__all__ = ["edge_balance", "match_edges", "uses", "face_components"]


def _edge_hash(tail, head, vertex_bits):
    """A hash of each directed edge tail → head that is a bijection of its undirected edge, and its direction.

    The lower vertex fills the top bits and an odd multiple of the higher one
    the rest, so a hash table's slot (the top bits) is the lower vertex
    followed by a multiplicative hash of the higher: welded labels follow the
    face order, so consecutive edges land in nearby slots (cache-friendly),
    and distinct edges of one vertex spread over its slots.  The direction is
    +1 from the lower vertex to the higher, -1 back, 0 for a collapsed edge.
    """
    if vertex_bits > 32:
        raise MeshGeometryError("more than 2**32 vertices: too many for the edge check",
                                fix="split the mesh into parts")
    difference = head - tail
    direction = np.sign(difference).astype(np.int8)
    low = np.minimum(tail, head)
    high = np.abs(difference, out=difference)             # the higher vertex is the lower plus |head - tail|
    high += low
    shift = np.uint64(64 - vertex_bits)
    low, high = low.view(np.uint64), high.view(np.uint64)
    high *= np.uint64(0x9E3779B97F4A7C15)                # odd: a bijection mod 2**k
    high &= np.uint64((1 << int(shift)) - 1)
    low <<= shift
    low |= high
    return low, direction


def _edges_of(faces, rows):
    """Tail and head vertices of directed edges ``rows``: edge 3f + k runs from corner k to corner k+1 of face f."""
    flat = faces.ravel()
    following = rows + 1
    following[rows % 3 == 2] -= 3
    return flat[rows], flat[following]


_FACE_BLOCK = 1 << 15
_SMALL_HOOK_BLOCK = 1 << 10        # faces per block of the first hooking pass over a one-block mesh
# Up to this many edges (128 MiB of hashes) the edge hashes are kept; above, recomputed where needed.
_KEEP_EDGE_HASHES_UP_TO = 1 << 24


def _edge_representatives(faces, n_vertices):
    """For each directed edge, an edge of the same undirected edge (the first, as numpy writes in order).

    One hash-table round over all 3m edges, block by block (for very large
    meshes recomputing the edge hashes instead of storing them, so memory
    stays near the table's); edges whose slot another edge won go through
    :func:`table_rounds`.

    Returns
    -------
    representative : ndarray, shape (3m,)
    direction : ndarray, shape (3m,), int8
    """
    faces = np.ascontiguousarray(faces)
    m = faces.shape[0]
    vertex_bits = max(1, int(n_vertices - 1).bit_length())
    bits = max(4, int(6 * m - 1).bit_length())             # two slots an edge
    table = np.empty(1 << bits, dtype=np.int32 if 3 * m < 2 ** 31 - 1 else np.intp)
    shift = np.uint64(64 - bits)
    if m <= _FACE_BLOCK:
        return _one_block_edge_representatives(faces, vertex_bits, table, shift)
    starts = range(0, m, _FACE_BLOCK)
    keys = _block_edge_hashes(faces, starts, vertex_bits) if 3 * m <= _KEEP_EDGE_HASHES_UP_TO else None

    def block_hashes(begin):
        if keys is not None:
            rows = slice(3 * begin, 3 * min(m, begin + _FACE_BLOCK))
            h, direction = keys[0][rows], keys[1][rows]
        else:
            block = faces[begin:begin + _FACE_BLOCK]
            h, direction = (part.ravel() for part in _edge_hash(block, block[:, [1, 2, 0]], vertex_bits))
        return h, direction, np.right_shift(h, shift).view(np.intp)

    for begin in reversed(starts):                         # so that in each slot the earliest edge wins
        _, _, slot = block_hashes(begin)
        table[slot[::-1]] = np.arange(3 * begin, 3 * begin + slot.size, dtype=table.dtype)[::-1]
    representative = np.empty(3 * m, dtype=table.dtype)
    direction = np.empty(3 * m, dtype=np.int8) if keys is None else keys[1]
    pending = []
    for begin in starts:
        h, block_direction, slot = block_hashes(begin)
        rows = slice(3 * begin, 3 * begin + h.size)
        winner = np.take(table, slot, out=representative[rows])
        if keys is None:
            direction[rows] = block_direction
            same = _winner_hashes(faces, winner, h, 3 * begin, vertex_bits) == h
        else:
            same = np.take(keys[0], winner) == h
        pending.append(np.flatnonzero(~same) + 3 * begin)
    del table
    pending = np.concatenate(pending) if pending else np.zeros(0, dtype=np.intp)
    if pending.size:
        # Every edge of a pending edge's group is pending too (they share its slot).
        pending_hashes = (_edge_hash(*_edges_of(faces, pending), vertex_bits)[0] if keys is None
                          else keys[0][pending])
        representative[pending] = table_rounds(pending_hashes, pending)
    return representative, direction


def _block_edge_hashes(faces, starts, vertex_bits):
    """The edge hashes and directions of :func:`_edge_hash` for all edges, computed block by block (in cache)."""
    m = faces.shape[0]
    h = np.empty(3 * m, dtype=np.uint64)
    direction = np.empty(3 * m, dtype=np.int8)
    for begin in starts:
        block = faces[begin:begin + _FACE_BLOCK]
        rows = slice(3 * begin, 3 * (begin + block.shape[0]))
        block_h, block_direction = _edge_hash(block, block[:, [1, 2, 0]], vertex_bits)
        h[rows], direction[rows] = block_h.ravel(), block_direction.ravel()
    return h, direction


def _winner_hashes(faces, winner, h, first_row, vertex_bits):
    """Hashes of the edges ``winner``: from ``h`` (rows from ``first_row``) when in this block, else recomputed."""
    offset = winner - first_row
    far = np.flatnonzero((offset < 0) | (offset >= h.size))
    np.clip(offset, 0, h.size - 1, out=offset)
    winner_h = h[offset]
    if far.size:
        winner_h[far] = _edge_hash(*_edges_of(faces, winner[far]), vertex_bits)[0]
    return winner_h


def _one_block_edge_representatives(faces, vertex_bits, table, shift):
    """_edge_representatives for a mesh that is one block: whole-array steps, fewer numpy calls."""
    key, direction = (part.ravel() for part in _edge_hash(faces, faces[:, [1, 2, 0]], vertex_bits))
    slot = np.right_shift(key, shift).view(np.intp)
    # Written last edge first, so that in each slot the earliest edge wins.
    table[slot[::-1]] = np.arange(key.size - 1, -1, -1, dtype=table.dtype)
    representative = np.take(table, slot)
    pending = np.flatnonzero(key[representative] != key)
    if pending.size:
        representative[pending] = table_rounds(key[pending], pending)
    return representative, direction


def edge_balance(faces, n_vertices):
    """Per undirected edge: how often it is used, and forward minus backward uses (int32).

    Both are indexed by one representative directed edge of each undirected
    edge (zero at the other indices), which is all the checks need.
    """
    representative, _, balance = match_edges(faces, n_vertices)
    return uses(representative), balance


def match_edges(faces, n_vertices):
    """Edge representatives and directions, and the balance per representative (see edge_balance)."""
    representative, direction = _edge_representatives(faces, n_vertices)
    balance = np.zeros(direction.size, dtype=np.int32)
    for begin in range(0, direction.size, _FACE_BLOCK):
        # ufunc.at is fast when index, target and values share a dtype; blocks keep the copies small.
        np.add.at(balance, representative[begin:begin + _FACE_BLOCK].astype(np.intp, copy=False),
                  direction[begin:begin + _FACE_BLOCK].astype(np.int32))
    return representative, direction, balance


def uses(representative):
    """How many directed edges each representative stands for (int32, zero elsewhere)."""
    return np.bincount(representative, minlength=representative.size).astype(np.int32)


def face_components(faces, n_vertices):
    """Connected components of faces sharing vertices: (labels per face, count).

    Hook-and-compress label propagation.  A first pass over the faces, block
    by block, hooks every root that a face reaches to the smallest root of
    that face (any one such write wins; roots only ever point to smaller
    roots, so no cycle forms), then paths are halved until every vertex
    points at its root.  A second pass finds the faces whose corners still
    reach different roots; from then on only those faces are hooked and
    looked at again: hooking joins whole trees, so a face whose corners share
    a root keeps sharing one.  No Python loop over elements.
    """
    if faces.shape[0] == 0:
        return np.zeros(0, dtype=np.int64), 0
    # One spare slot at the end absorbs the writes of faces that hook nothing.
    index_type = np.int32 if n_vertices < 2 ** 31 - 2 else np.intp
    parent = np.arange(n_vertices + 1, dtype=index_type)
    grand = np.empty_like(parent)
    # Later blocks see the hooks of earlier ones, so labels spread along the face
    # order in one pass; a small mesh pays for more, smaller blocks with fewer rounds.
    block = _FACE_BLOCK if faces.shape[0] > _FACE_BLOCK else _SMALL_HOOK_BLOCK
    for begin in range(0, faces.shape[0], block):
        _hook(parent, parent[faces[begin:begin + block]])
    _compress(parent, grand)
    face_root = np.empty(faces.shape[0], dtype=index_type)
    spanning = []
    for begin in range(0, faces.shape[0], _FACE_BLOCK):
        roots = parent[faces[begin:begin + _FACE_BLOCK]]
        face_root[begin:begin + roots.shape[0]] = roots[:, 0]
        spanning.append(np.flatnonzero(_spans(roots)) + begin)
    spanning = np.concatenate(spanning)
    while spanning.size:
        _hook(parent, parent[faces[spanning]])
        _compress(parent, grand)
        spanning = spanning[_spans(parent[faces[spanning]])]
    np.take(parent, face_root, out=face_root)
    if np.all(face_root == face_root[0]):
        return np.zeros(faces.shape[0], dtype=np.int64), 1
    labels, first = group_ids(face_root.astype(np.uint64)[:, None])
    return labels, first.size


def _spans(roots):
    """Flags of the rows of ``roots`` (k, 3) that are not one root three times."""
    return (roots[:, 0] != roots[:, 1]) | (roots[:, 1] != roots[:, 2])


def _hook(parent, roots):
    """Point each root in ``roots`` (k, 3) that is not its row's smallest at that smallest, in place."""
    smallest = np.minimum(np.minimum(roots[:, 0], roots[:, 1]), roots[:, 2])[:, None]
    hook = roots > smallest
    if hook.any():
        parent[np.where(hook, roots, parent.size - 1)] = smallest
        parent[-1] = parent.size - 1


def _compress(parent, grand):
    """Halve paths until every entry of ``parent`` is its root (``grand`` is scratch of the same shape)."""
    while True:
        np.take(parent, parent, out=grand)
        np.take(grand, grand, out=parent)
        if np.array_equal(grand, parent):
            return

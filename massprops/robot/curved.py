"""The union of overlapping primitives of one density: closed forms where they exist, a certified octree elsewhere.

A link's solid is the union of its geometries.  For a cluster of primitives
(box, sphere, cylinder, capsule, cone, ellipsoid) that may overlap, the
union's volume moments ``(V, ∫x, ∫x xᵀ)`` are computed with an absolute
bound on each, in this order:

1. **Solids of revolution on one axis** (cylinders, capsules, cones, and the
   spheres whose centre is on that axis; two spheres on the line through their
   centres) are one *unit*: the union has the radius profile ``R(z)² = max_k
   R_k(z)²``, each ``R_k²`` a polynomial of degree ≤ 2 in ``z`` on an interval.
   ``V = π∫R²``, ``∫z = π∫zR²``, ``∫z² = π∫z²R²``, ``∫x² = ∫y² = π∫R⁴/4``:
   polynomials integrated exactly in rationals between breakpoints (the ends of
   the pieces and the crossings of two profiles; an irrational crossing is a
   float whose bracket ``[t − ε, t + ε]`` is verified by exact signs, and the
   bound takes ``2ε max|R_i² − R_j²|`` there).  A member off the axis by
   rounding (``δ``) is modelled on it, and the bound adds ``2δ`` times its area
   (the volume a surface moved by ``δ`` sweeps), times ``|x|`` or ``|x|²``.
2. **Two units** that are certified disjoint (a separating plane, support
   functions with a margin above the rounding) share nothing; one inside the
   other (support functions against a box's faces, farthest points against a
   sphere, cylinder or capsule) share the inner one; a unit of revolution
   whose axis is a box's axis and whose radius stays inside the box's cross
   section shares with the box the profile clipped to the box's slab.
3. **Prisms along one direction** (cylinders and boxes whose axes agree within
   1e-9 rad, each modelled exactly along it with the swept volume of the turn
   in the bound): exact in slabs between their ends, and across each slab a
   certified quadtree as below, in two dimensions.
4. **Otherwise** (three units that pairwise meet, or a pair none of the above
   decides) an octree over the region where units meet classifies cells by
   1-Lipschitz functions ``g_k`` (``g_k < 0`` inside unit ``k``: distance to a
   sphere, segment, cylinder, box; ``min r · (|y/r| − 1)`` for an ellipsoid):
   a cell is inside (outside) unit ``k`` when ``g_k`` at its centre is below
   (above) minus (plus) its half diagonal and the rounding.  The volume
   counted more than once, ``∫max(0, n(x) − 1)`` (``n`` the number of units
   holding ``x``), is exact on decided cells and bounded on the others; cells
   are refined until the bound is at most the tolerance or the budget is spent.

The union is ``Σ units − that excess``; see :func:`cluster_union`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

from ..core.rounding import U as _U

__all__ = ["Raw", "cluster_union", "REVOLUTION"]

REVOLUTION = ("cylinder", "capsule", "cone", "sphere")
_CELL_BUDGET = 4_000_000          # cells classified per cluster before the octree stops


@dataclass
class Raw:
    """Volume moments ``(V, ∫x, ∫x xᵀ)`` in the link frame and absolute bounds on each (largest element).

    The bounds are those of the moments about ``ref`` (``∫(x − ref)``, ``∫(x − ref)(x − ref)ᵀ``), a point near
    the solid: about the link origin far away they would be far larger than the inertia they end in.
    """

    volume: float
    first: np.ndarray
    second: np.ndarray
    e_volume: float = 0.0
    e_first: float = 0.0
    e_second: float = 0.0
    ref: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def at(self, ref):
        """The same moments, their bounds about ``ref``."""
        step = float(np.abs(np.asarray(ref) - self.ref).max())
        if step == 0:
            return self
        return Raw(self.volume, self.first, self.second, self.e_volume, self.e_first + step * self.e_volume,
                   self.e_second + 2 * step * self.e_first + step * step * self.e_volume, np.asarray(ref, float))

    def __add__(self, other):
        other = other.at(self.ref)
        return Raw(self.volume + other.volume, self.first + other.first, self.second + other.second,
                   *self._errors(other), self.ref)

    def __sub__(self, other):
        other = other.at(self.ref)
        return Raw(self.volume - other.volume, self.first - other.first, self.second - other.second,
                   *self._errors(other), self.ref)

    def _errors(self, other):
        grow = 1 + 4 * _U
        return ((self.e_volume + other.e_volume + _U * (abs(self.volume) + abs(other.volume))) * grow,
                (self.e_first + other.e_first + _U * float(np.abs(self.first).max() + np.abs(other.first).max()))
                * grow,
                (self.e_second + other.e_second + _U * float(np.abs(self.second).max() + np.abs(other.second).max()))
                * grow)


def zero_raw(ref=None):
    return Raw(0.0, np.zeros(3), np.zeros((3, 3)), ref=np.zeros(3) if ref is None else np.asarray(ref, float))


def raw_of(props):
    """The volume moments of placed :class:`MassProperties` (link frame), with bounds from its error bounds."""
    pose = props.pose
    rotation, translation = pose.rotation, pose.translation
    c = rotation @ props.center_of_mass + translation
    volume = props.volume
    per_volume = volume / props.mass if props.mass else 0.0
    j = rotation @ props.inertia_com @ rotation.T * per_volume
    second = np.trace(j) / 2 * np.eye(3) - j + volume * np.outer(c, c)
    error = props.error
    e_com = error.center_of_mass + 8 * _U * (float(np.abs(c).max()) + float(np.abs(translation).max()))
    e_j = error.inertia_com * per_volume + 16 * _U * float(np.abs(j).max())
    # About c: ∫(x − c) = V (c_true − c), ∫(x − c)(x − c)ᵀ from the tensor and the center's error.
    e_first = (volume + error.volume) * e_com
    e_second = 2.5 * e_j + (volume + error.volume) * e_com * e_com + 16 * _U * float(np.abs(second).max())
    return Raw(volume, volume * c, second, error.volume, e_first * (1 + 1e-9), e_second * (1 + 1e-9), c)


def props_of(raw, density, area):
    """:class:`MassProperties` (identity pose, link frame) of volume moments at ``density``, bounds propagated."""
    from ..model.properties import ErrorBounds, MassProperties
    v, f, s = raw.volume, raw.first, raw.second
    ev, ef, es = raw.e_volume, raw.e_first, raw.e_second
    low = v - ev
    if not low > 0:
        return None
    r = raw.ref
    fr = f - v * r                                   # about ref, where the bounds are
    sr = s - np.outer(r, f) - np.outer(f, r) + v * np.outer(r, r)
    pr = float(np.abs(r).max())
    shift_rounding = 16 * _U * (float(np.abs(s).max()) + 2 * pr * float(np.abs(f).max()) + abs(v) * pr * pr)
    cr = fr / v
    c = r + cr
    central = sr - np.outer(fr, fr) / v
    j = (np.trace(central) * np.eye(3) - central) * density
    size_f = float(np.abs(fr).max())
    e_c = (ef + 16 * _U * (float(np.abs(f).max()) + abs(v) * pr) + float(np.abs(cr).max()) * ev) / low \
        + 4 * _U * float(np.abs(c).max())
    e_central = es + shift_rounding + (2 * size_f * ef + ef * ef) / low + size_f * size_f * ev / (v * low) \
        + 16 * _U * size_f * size_f / v
    e_j = 2 * e_central * density * (1 + 1e-9) + 8 * _U * float(np.abs(j).max())
    mass = v * density
    error = ErrorBounds(volume=ev, mass=ev * density * (1 + 2 * _U) + _U * mass, center_of_mass=e_c * (1 + 1e-9),
                        inertia_com=e_j)
    return MassProperties(v, mass, density, area, c, j, error)


# -- units ---------------------------------------------------------------------------

@dataclass
class _Prim:
    """One primitive in the link frame: ``x = R y + t`` with ``y`` in its own frame (z its axis)."""

    name: str
    kind: str
    size: dict
    rotation: np.ndarray
    translation: np.ndarray
    props: object

    @property
    def axis(self):
        return self.rotation[:, 2]

    def dims(self):
        s = self.size
        if self.kind == "box":
            return np.asarray(s["size"], float) / 2
        if self.kind == "ellipsoid":
            return np.asarray(s["radii"], float)
        if self.kind == "sphere":
            return np.array([float(s["radius"])] * 3)
        return np.array([float(s["radius"]), float(s.get("length", 0.0)) / 2])

    def reach(self):
        """A radius around ``translation`` holding the primitive."""
        d = self.dims()
        if self.kind in ("box", "ellipsoid", "sphere"):
            return float(np.linalg.norm(d)) if self.kind == "box" else float(d.max())
        r, h = d
        return math.hypot(r, h) + (r if self.kind == "capsule" else 0.0)

    def local(self, points):
        return (points - self.translation) @ self.rotation

    def g(self, points):
        """A 1-Lipschitz function, negative inside, positive outside (see the module docstring)."""
        y = self.local(points)
        kind, d = self.kind, self.dims()
        if kind == "sphere":
            return np.linalg.norm(y, axis=1) - d[0]
        if kind == "box":
            return (np.abs(y) - d).max(axis=1)
        if kind == "ellipsoid":
            return (np.linalg.norm(y / d, axis=1) - 1) * float(d.min())
        r, h = d
        radial = np.hypot(y[:, 0], y[:, 1])
        if kind == "cylinder":
            return np.maximum(radial - r, np.abs(y[:, 2]) - h)
        if kind == "capsule":
            z = np.clip(y[:, 2], -h, h)
            return np.hypot(radial, y[:, 2] - z) - r
        # cone: base radius r at z = −h, apex at +h
        length = 2 * h
        side = (radial - r * (h - y[:, 2]) / length) / math.hypot(1.0, r / length)
        return np.maximum(-y[:, 2] - h, side)

    def support(self, n):
        """``max n·x`` over the primitive (a float; callers add a margin)."""
        kind, d = self.kind, self.dims()
        base = float(n @ self.translation)
        local = self.rotation.T @ n
        if kind == "sphere":
            return base + d[0] * float(np.linalg.norm(n))
        if kind == "box":
            return base + float(np.abs(local) @ d)
        if kind == "ellipsoid":
            return base + float(np.linalg.norm(local * d))
        r, h = d
        along = float(local[2])
        across = math.sqrt(max(0.0, float(local[0] ** 2 + local[1] ** 2)))
        if kind == "cylinder":
            return base + h * abs(along) + r * across
        if kind == "capsule":
            return base + h * abs(along) + r * float(np.linalg.norm(n))
        return base + max(h * along, -h * along + r * across)

    def corners(self):
        """Points whose hull is the primitive (a box's 8 corners), or None."""
        if self.kind != "box":
            return None
        d = self.dims()
        signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float)
        return (signs * d) @ self.rotation.T + self.translation


@dataclass
class _Unit:
    """A primitive, or a union of solids of revolution on one axis (``members``, ``profile``)."""

    members: list
    axis: np.ndarray | None = None      # unit direction of a unit of revolution
    origin: np.ndarray | None = None    # a point on its axis
    pieces: list = field(default_factory=list)   # (lo, hi, (A, B, C)) Fractions: R² = A + Bz + Cz² on [lo, hi]
    slack: float = 0.0                  # Σ 2 δ_k area_k: members modelled on the axis by at most δ_k

    @property
    def revolution(self):
        return self.axis is not None

    def g(self, points):
        return np.min([m.g(points) for m in self.members], axis=0)

    def support(self, n):
        return max(m.support(n) for m in self.members)


def _frac(values):
    return [Fraction(float(x)) for x in values]


def _dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def _sqrt_up(value):
    return math.sqrt(float(value)) * (1 + 4 * _U) if value > 0 else 0.0


def _modelled(member, origin, axis):
    """``(z0, δ)``: the member's centre at ``origin + z0 axis`` (``z0`` a Fraction) and how far that is from it,
    counting its axis's turn from ``±axis`` and ``|axis| ≠ 1`` (None if off by more than rounding)."""
    a, p, c = _frac(axis), _frac(origin), _frac(member.translation)
    z0 = _dot([x - y for x, y in zip(c, p)], a)
    miss = _sqrt_up(sum((ci - pi - z0 * ai) ** 2 for ci, pi, ai in zip(c, p, a)))
    d = member.dims()
    extent = float(abs(z0)) + float(np.abs(d).max()) * 2
    unit = _dot(a, a) - 1                     # ||a| − 1| ≤ |a·a − 1|: the profile takes |a| as 1
    if unit:
        miss += abs(float(unit)) * (1 + 4 * _U) * extent * 2
    if member.kind != "sphere":
        own = member.axis
        turn = min(float(np.linalg.norm(own - axis)), float(np.linalg.norm(own + axis)))
        miss += 1.6 * turn * member.reach()
    # Off by more than rounding (a capsule written with rpy="1.57 0 0", whose spheres sit 6e-5 off the tilted
    # axis): still modelled on the axis, with the volume its surface sweeps in the bound — far tighter than a
    # grid gets, and said in the bound.  Farther off, it is a solid of its own.
    if miss > 2e-3 * member.reach():
        return None
    return z0, miss


def _profile(member, z0, axis):
    """The member's ``R(z)²`` pieces along ``axis`` (its centre at ``z0``)."""
    s = member.size
    r = Fraction(float(s["radius"]))
    if member.kind == "sphere":
        return [_sphere_piece(z0, r)]
    h = Fraction(float(s["length"])) / 2
    if member.kind == "cylinder":
        return [(z0 - h, z0 + h, (r * r, Fraction(0), Fraction(0)))]
    if member.kind == "capsule":
        return [_sphere_piece(z0 - h, r, hi=z0 - h), (z0 - h, z0 + h, (r * r, Fraction(0), Fraction(0))),
                _sphere_piece(z0 + h, r, lo=z0 + h)]
    # cone: apex at z0 + sign·h, base radius r at z0 − sign·h; R = r (apex − z) sign / (2h)
    sign = 1 if float(member.axis @ axis) > 0 else -1
    apex = z0 + sign * h
    k = r * r / (4 * h * h)
    return [(min(apex, z0 - sign * h), max(apex, z0 - sign * h), (k * apex * apex, -2 * k * apex, k))]


def _sphere_piece(centre, r, lo=None, hi=None):
    coefficients = (r * r - centre * centre, 2 * centre, Fraction(-1))
    return (centre - r if lo is None else lo, centre + r if hi is None else hi, coefficients)


def _units(prims):
    """Group primitives into units: coaxial solids of revolution share one (see the module docstring)."""
    units = []
    axial = [p for p in prims if p.kind in ("cylinder", "capsule", "cone")]
    spheres = [p for p in prims if p.kind == "sphere"]
    others = [p for p in prims if p.kind not in REVOLUTION]
    for prim in axial:
        for unit in units:
            if _join(unit, prim):
                break
        else:
            unit = _Unit([], axis=prim.axis.copy(), origin=prim.translation.copy())
            _join(unit, prim)
            units.append(unit)
    lone = []
    for sphere in spheres:
        if not any(_join(unit, sphere) for unit in units):
            lone.append(sphere)
    while lone:
        first = lone.pop(0)
        partner = next((s for s in lone if _meet(first, s)), None)
        if partner is None:
            units.append(_Unit([first]))
            continue
        d = partner.translation - first.translation
        unit = _Unit([], axis=d / np.linalg.norm(d), origin=first.translation.copy())
        _join(unit, first)
        _join(unit, partner)
        lone.remove(partner)
        for other in list(lone):
            if _join(unit, other):
                lone.remove(other)
        units.append(unit)
    units += [_Unit([p]) for p in others]
    return units


def _meet(a, b):
    return float(np.linalg.norm(a.translation - b.translation)) < a.reach() + b.reach()


def _join(unit, prim):
    """Add ``prim`` to a unit of revolution if it lies on its axis (within rounding); True if added."""
    if unit.axis is None:
        return False
    found = _modelled(prim, unit.origin, unit.axis)
    if found is None:
        return False
    z0, miss = found
    unit.members.append(prim)
    unit.pieces += _profile(prim, z0, unit.axis)
    unit.slack += 2 * miss * prim.props.surface_area * (1 + 1e-9)
    return True


# -- the profile integral -------------------------------------------------------------

def _value(c, z):
    return c[0] + c[1] * z + c[2] * z * z


def _crossings(p, q, lo, hi):
    """Breakpoints where ``R_p² − R_q²`` changes sign in ``(lo, hi)``: ``[(t, ε)]`` with the root in ``[t−ε, t+ε]``
    (``ε`` 0 for an exact rational root)."""
    a, b, c = (x - y for x, y in zip(p, q))
    out = []
    if c == 0:
        if b != 0:
            t = -a / b
            if lo < t < hi:
                out.append((t, Fraction(0)))
        return out
    disc = b * b - 4 * a * c
    if disc <= 0:
        return out                   # one sign throughout (a double root changes nothing)
    root = math.sqrt(float(disc))
    for t in ((-float(b) - root) / (2 * float(c)), (-float(b) + root) / (2 * float(c))):
        if not math.isfinite(t):
            continue
        t = Fraction(t)
        eps = Fraction(max(abs(float(t)), float(hi - lo), 1e-300)) * Fraction(1, 2 ** 50)
        for _ in range(40):
            left, right = _value((a, b, c), t - eps), _value((a, b, c), t + eps)
            if (left < 0) != (right < 0) or left == 0 or right == 0:
                break
            eps *= 4
        else:
            eps = None
        if eps is None:
            # Two roots within one bracket: no sign change seen; bound the whole stretch between them.
            t1, t2 = sorted(((-float(b) - root) / (2 * float(c)), (-float(b) + root) / (2 * float(c))))
            out.append((Fraction((t1 + t2) / 2), Fraction(abs(t2 - t1) / 2 + 1e-12 * float(hi - lo))))
            break
        if lo - eps < t < hi + eps:
            out.append((min(max(t, lo), hi), eps))
    return out


def _antiderivative_terms(c, n):
    """``∫ z^n (A + Bz + Cz²) dz`` as ``[(coefficient, power)]``."""
    return [(c[0] / (n + 1), n + 1), (c[1] / (n + 2), n + 2), (c[2] / (n + 3), n + 3)]


def _integral(c, n, lo, hi):
    return sum(k * (hi ** p - lo ** p) for k, p in _antiderivative_terms(c, n))


def _square_integral(c, lo, hi):
    """``∫ (A + Bz + Cz²)² dz``."""
    a, b, cc = c
    square = (a * a, 2 * a * b, b * b + 2 * a * cc, 2 * b * cc, cc * cc)
    return sum(k / (p + 1) * (hi ** (p + 1) - lo ** (p + 1)) for p, k in enumerate(square))


def profile_moments(pieces, clip=None):
    """Axial moments of the union of profile pieces (optionally clipped to ``[lo, hi]``):
    ``(∫R², ∫zR², ∫z²R², ∫R⁴)`` (Fractions, without π) and a bound on each from the inexact breakpoints."""
    if clip is not None:
        pieces = [(max(lo, clip[0]), min(hi, clip[1]), c) for lo, hi, c in pieces]
        pieces = [p for p in pieces if p[0] < p[1]]
    if not pieces:
        return (Fraction(0),) * 4, (0.0,) * 4
    points = {lo for lo, _, _ in pieces} | {hi for _, hi, _ in pieces}
    slack = [0.0] * 4
    for i in range(len(pieces)):
        for j in range(i + 1, len(pieces)):
            lo = max(pieces[i][0], pieces[j][0])
            hi = min(pieces[i][1], pieces[j][1])
            if lo >= hi:
                continue
            for t, eps in _crossings(pieces[i][2], pieces[j][2], lo, hi):
                points.add(t)
                if eps:
                    # Wrong by at most |R_i² − R_j²| on a stretch of 2ε: bound it by the coefficients.
                    reach = float(max(abs(lo), abs(hi)))
                    d = [abs(float(x - y)) for x, y in zip(pieces[i][2], pieces[j][2])]
                    gap = d[0] + d[1] * reach + d[2] * reach * reach
                    top = max(float(abs(_value(pieces[k][2], t))) for k in (i, j)) + gap
                    width = 2 * float(eps) * (1 + 1e-9)
                    slack[0] += width * gap
                    slack[1] += width * gap * reach
                    slack[2] += width * gap * reach * reach
                    slack[3] += width * gap * 2 * top
    points = sorted(points)
    totals = [Fraction(0)] * 4
    for lo, hi in zip(points, points[1:]):
        middle = (lo + hi) / 2
        active = [c for a, b, c in pieces if a <= middle <= b]
        if not active:
            continue
        best = max(active, key=lambda c: _value(c, middle))
        totals[0] += _integral(best, 0, lo, hi)
        totals[1] += _integral(best, 1, lo, hi)
        totals[2] += _integral(best, 2, lo, hi)
        totals[3] += _square_integral(best, lo, hi)
    return tuple(totals), tuple(slack)


def _frame(axis):
    """An orthonormal frame whose third column is ``axis`` (floats)."""
    helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
    e1 = np.cross(axis, helper)
    e1 /= np.linalg.norm(e1)
    return np.column_stack([e1, np.cross(axis, e1), axis])


def revolution_raw(unit, clip=None):
    """The volume moments of a unit of revolution (optionally clipped to the slab ``clip`` along its axis)."""
    totals, slack = profile_moments(unit.pieces, clip)
    pi = math.pi
    v, fz, szz, s4 = (float(x) * pi for x in totals)
    q = _frame(unit.axis)
    p = unit.origin
    axial_first = q[:, 2] * fz
    local_second = np.diag([s4 / 4, s4 / 4, szz])
    second = q @ local_second @ q.T + np.outer(p, axial_first) + np.outer(axial_first, p) + v * np.outer(p, p)
    first = v * p + axial_first
    members = unit.members
    far = max(float(np.linalg.norm(m.translation - p)) + m.reach() for m in members)
    e_v = (slack[0] * pi + 4 * _U * abs(v)) * (1 + 1e-9)
    e_fz = slack[1] * pi + 4 * _U * abs(fz)
    e_local = max(slack[2], slack[3] / 4) * pi + 4 * _U * max(abs(szz), abs(s4))
    # Bounds about p (the frame's rounding included); members modelled on the axis: what their surfaces moved
    # by δ sweep.
    e_first = 2 * e_fz + 16 * _U * abs(fz)
    e_second = 3 * e_local + 32 * _U * max(abs(szz), abs(s4))
    e_v += unit.slack
    e_first += unit.slack * far
    e_second += unit.slack * far * far
    return Raw(v, first, second, e_v, e_first * (1 + 1e-9), e_second * (1 + 1e-9), p.copy())


def unit_raw(unit):
    if unit.revolution:
        return revolution_raw(unit)
    return raw_of(unit.members[0].props)


# -- pairs -----------------------------------------------------------------------------

def _margin(*units):
    scale = max(float(np.abs(m.translation).max()) + m.reach() for u in units for m in u.members)
    return 64 * _U * scale


def _disjoint(a, b):
    """A separating plane between every member of ``a`` and every member of ``b``, with a margin."""
    eps = _margin(a, b)
    for m in a.members:
        for n in b.members:
            if not _separated(m, n, eps):
                return False
    return True


def _separated(m, n, eps):
    candidates = [n.translation - m.translation, m.axis, n.axis, *m.rotation.T, *n.rotation.T,
                  np.cross(m.axis, n.axis)]
    for d in candidates:
        length = float(np.linalg.norm(d))
        if not length > 0:
            continue
        d = d / length
        if m.support(d) + n.support(-d) < -eps:
            return True
    return False


def _inside(a, b):
    """Certified ``a ⊂ b`` for a unit ``a`` and a single convex primitive ``b``."""
    if len(b.members) != 1:
        return False
    outer = b.members[0]
    eps = _margin(a, b)
    d = outer.dims()
    if outer.kind == "box":
        for k in range(3):
            n = outer.rotation[:, k]
            centre = float(n @ outer.translation)
            if a.support(n) - centre > d[k] - eps or a.support(-n) + centre > d[k] - eps:
                return False
        return True
    if outer.kind == "sphere":
        return _farthest(a, outer.translation) <= d[0] - eps
    if outer.kind in ("cylinder", "capsule"):
        r, h = d
        axis = outer.axis
        centre = float(axis @ outer.translation)
        if outer.kind == "cylinder":
            if a.support(axis) - centre > h - eps or a.support(-axis) + centre > h - eps:
                return False
            radial = _farthest_from_line(a, outer.translation, axis)
            return radial is not None and radial <= r - eps
        far = _farthest_from_segment(a, outer.translation, axis, h)
        return far is not None and far <= r - eps
    return False


def _farthest(unit, point):
    """The largest distance from ``point`` to the unit (an upper bound)."""
    best = 0.0
    for m in unit.members:
        corners = m.corners()
        if corners is not None:
            best = max(best, float(np.linalg.norm(corners - point, axis=1).max()))
        elif m.kind == "sphere":
            best = max(best, float(np.linalg.norm(m.translation - point)) + m.dims()[0])
        elif m.kind in ("cylinder", "capsule", "cone"):
            r, h = m.dims()
            for z in (-h, h):
                centre = m.translation + z * m.axis
                offset = centre - point
                across = offset - (offset @ m.axis) * m.axis
                if m.kind == "capsule":
                    best = max(best, float(np.linalg.norm(offset)) + r)
                else:
                    radius = 0.0 if (m.kind == "cone" and z > 0) else r
                    best = max(best, math.sqrt(float(offset @ offset) + radius * radius
                                               + 2 * radius * float(np.linalg.norm(across))))
        else:
            best = max(best, float(np.linalg.norm(m.translation - point)) + m.reach())
    return best * (1 + 8 * _U)


def _farthest_from_line(unit, point, axis):
    best = 0.0
    for m in unit.members:
        corners = m.corners()
        if corners is not None:
            rel = corners - point
            best = max(best, float(np.linalg.norm(rel - np.outer(rel @ axis, axis), axis=1).max()))
            continue
        rel = m.translation - point
        across = float(np.linalg.norm(rel - (rel @ axis) * axis))
        if m.kind == "sphere":
            best = max(best, across + m.dims()[0])
        elif m.kind in ("cylinder", "capsule", "cone") and abs(abs(float(m.axis @ axis)) - 1) <= 4 * _U:
            r, h = m.dims()
            best = max(best, across + r + 4 * _U * h)
        else:
            return None
    return best * (1 + 8 * _U)


def _farthest_from_segment(unit, point, axis, h):
    def distance(x):
        rel = x - point
        z = min(max(float(rel @ axis), -h), h)
        return float(np.linalg.norm(rel - z * axis))
    best = 0.0
    for m in unit.members:
        corners = m.corners()
        if corners is not None:
            best = max(best, max(distance(c) for c in corners))
        elif m.kind == "sphere":
            best = max(best, distance(m.translation) + m.dims()[0])
        elif m.kind == "capsule":
            r, hh = m.dims()
            best = max(best, max(distance(m.translation + s * hh * m.axis) for s in (-1, 1)) + r)
        else:
            return None
    return best * (1 + 8 * _U)


def _slab(revolution, box):
    """The clip ``(lo, hi)`` along the axis when the unit of revolution meets the box only through two of its
    faces (the box's axis is the unit's, and the unit's radius stays inside the cross section), else None."""
    outer = box.members[0]
    axis = revolution.axis
    d = outer.dims()
    for k in range(3):
        column = outer.rotation[:, k]
        if not (np.array_equal(column, axis) or np.array_equal(column, -axis)):
            continue
        eps = _margin(revolution, box)
        radius = max(float(m.dims()[0]) for m in revolution.members)
        local = outer.rotation.T @ (revolution.origin - outer.translation)
        if any(abs(float(local[i])) + radius > d[i] - eps for i in range(3) if i != k):
            return None
        centre = _dot([x - y for x, y in zip(_frac(outer.translation), _frac(revolution.origin))], _frac(axis))
        half = Fraction(float(outer.size["size"][k])) / 2
        return centre - half, centre + half
    return None


def _pair_excess(a, b, tolerance, budget):
    """``(Raw, exact, note)``: the volume moments of ``a ∩ b`` (see the module docstring)."""
    if _disjoint(a, b):
        return zero_raw(), True, "apart"
    if _inside(a, b):
        return unit_raw(a), True, "inside"
    if _inside(b, a):
        return unit_raw(b), True, "inside"
    for rev, box in ((a, b), (b, a)):
        if rev.revolution and not box.revolution and box.members[0].kind == "box":
            clip = _slab(rev, box)
            if clip is not None:
                return revolution_raw(rev, clip), True, "through a box"
    prism = _prism_axis([a, b])
    if prism is not None:
        return _prism_excess([a, b], prism[1], prism[0], tolerance, budget)
    return _octree_excess([a, b], tolerance, budget)


# -- the octree --------------------------------------------------------------------------

def _overlap_box(units):
    """The box holding every pairwise meeting of the units' boxes."""
    boxes = []
    for u in units:
        lows, highs = [], []
        for m in u.members:
            reach = m.reach()
            lows.append(m.translation - reach)
            highs.append(m.translation + reach)
        boxes.append((np.min(lows, axis=0), np.max(highs, axis=0)))
    low, high = np.full(3, np.inf), np.full(3, -np.inf)
    for i in range(len(boxes)):
        for j in range(i + 1, len(boxes)):
            lo = np.maximum(boxes[i][0], boxes[j][0])
            hi = np.minimum(boxes[i][1], boxes[j][1])
            if np.all(hi > lo):
                low, high = np.minimum(low, lo), np.maximum(high, hi)
    return (low, high) if np.all(high > low) else None


def _cell_raw(centres, half, weight):
    """Σ weight · volume moments of the cubes of half side ``half`` at ``centres``."""
    volume = (2 * half) ** 3
    w = weight * volume
    first = w @ centres
    second = (centres * w[:, None]).T @ centres + np.eye(3) * float(w.sum()) * half * half / 3
    return float(w.sum()), first, second


def _excess_range(values, radius):
    """Per cell, from each unit's signed distance at its centre (``values``, units × cells) and the cell's
    circumradius: the least and most of ``n − 1`` over the cell (n the units holding a point, 0 when none),
    and whether the two agree."""
    inside = (values < -radius).sum(axis=0)
    unknown = (np.abs(values) <= radius).sum(axis=0)
    lo = np.maximum(0, inside - 1)
    hi = np.maximum(0, inside + unknown - 1)
    return lo, hi, lo == hi


def _octree_excess(units, tolerance, budget):
    """Volume moments of ``∫ max(0, n − 1)`` over space, bounded (see the module docstring)."""
    region = _overlap_box(units)
    if region is None:
        return zero_raw(), True, "apart"
    low, high = region
    side = float((high - low).max())
    centres = ((low + high) / 2)[None, :]
    half = side / 2
    scale = max(float(np.abs(low).max()), float(np.abs(high).max()), side)
    eps = 64 * _U * scale
    ref = (low + high) / 2                # the bounds are about it
    total = zero_raw(ref)
    absolute = [0.0, 0.0, 0.0]           # Σ |terms| for the rounding of the sums
    used = 0
    spent = False
    while True:
        radius = half * math.sqrt(3) + eps
        values = np.array([u.g(centres) for u in units])          # (units, cells)
        lo, hi, decided = _excess_range(values, radius)
        used += centres.shape[0]
        if np.any(decided & (lo > 0)):
            chosen = decided & (lo > 0)
            v, f, s = _cell_raw(centres[chosen], half, lo[chosen].astype(float))
            total = Raw(total.volume + v, total.first + f, total.second + s, ref=ref)
            absolute[0] += abs(v)
            absolute[1] += float(np.abs(centres[chosen]).max()) * abs(v)
            absolute[2] += float(np.abs(centres[chosen]).max() + half) ** 2 * abs(v)
        undecided = ~decided
        centres, lo, hi = centres[undecided], lo[undecided], hi[undecided]
        if centres.shape[0] == 0:
            break
        # The undecided cells: the midpoint of [lo, hi], off by at most half the range.
        v_open, f_open, s_open = _cell_raw(centres, half, (lo + hi) / 2.0)
        far = float(np.abs(centres).max()) + half
        spread = (hi - lo) / 2.0 * (2 * half) ** 3
        reach = np.abs(centres - ref).max(axis=1) + half
        open_error = (float(spread.sum()), float(spread @ reach), float(spread @ (reach * reach)))
        remaining = [open_error[0], open_error[1], open_error[2]]
        done = open_error[0] <= tolerance[0] and open_error[1] <= tolerance[1] and open_error[2] <= tolerance[2]
        if done or used + 8 * centres.shape[0] > budget:
            spent = not done
            total = Raw(total.volume + v_open, total.first + f_open, total.second + s_open,
                        remaining[0], remaining[1], remaining[2], ref)
            absolute[0] += abs(v_open)
            absolute[1] += far * abs(v_open)
            absolute[2] += far * far * abs(v_open)
            break
        half /= 2
        offsets = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float) * half
        centres = (centres[:, None, :] + offsets[None, :, :]).reshape(-1, 3)
    rounding = 4 * _U * math.log2(max(2, used)) + 8 * _U
    total = Raw(total.volume, total.first, total.second,
                total.e_volume + rounding * absolute[0], total.e_first + rounding * absolute[1],
                total.e_second + rounding * absolute[2], ref)
    return total, False, ("spent" if spent else "refined")


# -- prisms: cylinders and boxes along one direction -------------------------------------------

def _prism_axis(units):
    """``(d, [(member, column, turn)])`` when every member is a cylinder or a box with an axis along ``d``
    (within 1e-9 rad), else None."""
    members = [m for u in units for m in u.members]
    if not all(m.kind in ("cylinder", "box") for m in members):
        return None
    first = members[0]
    candidates = [first.axis] if first.kind == "cylinder" else list(first.rotation.T)
    for d in candidates:
        found = []
        for m in members:
            columns = [2] if m.kind == "cylinder" else [0, 1, 2]
            turns = [min(float(np.linalg.norm(m.rotation[:, k] - d)), float(np.linalg.norm(m.rotation[:, k] + d)))
                     for k in columns]
            best = int(np.argmin(turns))
            if turns[best] > 1e-9:
                break
            found.append((m, columns[best], turns[best]))
        else:
            return d / np.linalg.norm(d), found
    return None


@dataclass
class _Section:
    """A member's cross section in the prism frame: a disk or a rectangle, and its axial extent."""

    unit: int
    low: float
    high: float
    centre: np.ndarray            # (2,)
    radius: float = 0.0           # a disk
    axes: np.ndarray | None = None    # (2, 2) unit rows: a rectangle's axes
    half: np.ndarray | None = None    # (2,) its half extents

    def g(self, points):
        d = points - self.centre
        if self.axes is None:
            return np.linalg.norm(d, axis=1) - self.radius
        return (np.abs(d @ self.axes.T) - self.half).max(axis=1)

    def reach(self):
        return self.radius if self.axes is None else float(np.linalg.norm(self.half))


def _prism_excess(units, found, d, tolerance, budget):
    """The volume counted more than once by prisms along ``d``: exact axial slabs, a certified quadtree across."""
    q = _frame(d)
    origin = np.mean([m.translation for u in units for m in u.members], axis=0)
    unit_of = {id(m): k for k, u in enumerate(units) for m in u.members}
    sections, slack = [], 0.0
    far = 0.0
    for m, column, turn in found:
        y = q.T @ (m.translation - origin)
        dims = m.dims()
        if m.kind == "cylinder":
            r, h = dims
            section = _Section(unit_of[id(m)], float(y[2] - h), float(y[2] + h), y[:2].copy(), radius=float(r))
        else:
            others = [k for k in range(3) if k != column]
            axes = np.array([(q.T @ m.rotation[:, k])[:2] for k in others])
            axes /= np.linalg.norm(axes, axis=1)[:, None]
            h = float(dims[column])
            section = _Section(unit_of[id(m)], float(y[2] - h), float(y[2] + h), y[:2].copy(), axes=axes,
                               half=dims[others].copy())
        sections.append(section)
        # Modelled as an exact prism along d: moved by the turn and the rounding of its placement.
        move = 1.6 * turn * m.reach() + 16 * _U * (float(np.abs(m.translation).max())
                                                   + float(np.abs(origin).max()) + m.reach())
        slack += 2 * move * m.props.surface_area * (1 + 1e-9)
        far = max(far, float(np.linalg.norm(m.translation - origin)) + m.reach())
    ends = sorted({s.low for s in sections} | {s.high for s in sections})
    slabs = [(a, b) for a, b in zip(ends, ends[1:]) if b > a]
    area_tolerance = tuple(t / max(1, len(slabs)) for t in tolerance)
    totals = [0.0] * 10     # V, Fu, Fv, Fw, Suu, Suv, Svv, Suw, Svw, Sww
    errors = [0.0, 0.0, 0.0]
    spent = False
    for a, b in slabs:
        middle = (a + b) / 2
        active = [s for s in sections if s.low <= middle <= s.high]
        if len({s.unit for s in active}) < 2:
            continue
        length = b - a
        wanted = (area_tolerance[0] / length, area_tolerance[1] / length, area_tolerance[2] / length)
        moments, error, stopped = _quadtree_excess(active, wanted, budget // max(1, len(slabs)))
        spent = spent or stopped
        area, au, av, auu, auv, avv = moments
        w1, w2 = (b * b - a * a) / 2, (b ** 3 - a ** 3) / 3
        for k, value in enumerate((area * length, au * length, av * length, area * w1, auu * length, auv * length,
                                   avv * length, au * w1, av * w1, area * w2)):
            totals[k] += value
        reach_w = max(abs(a), abs(b))
        errors[0] += error[0] * length
        errors[1] += max(error[1] * length, error[0] * length * reach_w)
        errors[2] += max(error[2] * length, error[1] * length * reach_w, error[0] * length * reach_w * reach_w)
    v = totals[0]
    first_local = np.array(totals[1:4])
    second_local = np.array([[totals[4], totals[5], totals[7]], [totals[5], totals[6], totals[8]],
                             [totals[7], totals[8], totals[9]]])
    first_q = q @ first_local
    first = v * origin + first_q
    second = q @ second_local @ q.T + np.outer(origin, first_q) + np.outer(first_q, origin) + v * np.outer(origin,
                                                                                                           origin)
    # Bounds about the origin of the prism frame (its rounding included).
    e_v = errors[0] + slack
    e_first = 2 * errors[1] + slack * far + 16 * _U * float(np.abs(first_local).max())
    e_second = 3 * errors[2] + slack * far * far + 64 * _U * float(np.abs(second_local).max())
    raw = Raw(v, first, second, e_v * (1 + 1e-9), e_first * (1 + 1e-9), e_second * (1 + 1e-9), origin.copy())
    return raw, False, ("spent" if spent else "refined")


def _quadtree_excess(sections, tolerance, budget):
    """2D moments ``(A, ∫u, ∫v, ∫u², ∫uv, ∫v²)`` of ``max(0, n − 1)`` over the cross section, n counting units;
    and bounds ``(area, first, second)``, and whether the budget stopped it."""
    units = sorted({s.unit for s in sections})
    boxes = []
    for k in units:
        mine = [s for s in sections if s.unit == k]
        boxes.append((np.min([s.centre - s.reach() for s in mine], axis=0),
                      np.max([s.centre + s.reach() for s in mine], axis=0)))
    low, high = np.full(2, np.inf), np.full(2, -np.inf)
    for i in range(len(boxes)):
        for j in range(i + 1, len(boxes)):
            lo, hi = np.maximum(boxes[i][0], boxes[j][0]), np.minimum(boxes[i][1], boxes[j][1])
            if np.all(hi > lo):
                low, high = np.minimum(low, lo), np.maximum(high, hi)
    zero = (0.0,) * 6
    if not np.all(high > low):
        return zero, (0.0, 0.0, 0.0), False
    side = float((high - low).max())
    centres = ((low + high) / 2)[None, :]
    half = side / 2
    scale = max(float(np.abs(low).max()), float(np.abs(high).max()), side)
    eps = 64 * _U * scale
    sums = np.zeros(6)
    absolute = 0.0
    used, stopped, error = 0, False, (0.0, 0.0, 0.0)
    while True:
        radius = half * math.sqrt(2) + eps
        values = np.array([np.min([s.g(centres) for s in sections if s.unit == k], axis=0) for k in units])
        lo, hi, decided = _excess_range(values, radius)
        used += centres.shape[0]
        chosen = decided & (lo > 0)
        if np.any(chosen):
            sums += _square_moments(centres[chosen], half, lo[chosen].astype(float))
            absolute += float(lo[chosen].sum()) * (2 * half) ** 2
        centres, lo, hi = centres[~decided], lo[~decided], hi[~decided]
        if centres.shape[0] == 0:
            break
        spread = (hi - lo) / 2.0 * (2 * half) ** 2
        reach = np.abs(centres).max(axis=1) + half
        error = (float(spread.sum()), float(spread @ reach), float(spread @ (reach * reach)))
        done = all(e <= t for e, t in zip(error, tolerance))
        if done or used + 4 * centres.shape[0] > budget:
            stopped = not done
            sums += _square_moments(centres, half, (lo + hi) / 2.0)
            absolute += float(((lo + hi) / 2.0).sum()) * (2 * half) ** 2
            break
        half /= 2
        offsets = np.array([[sx, sy] for sx in (-1, 1) for sy in (-1, 1)], float) * half
        centres = (centres[:, None, :] + offsets[None, :, :]).reshape(-1, 2)
        error = (0.0, 0.0, 0.0)
    rounding = (4 * math.log2(max(2, used)) + 8) * _U * absolute
    error = (error[0] + rounding, error[1] + rounding * 2 * scale, error[2] + rounding * 4 * scale * scale)
    return tuple(float(x) for x in sums), error, stopped


def _square_moments(centres, half, weight):
    """Σ weight · ``(A, ∫u, ∫v, ∫u², ∫uv, ∫v²)`` of the squares of half side ``half`` at ``centres``."""
    w = weight * (2 * half) ** 2
    u, v = centres[:, 0], centres[:, 1]
    extra = half * half / 3
    return np.array([w.sum(), w @ u, w @ v, w @ (u * u + extra), w @ (u * v), w @ (v * v + extra)])


# -- clusters ------------------------------------------------------------------------------

@dataclass
class Union:
    """What :func:`cluster_union` found: the union's moments, and how."""

    raw: Raw
    exact: bool            # closed forms only (every bound from rounding)
    spent: bool            # the octree stopped at its budget above the tolerance
    notes: list


def prims_of(pieces):
    return [_Prim(p.name, p.kind, dict(p.size), p.props.pose.rotation, p.props.pose.translation, p.props)
            for p in pieces]


def cluster_union(prims, tolerance):
    """The union of primitives of one density (link frame volume moments), see the module docstring.

    ``tolerance`` is the absolute bound ``(V, ∫x, ∫xxᵀ)`` the octree aims for.
    """
    units = _units(prims)
    weights = np.array([p.props.volume for p in prims])
    total = zero_raw(weights @ np.array([p.translation for p in prims]) / weights.sum())
    for unit in units:
        total = total + unit_raw(unit)
    notes = [f"{' + '.join(m.name for m in u.members)}: one solid of revolution" for u in units if len(u.members) > 1]
    if len(units) == 1:
        return Union(total, True, False, notes)
    pairs = [(i, j) for i in range(len(units)) for j in range(i + 1, len(units))
             if not _disjoint(units[i], units[j])]
    neighbours = {k: set() for k in range(len(units))}
    for i, j in pairs:
        neighbours[i].add(j)
        neighbours[j].add(i)
    triangle = any(neighbours[i] & neighbours[j] for i, j in pairs)
    exact, spent = True, False
    prism = _prism_axis(units)
    if triangle and prism is not None:
        excess, exact, how = _prism_excess(units, prism[1], prism[0], tolerance, _CELL_BUDGET)
        return Union(total - excess, exact, how == "spent", notes + ["prisms along one axis: refined across"])
    if triangle:
        excess, exact, how = _octree_excess(units, tolerance, _CELL_BUDGET)
        spent = how == "spent"
        return Union(total - excess, exact, spent, notes + ["three or more overlap: refined on a grid"])
    share = max(1, len(pairs))
    for i, j in pairs:
        excess, closed, how = _pair_excess(units[i], units[j], tuple(t / share for t in tolerance),
                                           _CELL_BUDGET // share)
        exact = exact and closed
        spent = spent or how == "spent"
        total = total - excess
        notes.append(f"{_label(units[i])} and {_label(units[j])}: {how}")
    return Union(total, exact, spent, notes)


def _label(unit):
    return " + ".join(repr(m.name) for m in unit.members)

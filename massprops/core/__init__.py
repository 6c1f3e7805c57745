"""The kernel: grouping equal keys (welding), edge matching and shells, the
signed-tetrahedron integrals with their certified error bounds, and exact
triangle-intersection and point-in-solid decisions (:mod:`.intersect`, compiled)."""

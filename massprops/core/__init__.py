"""The kernel: grouping equal keys (welding), edge matching and shells, and the
signed-tetrahedron integrals with their certified error bounds."""

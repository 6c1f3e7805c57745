"""The tools that check massprops rather than run it: the exact rational oracle (:mod:`.exact`),
analytic solids (:mod:`.analytic`, :mod:`.solids`), the reference set (:mod:`.reference_set`),
regression against expected values (:mod:`.regress`), the accuracy report (:mod:`.accuracy`)
and the cross-check against trimesh (:mod:`.crosscheck`)."""

"""Batch CSV reports over many files, in local worker processes (:mod:`.workers`: a time limit per
file, a dead worker costs only its file) or on a Dask cluster (:mod:`.run`), with the report file
and resume state in :mod:`.output` (rendered by :mod:`massprops.report`)."""

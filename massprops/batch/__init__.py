"""Batch CSV reports over many files, in a local process pool or on a Dask cluster
(:mod:`.run`), with the report file and resume state in :mod:`.report`."""

"""``mfid batch``: the run, its plan (what is up to date), the task of one folder
and the engines it runs on (process pool, Dask)."""

"""Fitting: the least-squares engine (``solve``), the Magic Formula stages (``mf``), the
pressure relations (``relations``), MCMC (``mcmc``), and over them one fit's result, status,
bounds and identifiability and the record of a whole folder's fit (``run``, fit.json)."""

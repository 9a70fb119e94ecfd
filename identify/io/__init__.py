"""Every file format in and out, and nothing else: measurement folders (``tyre.toml``,
Flatplank channel files, trailer CSV/HDF5/TYDEX, characteristic tables), .tir files, operating
points, fit directories (fit.json with its schema, measured_vs_model.csv).

Readers convert to SI and ISO-W (identify.core.units, ``axes``) and raise
:class:`~identify.core.errors.InputError` with one line naming the file, line and channel.
"""

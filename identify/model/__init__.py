"""The forward model: Magic Formula 6.1/6.2 with inflation pressure in numpy (``evaluate`` and
the equations it calls), its .tir parameter table, and the compiled twin (``kernel``)."""

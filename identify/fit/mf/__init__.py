"""The Magic Formula fit in stages: stage specifications, their data and problems, the
global search, identifiability screen, constraints, exact Jacobians, intervals and
the pressure hold-out."""

"""Tire Test Consortium trailer files: the MATLAB .mat (v5/v7 with a structural guard,
v7.3) and .dat readers and the consortium's channel names."""

"""Trailer channel files of every format -> tidy tables in SI and ISO-W: the channel
table, the stand-ins for older TTC rounds, and the real-data quirks found and cleaned."""

"""The bottom layer: what every other layer shares and nothing in it depends on the rest.

``errors`` (the one-line user errors and their exit codes), ``units`` (the one unit table of
every reader and writer), ``quantities`` (the names and dimensions of the characteristics),
``jsonsafe`` (JSON for outputs), ``version``.
"""

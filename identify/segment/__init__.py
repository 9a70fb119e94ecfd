"""Segmentation of trailer data: condition levels, sweeps, and the filters that select samples.

Pure computation on the tidy trailer table (identify.io.trailer.files). :func:`segment_trailer`
returns a :class:`SegmentedTable`: the :class:`Segmentation` (levels, segments, filter counts:
small frozen records with a JSON round trip, for fit.json and the report) and the selected
samples with their segment and level values (for the fit).
"""
from identify.segment.result import FilterCount, Level, Segment, Segmentation
from identify.segment.segment import LEVEL_COLUMNS, SegmentedTable, segment_trailer
from identify.segment.settings import CONDITIONS, SegmentSettings

__all__ = [
           "CONDITIONS",
           "LEVEL_COLUMNS",
           "FilterCount",
           "Level",
           "Segment",
           "SegmentSettings",
           "Segmentation",
           "SegmentedTable",
           "segment_trailer",
]

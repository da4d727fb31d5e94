"""Automatic tie and control point measurement (``scangeo match``, docs/match.md).

``match_project`` measures the tie points of every overlap of a project's strips and, given
reference orthoimages, control and check points; it writes them into points.csv and ground.csv.
"""
from scangeo.match.options import MatchOptions
from scangeo.match.run import MatchResult, match_project

__all__ = ["match_project", "MatchOptions", "MatchResult"]

"""Reference contours: segments, paths, builders, G-code, feed profile and reference tables."""

from .builders import arc, circle, helix, inclined_circle, line, polyline, spline
from .feed import FeedProfile
from .geometry import PathGeometry
from .reference import ReferenceTrajectory
from .segments import Arc, Cubic, Line

__all__ = [
    "Arc",
    "Cubic",
    "FeedProfile",
    "Line",
    "PathGeometry",
    "ReferenceTrajectory",
    "arc",
    "circle",
    "helix",
    "inclined_circle",
    "line",
    "polyline",
    "spline",
]

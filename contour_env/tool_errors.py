"""Task-space errors of a five-axis run: the true tool-tip contour error (shortest distance
from the tip to the whole reference tip path, m) and the orientation error (angle between
the tool vector and the reference tool vector at the nearest path point; Chen, Khong &
Hsieh 2022, §3.1). Vectorised over points (n, 3); SI units, angles in rad and arc-seconds.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from .contour_error import nearest_points, true_contour_error
from .paths.builders import polyline

__all__ = [
    "ARCSEC_PER_RAD",
    "ToolErrors",
    "orientation_error_rad",
    "reference_polyline",
    "tool_errors",
    "tool_errors_from_samples",
]

ARCSEC_PER_RAD = 180.0 * 3600.0 / math.pi
# feet per block when interpolating a sampled reference (block × segments × 3 floats)
_CHUNK = 64


class ToolErrors(NamedTuple):
    """Per point (n,): contour_error_m (tip to the tip path), orientation_error_rad and
    orientation_error_arcsec (tool vector to the reference tool vector at the foot point);
    foot_m (n, 3): the nearest point of the tip path."""

    contour_error_m: np.ndarray
    orientation_error_rad: np.ndarray
    orientation_error_arcsec: np.ndarray
    foot_m: np.ndarray


def _vectors(name: str, value) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a numeric array (n, 3), got {value!r}") from None
    if arr.ndim not in (1, 2) or arr.shape[-1] != 3:
        raise ValueError(f"{name}: expected shape (n, 3) or (3,), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: must be finite (got NaN or inf)")
    return np.atleast_2d(arr)


def orientation_error_rad(tool, ref_tool) -> np.ndarray:
    """Angle (rad, in [0, π]) between tool vectors (n, 3) and reference vectors (n, 3) (any
    non-zero lengths): atan2(‖a × b‖, a · b), accurate for small angles too."""
    a = _vectors("tool", tool)
    b = _vectors("ref_tool", ref_tool)
    a, b = np.broadcast_arrays(a, b)
    if np.any(np.linalg.norm(a, axis=-1) == 0) or np.any(np.linalg.norm(b, axis=-1) == 0):
        raise ValueError("tool vectors must be non-zero")
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.einsum("ij,ij->i", a, b))


def tool_errors(tip, tool, tip_path, reference_tool: Callable[[np.ndarray], np.ndarray]):
    """ToolErrors of tips (n, 3) m and tool vectors (n, 3) against ``tip_path`` (a
    PathGeometry in the workpiece frame, or any object with seg_type / seg_data / seg_bounds)
    whose reference tool vector at a path point is ``reference_tool(points (n, 3)) -> (n, 3)``
    (e.g. ``FiveAxisPath.tool_at``: towards X_c)."""
    tip = _vectors("tip", tip)
    tool = _vectors("tool", tool)
    if tip.shape != tool.shape:
        raise ValueError(f"tip and tool: expected the same shape, got {tip.shape}, {tool.shape}")
    dist = np.asarray(true_contour_error(tip_path, tip), dtype=np.float64).reshape(-1)
    foot = nearest_points(tip_path, tip).reshape(-1, 3)
    ang = orientation_error_rad(tool, reference_tool(foot))
    return ToolErrors(dist, ang, ang * ARCSEC_PER_RAD, foot)


def reference_polyline(ref_tip):
    """PathGeometry through the reference tips (n, 3) m, dropping repeated samples (the
    reference at rest); with the indices (m,) of the kept samples."""
    pts = _vectors("ref_tip", ref_tip)
    step = np.linalg.norm(np.diff(pts, axis=0), axis=-1)
    keep = np.concatenate([[0], np.nonzero(step > 1e-15)[0] + 1])
    if keep.shape[0] < 2:
        raise ValueError("ref_tip: the reference tip does not move (need two distinct points)")
    return polyline(pts[keep]), keep


def tool_errors_from_samples(tip, tool, ref_tip, ref_tool) -> ToolErrors:
    """ToolErrors against a sampled reference: the tip path is the polyline through ref_tip
    (n_ref, 3) and the reference tool vector at the foot point is ref_tool (n_ref, 3)
    interpolated linearly along the nearest segment and normalised (for paths given only as
    samples, e.g. G-code; the polyline's chord error is part of the result)."""
    ref_tool = _vectors("ref_tool", ref_tool)
    path, keep = reference_polyline(ref_tip)
    if ref_tool.shape[0] != _vectors("ref_tip", ref_tip).shape[0]:
        raise ValueError("ref_tool: expected one tool vector per reference tip")
    pts = np.vstack([path.segments[0].start] + [seg.end for seg in path.segments])
    tools = ref_tool[keep]

    def interpolate(foot):
        # per chunk of feet: the nearest segment, then the fraction along it
        a, d = pts[:-1], np.diff(pts, axis=0)
        dd = np.einsum("kj,kj->k", d, d)
        out = np.empty_like(foot)
        for i in range(0, foot.shape[0], _CHUNK):
            rel = foot[i : i + _CHUNK, None, :] - a[None, :, :]
            frac = np.clip(np.einsum("nkj,kj->nk", rel, d) / dd, 0.0, 1.0)
            gap = np.linalg.norm(rel - frac[..., None] * d[None], axis=-1)
            k = np.argmin(gap, axis=1)
            f = frac[np.arange(k.shape[0]), k][:, None]
            out[i : i + _CHUNK] = (1.0 - f) * tools[k] + f * tools[k + 1]
        return out / np.linalg.norm(out, axis=-1, keepdims=True)

    return tool_errors(tip, tool, path, interpolate)

"""Width-time curve of an incision (paper Fig. 6): peak, plateau and settling time.

The width between paired points across the incision first rises quickly, then falls as the
residual stress pulls the lips together, then settles to a plateau. From a sampled curve:

* peak: the largest width and the first time it is reached;
* plateau: the mean width over the last ``plateau_fraction`` of the sampled duration;
* settling time: the first sample time at or after the peak from which every later sample
  stays within ``band`` x plateau of the plateau (None if the last sample is outside the band).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["WidthCurve", "analyse_width", "width_curve_metrics"]


@dataclass(frozen=True)
class WidthCurve:
    """Features of a width-time curve. Widths [m], times [s]; ``band`` relative [-]."""

    peak_width: float
    peak_time: float
    plateau_width: float
    plateau_start: float
    settling_time: float | None
    band: float

    def metrics(self) -> dict:
        """The features as metrics.json entries, with units in the names."""
        return {"peak_m": self.peak_width, "peak_time_s": self.peak_time,
                "plateau_m": self.plateau_width, "plateau_start_s": self.plateau_start,
                "settling_time_s": self.settling_time, "band": self.band}


def width_curve_metrics(t, width) -> dict | None:
    """``width_curve`` entry of metrics.json: ``analyse_width(t, width).metrics()``, or None
    when fewer than 3 samples have an incision."""
    try:
        return analyse_width(t, width).metrics()
    except ValueError:
        return None


def analyse_width(t, width, *, plateau_fraction: float = 0.2, band: float = 0.02) -> WidthCurve:
    """Peak, plateau and settling time of ``width`` (k,) [m] sampled at ``t`` (k,) [s].

    Samples whose width is not finite (no incision yet) are left out; at least 3 must remain,
    at strictly increasing times. ``plateau_fraction`` in (0, 1], ``band`` > 0.
    Raises ValueError on bad input.
    """
    t = np.asarray(t, dtype=np.float64).ravel()
    w = np.asarray(width, dtype=np.float64).ravel()
    if t.shape != w.shape:
        raise ValueError(f"t and width must have the same length, got {t.size} and {w.size}")
    if not np.all(np.isfinite(t)):
        raise ValueError("t must be finite")
    if not (0.0 < plateau_fraction <= 1.0):
        raise ValueError(f"plateau_fraction must be in (0, 1], got {plateau_fraction}")
    if not (np.isfinite(band) and band > 0.0):
        raise ValueError(f"band must be > 0, got {band}")
    keep = np.isfinite(w)
    t, w = t[keep], w[keep]
    if len(t) < 3:
        raise ValueError(f"need at least 3 finite width samples, got {len(t)}")
    if np.any(np.diff(t) <= 0):
        raise ValueError("t must be strictly increasing")
    k = int(np.argmax(w))
    plateau_start = t[-1] - plateau_fraction * (t[-1] - t[0])
    plateau = float(w[t >= plateau_start].mean())
    outside = np.abs(w - plateau) > band * abs(plateau)
    settling = None
    if not outside[-1]:
        after = np.flatnonzero(outside[k:])
        settling = float(t[k]) if len(after) == 0 else float(t[k + after[-1] + 1])
    return WidthCurve(peak_width=float(w[k]), peak_time=float(t[k]), plateau_width=plateau,
                      plateau_start=float(plateau_start), settling_time=settling, band=float(band))

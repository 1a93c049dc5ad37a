"""The sonar fix of paper 003 §4.1: the UUV's horizontal position from the ASV's multibeam.

The ASV's sonar measures the slant range R and the bearing of the UUV's echo; the one-way link
cannot tell the ASV the UUV's depth, so the ASV sends R, the absolute bearing (its heading plus
the bearing in the sonar head, ``psi_ASV + epsilon``) and its own position in {T}, and the UUV
puts in its own depth z measured at the time of the ping (the printed eq. "(3)" of §4.1):

    x_UUV = x_ASV + cos(psi_ASV + epsilon) sqrt(R^2 - z^2)
    y_UUV = y_ASV + sin(psi_ASV + epsilon) sqrt(R^2 - z^2)

z is the depth below the sonar head (the UUV's depth minus the head's). When R < z (noise
on a vehicle almost under the head) the horizontal range is taken as 0.

The covariance (§4.1: "constant or diagonal and increasing with the slant range"): diagonal,
``sigma^2 = sigma_R^2 + (sigma_eps R)^2 + sigma_ASV^2`` on each axis — the range error, the
bearing error across the beam at that range, and the ASV's own position error. Diagonal R is
what lets the navigator fuse x and y sequentially (§4.3, [9]).
"""

from __future__ import annotations

import math
from dataclasses import dataclass


def sonar_fix(slant_range: float, bearing: float, asv_xy: tuple[float, float],
              depth: float) -> tuple[float, float]:
    """The UUV's (x, y) in {T} from R, the absolute bearing (rad) and the ASV's (x, y)."""
    horizontal = math.sqrt(max(slant_range * slant_range - depth * depth, 0.0))
    return (asv_xy[0] + math.cos(bearing) * horizontal,
            asv_xy[1] + math.sin(bearing) * horizontal)


@dataclass(frozen=True)
class FixNoise:
    """One sigma of what makes a sonar fix: range (m), bearing (rad), the ASV's position (m)."""

    range_std: float = 0.3
    bearing_std: float = math.radians(1.5)
    asv_std: float = 0.3

    def variance(self, slant_range: float) -> float:
        """The variance of the fix on each horizontal axis at this slant range (m^2)."""
        return (self.range_std ** 2 + (self.bearing_std * slant_range) ** 2
                + self.asv_std ** 2)

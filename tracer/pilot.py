"""The light-vertex pilot: an adaptive render measures, on its first samples, whether camera
paths' connections to light vertices (light_vertices.py) pay for their rays.

Until the first error estimate every camera path also carries its light as it would without
light vertices (wavefront.emitters), into the pilot's own sums; at that estimate the pilot
compares the rays each estimator is predicted to need for the noise threshold, and the rest of
the render runs the cheaper one. Either way every sample is unbiased.
"""
from __future__ import annotations

import numpy as np

from . import adaptive, wavefront


class LightVertexPilot:
    """The samples without light vertices (sums, sums of squares) and the camera rays spent."""

    def __init__(self, pixels: int):
        self.sums = (np.zeros((pixels, 3)), np.zeros((pixels, 3)))
        self.rays = 0

    def choose(self, total, total_sq, n, light, halves, most, counters) -> tuple[bool, str]:
        """(whether the rest of an adaptive render uses light vertices, why), from its first n
        samples in every pixel: their sums and sums of squares with light vertices (total,
        total_sq) and without (self.sums), `light` the light tracer's image (or 0), `halves` the
        render's adaptive.Halves, `most` its cap and `counters` the samples' wavefront.STATS.

        Each estimator's cost is the samples adaptive sampling is predicted to give all pixels
        (adaptive.predicted_samples) times its rays per sample; without light vertices a path
        saves their rays (the ray from the lamp and the connections). Rays, not seconds, so that
        the choice, and the image, depend on the seed alone. A pixel's own samples sway the
        choice by one pixel's share of an image-wide sum."""
        rays = self.rays
        saved = counters[wavefront.VERTEX_RAYS] + counters[wavefront.CONNECTIONS]
        mean = total / n + light
        cost = [float(adaptive.predicted_samples(s, sq, n, mean, halves.threshold, halves.first,
                                                 most, halves.width, halves.height).sum()) * r
                for (s, sq), r in (((total, total_sq), rays), (self.sums, rays - saved))]
        ratio = cost[0] / cost[1] if cost[1] > 0.0 else 1.0
        if ratio <= 1.0:
            return True, (f"mesh lights or area lamps light diffuse surfaces; measured: "
                          f"{ratio:.2f}x the rays to the noise threshold with them")
        return False, f"measured: {ratio:.2f}x the rays to the noise threshold with them"

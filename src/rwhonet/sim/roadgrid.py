"""The route type: road geometry and the driver's wishes on a regular grid of travelled distance.

Its own module so that :mod:`rwhonet.sim.motion` (which plans a speed profile
along a route) and :mod:`rwhonet.sim.route` (which builds routes and uses the
planner to fit a route to a drive's duration) do not import each other.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np


@dataclass(frozen=True)
class Route:
    """A route on a regular grid of travelled distance (``n`` nodes).

    Interval arrays (``accel_m_s2``, ``decel_m_s2``, ``direction``, ``wet``) describe
    the stretch from node ``i`` to ``i + 1``; their last element is unused.

    Attributes:
        ds_m: grid step, m.
        curvature_1_m: path curvature of the rear-axle centre, 1/m, left positive.
        v_max_m_s: the speed the driver wants (road, traffic, caps), m/s; the
            curvature limit is applied by the planner.
        accel_m_s2: acceleration the driver uses, m/s^2.
        decel_m_s2: deceleration the driver uses (positive), m/s^2.
        stop: the car stops at the node.
        dwell_s: how long it stands there, s.
        direction: +1 forwards, -1 reversing.
        wet: wet road.
        tags: scenario intervals ``(s0_m, s1_m, tag)``.
        duration_s: recording length; None: until the car has stopped at the end.
    """

    ds_m: float
    curvature_1_m: np.ndarray
    v_max_m_s: np.ndarray
    accel_m_s2: np.ndarray
    decel_m_s2: np.ndarray
    stop: np.ndarray
    dwell_s: np.ndarray
    direction: np.ndarray
    wet: np.ndarray
    tags: tuple[tuple[float, float, str], ...] = ()
    duration_s: float | None = None

    @property
    def n(self) -> int:
        """Number of grid nodes."""
        return int(self.curvature_1_m.size)

    @property
    def s_m(self) -> np.ndarray:
        """Travelled distance at the nodes, m."""
        return np.arange(self.n) * self.ds_m

    def truncated(self, n_nodes: int, end_dwell_s: float = 0.0) -> Route:
        """Return the first ``n_nodes`` nodes, with the car stopping at the last one.

        Args:
            n_nodes: nodes to keep (>= 2).
            end_dwell_s: standstill after the final stop, s.

        Returns:
            The shortened route; scenario intervals are clipped to it.
        """
        s_end = (n_nodes - 1) * self.ds_m
        stop = self.stop[:n_nodes].copy()
        dwell = self.dwell_s[:n_nodes].copy()
        stop[-1] = True
        dwell[-1] = end_dwell_s
        tags = tuple((s0, min(s1, s_end), t) for s0, s1, t in self.tags if s0 <= s_end)
        return replace(
            self,
            curvature_1_m=self.curvature_1_m[:n_nodes].copy(),
            v_max_m_s=self.v_max_m_s[:n_nodes].copy(),
            accel_m_s2=self.accel_m_s2[:n_nodes].copy(),
            decel_m_s2=self.decel_m_s2[:n_nodes].copy(),
            stop=stop,
            dwell_s=dwell,
            direction=self.direction[:n_nodes].copy(),
            wet=self.wet[:n_nodes].copy(),
            tags=tags,
        )


# --------------------------------------------------------------------------- simple routes

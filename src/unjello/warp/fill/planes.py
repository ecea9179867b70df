"""One picture's planes, warped, given what they did not see from the neighbours'."""

from __future__ import annotations

import numpy as np

from ...timing import SensorTiming
from ..bands import PlaneMaps
from .leaving import edge_objects, objects_beyond, settled_objects
from .neighbours import fill_from_neighbours, neighbour_sources, unseen_share
from .uncovered import confirmed, uncovered, uncovered_sources

__all__ = ["NeighbourFill"]


class NeighbourFill:
    """One picture's planes, warped, given what they did not see from the neighbours'.

    Parameters
    ----------
    maps : tuple of ndarray
        The frame's backward maps on its field's grid (coarse).
    neighbours : list of (planes, flow)
        Each neighbour's picture (top-bottom planes, the first plane's size first) and
        this frame's flow to it, with its offset in ``offsets``.
    offsets : list of int
        -1: the previous frame, 1: the next.
    timing : SensorTiming
        For the reference scanline.
    field : ndarray, optional
        The forward displacement the maps invert, in their grid's pixels: given, the
        background a nearer object uncovered is looked for too (:func:`uncovered`).
    own : list of ndarray, optional
        This frame's planes (top-bottom): given with ``field``, nearer objects leaving
        the frame at a side are carried beyond it by their own motion
        (:func:`objects_beyond`).
    lone : bool
        Whether the frame shows an object moving on its own in front (a fitted drift or
        rotation): a lone neighbour is then read for all it uncovered (:func:`uncovered`).
    shown : ndarray of bool, optional
        Where those objects are shown, on the maps' grid
        (:func:`~unjello.warp.front_layers.shown_objects`): :func:`confirmed` does not take the
        output there for background.
    further : list, optional
        Per neighbour, the planes of the frame one further on its side (two frames away;
        None where there is none): background a leaving object covers in the neighbour
        is read there (:func:`objects_beyond`).
    """

    def __init__(self, maps: tuple[np.ndarray, np.ndarray],
                 neighbours: list[tuple[list, np.ndarray]], offsets: list[int],
                 timing: SensorTiming, field: np.ndarray | None = None,
                 own: list[np.ndarray] | None = None,
                 lone: bool = False, shown: np.ndarray | None = None,
                 further: list[list[np.ndarray] | None] | None = None) -> None:
        self.maps, self.offsets, self.timing = maps, offsets, timing
        self.further = further if further is not None else [None] * len(offsets)
        self.planes = [planes for planes, _ in neighbours]
        self.flows = [flow for _, flow in neighbours]
        grid = maps[0].shape
        # (a map gone to the object beside it is read in this frame where it has two
        # neighbours: with one, the astronaut 25 %/1.0 pair lost 0.12 dB)
        self.behind = (uncovered(maps, field, self.flows, offsets,
                                 timing.reference_row(grid[0]), lone,
                                 here=own is not None and len(offsets) > 1)
                       if field is not None else None)
        self._parts: dict[tuple[int, int], list] = {}
        self.own = own
        self.objects = (settled_objects(
            edge_objects(field, timing.readout, timing.reference_row(grid[0])), own[0],
            [p[0] for p in self.planes], [float(o) for o in offsets], grid)
            if field is not None and own is not None else [])
        self._shown = shown
        self._decided: np.ndarray | None = None  # the first plane's pixels taken by objects
        #: Of the first plane, the share whose source lies beyond the edge that no neighbour saw.
        self.unseen = 0.0

    def __call__(self, i: int, out: np.ndarray,
                 sized: tuple[np.ndarray, np.ndarray] | PlaneMaps,
                 slope: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
        """Fill plane ``i`` (warped, top-bottom, its maps ``sized``) in place; return it.

        ``sized``: the plane's maps whole, or as the coarse ones (a lens composed: whole);
        ``slope``: how the camera's displacement changes a row at the plane's top and
        bottom (:func:`~unjello.warp.fill.neighbours.edge_slopes`).
        """
        ph, pw = out.shape[:2]
        grid = self.maps[0].shape
        if i == 0 and self.behind is not None:
            self.behind = confirmed(self.behind, grid, out, self._sources(0), self._shown)
        if (ph, pw) not in self._parts:
            parts = neighbour_sources(sized, self.flows, self.offsets,
                                      self.timing.reference_row(ph), slope)
            if self.objects and (i == 0 or self._decided is not None):
                assert self.own is not None
                parts, self._decided = objects_beyond(
                    parts, self.objects, grid, self.timing.readout,
                    self.timing.reference_row(grid[0]), [float(o) for o in self.offsets],
                    self.offsets, self.own[0] if i == 0 else None,
                    [p[i] for p in self.planes], None if i == 0 else self._decided,
                    [None if f is None else f[i] for f in self.further])
            self._parts[(ph, pw)] = parts
            if self.behind is not None:
                self._parts[(ph, pw)] += uncovered_sources(self.behind, grid, (ph, pw))
        if i == 0:
            self.unseen = unseen_share(self._parts[(ph, pw)], (ph, pw))
        return fill_from_neighbours(out, self._parts[(ph, pw)], self._sources(i))

    def _sources(self, i: int) -> list[np.ndarray]:
        """Plane ``i`` of each neighbour, this frame's, then each frame two away's.

        This frame's is :func:`uncovered`'s ``here``; those two away are
        :func:`objects_beyond`'s (this frame's stands in where there is none).
        """
        if self.own is None:
            return [p[i] for p in self.planes]
        return ([p[i] for p in self.planes] + [self.own[i]]
                + [self.own[i] if f is None else f[i] for f in self.further])

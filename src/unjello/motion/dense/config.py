"""The dense method's settings (:class:`DenseConfig`), measured default by default.

The measurements behind each default are in ``docs/tuning.md``; the method itself is
:mod:`unjello.motion.dense.method`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from ...errors import SettingsError
from ..flow.dis import FlowSettings
from .vibration import VIBRATION

__all__ = ["DenseConfig", "POLISHED", "DETAILS"]

#: The flow's levels of detail (:attr:`DenseConfig.detail`).
DETAILS = ("full", "polished", "checked")

#: The polished flow (``detail='polished'``): DIS medium down to pyramid level 1 with three
#: refinement iterations a level, then one at full resolution. (``docs/tuning.md#polished``)
POLISHED = {"finest_scale": 1, "refinement": 3, "polish": 1}


@dataclass(frozen=True)
class DenseConfig:
    """Settings of the dense method (measurements behind each default: ``docs/tuning.md``).

    Parameters
    ----------
    flow_preset : {'ultrafast', 'fast', 'medium'}
        DIS optical flow preset.
    work_width : int
        Motion is estimated on frames downscaled to at most this width (0: full size);
        the per-pixel field is returned at that resolution, in full-frame pixels.
    grid : int
        Camera trajectory samples per readout time.
    smoothness : float
        Weight of the second-difference penalty on the camera trajectory.
    pair_smoothness : float
        The weight used instead, when larger, where a frame's window holds a single frame
        pair: the camera's acceleration and a velocity varying with the row then explain
        the same flows, and only the penalty decides.
    window : int
        Frame pairs after a frame used to solve its camera trajectory (the look-ahead).
    history : int
        Frame pairs before a frame used too.
    consistency : float
        Forward-backward flow disagreement (px) above which a pixel is unreliable.
    detail : {'full', 'polished', 'checked'}
        How finely the ``medium`` flow is measured. ``full``: DIS down to full resolution
        on copies up to 480 px wide (``finest_scale``, ``refinement``). ``polished``: DIS
        down to half the working copy's resolution (:data:`POLISHED`), then variational
        refinement at its full resolution: half the flow's cost, 0.1 dB less on the
        research pairs, and spinning objects missed (``docs/history/measurements.md``); the
        first spinning or kept object turns the full flow back on. ``checked`` (the
        default): the polished flow where it explains the frame pair, the full one where
        it does not (:func:`~unjello.motion.flow.dis.explains`: a spinner); a clip found to
        vibrate has its probed pairs measured again in full.
    finest_scale : int, optional
        With ``detail='full'``: DIS finest pyramid level (0 = full resolution). Default:
        the preset's, except that ``medium`` works at full resolution on copies up to
        480 px wide.
    refinement : int, optional
        With ``detail='full'``: variational refinement iterations of the ``medium``
        preset at each pyramid level (``None``: the preset's 5).
    fill_sigma : float
        Where the flow is unreliable, the residual motion is the Gaussian-weighted
        average (this sigma, px) of the reliable residuals around it.
    vibration : {'auto', 'on', 'off'}
        Vibration near the frame rate (drone jello): ``on`` uses :data:`VIBRATION`
        throughout; ``auto`` looks at the first ``probe`` frame pairs and switches to it
        where their evidence chooses it (:func:`~unjello.motion.dense.vibration.choose_model`).
    probe : int
        Frame pairs with contrast looked at before the first frame is emitted, to decide
        (waiting at most twice this many pairs).
    sinusoids : int
        Sinusoids of free frequency added to the camera trajectory, outside its
        smoothness penalty (:func:`~unjello.motion.dense.vibration.sinusoid_pursuit`).
    advect : bool
        Where a frame has one neighbour (the ends of a clip, a frame pair), carry each
        pixel's velocity through the smooth (projective) part of the flow field on its
        way to the reference time, instead of a constant velocity per pixel.
    edge_refine : bool
        Near motion boundaries, give each pixel the flow of the side it matches
        (:func:`~unjello.motion.flow.patches.refine_motion_edges`; per-pixel mode only).
    snap_window : int
        Pixels whose neighbourhood the frame's global (projective) motion explains as well
        as their own flow take the global motion
        (:func:`~unjello.motion.dense.field.snap_to_global`; this patch side in px, 0: off).
    per_pixel : bool
        Model each pixel's residual motion (parallax, moving objects) on top of the
        camera trajectory. False: the camera trajectory alone, one displacement per
        scanline (faster).
    """

    flow_preset: str = "medium"
    work_width: int = 480
    grid: int = 64
    smoothness: float = 3e-3
    pair_smoothness: float = 3e-2
    window: int = 2
    history: int = 2
    consistency: float = 3.0
    detail: str = "checked"
    finest_scale: int | None = None
    refinement: int | None = 1
    fill_sigma: float = 12.0
    vibration: str = "auto"
    probe: int = 8
    sinusoids: int = 0
    advect: bool = True
    edge_refine: bool = False
    snap_window: int = 9
    per_pixel: bool = True

    def __post_init__(self) -> None:
        if self.vibration not in ("auto", "on", "off"):
            raise SettingsError(f"vibration must be auto, on or off, not {self.vibration!r}")
        if self.work_width < 0:
            raise SettingsError(f"work width must be 0 (full size) or more, got "
                                f"{self.work_width}")
        if self.detail not in DETAILS:
            raise SettingsError(f"flow detail must be one of {', '.join(DETAILS)}, not "
                                f"{self.detail!r}")
        self.flow  # checks the preset  # noqa: B018

    @property
    def flow(self) -> FlowSettings:
        """The flow settings of :func:`~unjello.motion.flow.dis.flow_pair`."""
        full = FlowSettings(self.flow_preset, self.finest_scale, self.refinement,
                            self.consistency, self.edge_refine)
        if self.detail == "full" or self.flow_preset != "medium":
            return full
        return FlowSettings(self.flow_preset, consistency=self.consistency,
                            edge_refine=self.edge_refine, **POLISHED,
                            fallback=full if self.detail == "checked" else None)

    def vibrating(self) -> DenseConfig:
        """Return these settings with :data:`VIBRATION` applied (``vibration='on'``)."""
        return dataclasses.replace(self, **VIBRATION)

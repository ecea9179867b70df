"""The paper's stage V.D: a frame moved to where each scanline (or pixel) belongs.

The stages of :class:`~unjello.warp.warper.PictureWarper`, in the order its ``__call__``
calls them:

1. :mod:`~unjello.warp.maps`: backward maps from the frame's motion
   (:func:`~unjello.warp.maps.field_maps` for a per-pixel field,
   :func:`~unjello.warp.maps.remap_maps` per scanline), composed with a reframe
   (stabilisation) and a lens where given;
2. :mod:`~unjello.warp.bands`: a per-pixel field's maps made a band of rows at a time,
   at each plane's size;
3. :mod:`~unjello.warp.front_layers`: objects fitted a motion of their own, in front of
   the field;
4. the remap (or, with ``warp='splat'``, the paper's forward splat);
5. :mod:`unjello.warp.fill`: what the frame did not see, from the neighbours
   (up to :attr:`~unjello.warp.warper.PictureWarper.REACH` frames away).

It reads a :class:`~unjello.trajectory.FrameMotion` and imports nothing from
:mod:`unjello.motion`.
"""

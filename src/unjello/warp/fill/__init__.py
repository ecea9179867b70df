"""unjello.warp.fill."""

"""unjello.warp."""

"""unjello.cli."""

"""unjello.run."""

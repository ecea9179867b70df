"""unjello."""

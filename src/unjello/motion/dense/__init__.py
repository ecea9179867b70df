"""unjello.motion.dense."""

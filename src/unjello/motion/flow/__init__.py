"""unjello.motion.flow."""

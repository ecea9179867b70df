"""unjello.motion.paper."""

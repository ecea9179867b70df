"""unjello.motion.objects."""

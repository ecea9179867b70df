"""unjello.motion.gyro."""

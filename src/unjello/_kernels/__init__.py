"""unjello._kernels."""

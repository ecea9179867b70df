"""unjello.exports."""

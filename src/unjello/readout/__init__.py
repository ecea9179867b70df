"""unjello.readout."""

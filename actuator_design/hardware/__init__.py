"""Designs in hardware terms: coil currents and a magnet's pose (issue 19)."""

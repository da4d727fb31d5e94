"""Laser scanners: the laser equation with its systematic errors, calibration flights, 1D strip
adjustment and network design, height precision of area means, and consistency of real data."""

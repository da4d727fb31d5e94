"""Other tools' projects in, written as scangeo projects: PARGE status files of HySpex lines."""

"""The version of scangeo (also ``scangeo.__version__``), on the ground floor: the modules that stamp it
into their outputs import it from here, not from the package root, whose names load the workflow."""
__version__ = "0.1.0"

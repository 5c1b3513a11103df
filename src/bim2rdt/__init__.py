"""bim2rdt: turn a construction project's BIM (IFC) into a live, robot-ready site digital twin, safety first."""

__version__ = "0.1.0"

"""Simulated flight blocks with known truth (docs/simulate.md).

``simulate(out, load_preset("vienna2000"))`` writes a project folder (terrain, GPS/IMU as measured,
rendered scanner images, control/check/tie/height points) and a ``truth/`` folder (true trajectories,
injected GPS/IMU errors, true ground coordinates, true terrain and orthoimage).
"""
from scangeo.simulate.block import SimulatedBlock, simulate
from scangeo.simulate.config import SimulationConfig, available_presets, load_preset

__all__ = ["SimulatedBlock", "SimulationConfig", "available_presets", "load_preset", "simulate"]

"""The peers' own virtual environments for the peer benchmarks (``peer_gref4hsi.py``, ``peer_icp.py``).

A peer is never a dependency of scangeo: each one is installed by ``pip`` into a virtual environment
of its own, made on first use under ``~/.cache/scangeo-peers/NAME`` (or ``--venv DIR``), and run as a
child process of that environment's Python. Each child is measured from outside
(:func:`run_measured`: ``os.wait4`` gives the child's own CPU seconds and peak resident memory, its
waited-for children included), so the peer and scangeo are measured the same way.

:func:`ensure` returns the environment's Python, or raises :class:`PeerUnavailable` with a message
that says what is missing (the benchmark then prints it and exits 0: a skip, not a failure).
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

CACHE = Path.home() / ".cache" / "scangeo-peers"


class PeerUnavailable(RuntimeError):
    """The peer cannot be installed or imported here; the message says why and what would fix it."""


@dataclass(frozen=True)
class Peer:
    """How to install one peer: pip steps in order (each a list of arguments after ``pip install``),
    the import that proves it works, and environment variables it needs at run time."""

    name: str
    steps: tuple[tuple[str, ...], ...]
    check: str
    env: tuple[tuple[str, str], ...] = ()
    hint: str = ""


def gdal_version() -> str:
    """``gdal-config --version``: the GDAL whose Python bindings gref4hsi imports (``osgeo``)."""
    exe = shutil.which("gdal-config")
    if exe is None:
        raise PeerUnavailable("gdal-config not found: gref4hsi imports GDAL's Python bindings (osgeo), which pip "
                              "builds against the system's GDAL; install it with `apt-get install libgdal-dev`")
    return subprocess.run([exe, "--version"], capture_output=True, text=True, check=True).stdout.strip()


def gref4hsi_peer() -> Peer:
    """gref4hsi 0.2.6 and the three packages its modules import without declaring them: GDAL's Python
    bindings matching the system's GDAL, rasterio, and a Qt binding (PyQt5, run offscreen). numpy is
    installed first and held in the last step, so that GDAL's bindings are built against the numpy
    they run with (numpy 2.2.6 here)."""
    return Peer(
        "gref4hsi",
        (("numpy<2.3", "setuptools", "wheel"),
         ("--no-build-isolation", f"GDAL=={gdal_version()}"),
         ("gref4hsi==0.2.6", "rasterio", "PyQt5", "numpy<2.3")),
        "import gref4hsi.scripts.georeference, gref4hsi.scripts.orthorectification, "
        "gref4hsi.utils.parsing_utils, gref4hsi.utils.specim_parsing_utils",
        (("QT_QPA_PLATFORM", "offscreen"),),
        "gref4hsi needs libgdal-dev (apt-get install libgdal-dev) for its GDAL bindings",
    )


def icp_peer() -> Peer:
    """Open3D (point-to-plane ICP) and laspy with its LAZ backend, to read and write the strips."""
    return Peer("icp", (("open3d", "laspy[lazrs]"),), "import open3d, laspy, lazrs",
                hint="Open3D's wheel needs libusb-1.0 and libgomp from the system (apt-get install libusb-1.0-0)")


def _pip(python: Path, args: tuple[str, ...], log) -> None:
    cmd = [str(python), "-m", "pip", "install", "--quiet", *args]
    print(f"  pip install {' '.join(args)}", file=log, flush=True)
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode:
        tail = "\n".join(r.stderr.strip().splitlines()[-6:])
        raise PeerUnavailable(f"pip install {' '.join(args)} failed in {python.parent.parent}:\n{tail}")


def ensure(peer: Peer, venv: Path | None = None, log=sys.stderr) -> Path:
    """The Python of ``peer``'s virtual environment, made and installed on first use.

    Raises
    ------
    PeerUnavailable
        The environment cannot be made, a pip step fails, or the peer does not import (the message
        names the step and the hint of the peer).
    """
    venv = Path(venv) if venv else CACHE / peer.name
    python = venv / "bin" / "python"
    stamp = venv / "scangeo-peer.json"
    want = {"steps": [list(s) for s in peer.steps], "check": peer.check}
    if not (stamp.exists() and json.loads(stamp.read_text()) == want):
        print(f"installing {peer.name} into {venv} (once)", file=log, flush=True)
        if not python.exists():
            r = subprocess.run([sys.executable, "-m", "venv", str(venv)], capture_output=True, text=True)
            if r.returncode:
                raise PeerUnavailable(f"python -m venv {venv} failed: {r.stderr.strip()}")
        for step in peer.steps:
            _pip(python, step, log)
        stamp.write_text(json.dumps(want))
    r = subprocess.run([str(python), "-c", peer.check], capture_output=True, text=True, env=peer_environ(peer, python))
    if r.returncode:
        last = r.stderr.strip().splitlines()[-1] if r.stderr.strip() else "no message"
        raise PeerUnavailable(f"{peer.name} does not import in {venv}: {last}. {peer.hint}")
    return python


def peer_environ(peer: Peer, python: Path) -> dict[str, str]:
    """The child's environment: the venv's bin first on PATH (gref4hsi starts ``python`` by name for its
    triangulation), the peer's variables, and no PYTHONPATH of scangeo's."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PATH"] = f"{python.parent}{os.pathsep}{env.get('PATH', '')}"
    env["VIRTUAL_ENV"] = str(python.parent.parent)
    env.update(dict(peer.env))
    return env


@dataclass(frozen=True)
class Measured:
    """One child process: wall seconds, CPU seconds (user + system, its waited-for children included),
    peak resident memory (MiB, the largest of the process and of each waited-for child), exit code."""

    wall: float
    cpu: float
    user: float
    system: float
    peak_mb: float
    returncode: int


def run_measured(cmd: list[str], env: dict[str, str] | None = None, log_path: Path | None = None) -> Measured:
    """Run ``cmd`` as a child and measure it with ``os.wait4`` (its own rusage, not this process's).

    The child is started by a small launcher process (this file run as a script): Linux keeps the
    resident high-water mark of the process that forked across ``exec``, so a child forked directly
    from a benchmark holding a block in memory would report at least the benchmark's size."""
    with tempfile.TemporaryDirectory(prefix="scangeo-peer-") as tmp:
        record = Path(tmp) / "rusage.json"
        launcher = [sys.executable, str(Path(__file__).resolve()), "--measure", str(record),
                    str(log_path or os.devnull), "--", *cmd]
        subprocess.run(launcher, env=env, check=True)
        return Measured(**json.loads(record.read_text()))


def _measure(record: str, log: str, cmd: list[str]) -> None:
    """The launcher: run ``cmd`` with its output to ``log`` and write its rusage to ``record``."""
    with open(log, "w") as out:
        t0 = time.perf_counter()
        p = subprocess.Popen(cmd, stdout=out, stderr=subprocess.STDOUT)
        _, status, ru = os.wait4(p.pid, 0)
        wall = time.perf_counter() - t0
    Path(record).write_text(json.dumps({"wall": wall, "cpu": ru.ru_utime + ru.ru_stime, "user": ru.ru_utime,
                                        "system": ru.ru_stime, "peak_mb": ru.ru_maxrss / 1024.0,
                                        "returncode": os.waitstatus_to_exitcode(status)}))


def load_average() -> str:
    """``uptime``'s three load averages, for the figures' record."""
    a = os.getloadavg()
    return f"{a[0]:.1f} {a[1]:.1f} {a[2]:.1f}"


if __name__ == "__main__" and len(sys.argv) > 4 and sys.argv[1] == "--measure" and sys.argv[4] == "--":
    _measure(sys.argv[2], sys.argv[3], sys.argv[5:])

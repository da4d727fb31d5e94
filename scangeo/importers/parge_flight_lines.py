"""A platform's PARGE lines: their INS, the flight lines they share, and each sensor's mounting on it.

Used by :mod:`scangeo.importers.parge_platform` (its module docstring says the rules). PARGE's attitude
arrays are the INS's angles less the offsets it stores (``aux[0..3].OFFSET``; roll positive with the
left wing down): :func:`ins_stream` adds them back. Lines whose INS copies agree
(:func:`~scangeo.importers.navigation_agreement.compare_navigation`) share a flight line
(:func:`group_flight_lines`); its trajectory is the INS of its line with the most records a second,
extended by the others' records before and after it (:func:`flight_line_trajectory`); each sensor's
boresight is the constant rotation closest to its one-line attitude on that INS (:func:`sensor_mountings`).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicSpline

from scangeo.errors import ImportFileError
from scangeo.importers.navigation_agreement import (
    AgreementThresholds,
    NavigationAgreement,
    compare_navigation,
    mean_rotation,
    rotation_angles_deg,
)
from scangeo.importers.parge import ImportResult, _convergence, line_stream
from scangeo.importers.parge_status import ParGeStatus
from scangeo.importers.record import ImportRecord
from scangeo.rotation import matrix_to_rph, rph_to_matrix, small_rotation, unwrap_heading
from scangeo.trajectory.stream import GpsImuStream

#: the WGS84 semi-major axis (m): centimetre position differences as angles
_EARTH_M = 6378137.0


@dataclass(frozen=True)
class SensorMounting:
    """A sensor's mounting on its flight line's INS: ``boresight_deg`` (scangeo's convention), from
    ``strip``; ``departure_deg``: rms and largest angle between the constant mounting and the
    single-line attitude over the strip's lines; ``single_line_boresight_deg``: the single-line import's."""

    sensor: str
    camera: str
    strip: str
    boresight_deg: tuple[float, float, float]
    departure_deg: tuple[float, float]
    single_line_boresight_deg: tuple[float, float, float]



@dataclass
class PlatformLine:
    """One status file on its way into the platform: its status, its one-line import's result and
    ``import.json``, its sensor model and cube (or None), and what the platform import gives it."""

    st: ParGeStatus
    result: ImportResult
    record: dict
    sensor_model: str | Path | None
    cube: str | Path | None
    sensor: str = ""
    strip: str = ""
    flight_line: str = ""
    time_offset_s: float = 0.0



def ins_stream(line: PlatformLine) -> GpsImuStream:
    """The line's navigation with every stored offset of PARGE added back: the INS's own attitude."""
    st = line.st
    stored = tuple(float(np.degrees(st.offsets[k])) for k in ("roll", "pitch", "heading"))
    return line_stream(st, line.result.line_rate_hz, _convergence(st), stored)  # type: ignore[arg-type]


def camera_stream(line: PlatformLine) -> GpsImuStream:
    """The line's navigation as its single-line import writes it (the arrays)."""
    return line_stream(line.st, line.result.line_rate_hz, _convergence(line.st))


def held_offsets(line: PlatformLine) -> tuple[float, float, float]:
    """The offsets the single-line import found held by the arrays (PARGE's signs, deg)."""
    total = np.degrees([line.st.offsets[k] for k in ("roll", "pitch", "heading")])
    return tuple(float(v) for v in total - np.array(line.result.offsets.remainder_deg))  # type: ignore[return-value]


def group_flight_lines(lines: list[PlatformLine], thresholds: AgreementThresholds, record: ImportRecord):
    """Group the lines into flight lines: each joins the first flight line whose reference it agrees with."""
    order = sorted(lines, key=lambda line: -line.result.line_rate_hz)  # stable: the given order among equals
    groups: list[list[PlatformLine]] = []
    agreements: dict[str, NavigationAgreement] = {}
    for line in order:
        refused = []
        for group in groups:
            ref = group[0]
            a = compare_navigation(ins_stream(ref), ins_stream(line), thresholds)
            ok, why = a.agrees(thresholds)
            if ok:
                group.append(line)
                line.time_offset_s = a.time_offset_s
                agreements[line.st.path.name] = a
                record.extra.setdefault("arrays", {})[line.st.path.name] = asdict(
                    compare_navigation(camera_stream(ref), camera_stream(line), thresholds))
                break
            refused.append((ref, a, why))
        else:
            groups.append([line])
            for ref, a, why in refused:
                text = (f"{line.st.path.name} and {ref.st.path.name}: not one stretch of one GNSS/INS ("
                        f"{'; '.join(why)}): separate flight lines")
                if a.overlap > 0:
                    record.warn(text)
                else:
                    record.note(text)
                record.extra.setdefault("separate", []).append(
                    {"line": line.st.path.name, "reference": ref.st.path.name, "why": why, "figures": asdict(a)})
    groups.sort(key=lambda g: g[0].st.start_seconds)
    for k, group in enumerate(groups, 1):
        for line in group:
            line.flight_line = f"L{k}"
    strips_per_sensor: dict[str, int] = {}
    for line in lines:
        strips_per_sensor[line.sensor] = strips_per_sensor.get(line.sensor, 0) + 1
    for line in lines:
        line.strip = f"{line.sensor}-{line.flight_line}"
    ids = [line.strip for line in lines]
    for line in lines:
        if ids.count(line.strip) > 1:
            twins = [o.st.path.name for o in lines if o.strip == line.strip]
            raise ImportFileError(f"{' and '.join(twins)}: one camera ({line.st.camera}) twice on one stretch of "
                                "navigation (the same line imported twice?)")
    for group in groups:
        for line in group[1:]:
            a = agreements[line.st.path.name]
            record.decide(f"{line.strip}.flight_line", f"flight line {line.flight_line}, with {group[0].strip}",
                          "the two lines' navigation is one stretch of one GNSS/INS (navigation_agreement)",
                          {"agreement": asdict(a), "thresholds": asdict(thresholds)})
            record.decide(f"{line.strip}.time_offset",
                          f"line times moved by {1e3 * a.time_offset_s:+.3f} ms onto {group[0].strip}'s navigation",
                          "the shift of the line's times that makes its INS attitudes agree best with the flight "
                          "line's (PARGE's STARTTIME is a float32 of hours)",
                          {"time_offset_s": a.time_offset_s, "starttime_step_s": starttime_step(line.st)})
    return groups, agreements


def flight_line_trajectory(group: list[PlatformLine], agreements: dict[str, NavigationAgreement],
                           record: ImportRecord) -> GpsImuStream:
    """The flight line's trajectory: its reference line's INS, extended by the records of the other lines'
    INS (on the reference's time base, their constant differences taken off) before and after it."""
    ins = ins_stream(group[0])
    columns = ("time", "lat", "lon", "h", "roll", "pitch", "heading")
    parts = [{c: np.asarray(getattr(ins, c)) for c in columns}]
    parts[0]["heading"] = unwrap_heading(parts[0]["heading"])
    for line in group[1:]:
        a = agreements[line.st.path.name]
        other = ins_stream(line)
        t = np.asarray(other.time) + line.time_offset_s
        outside = (t < ins.time[0]) | (t > ins.time[-1])
        if not outside.any():
            continue
        c = np.radians(a.attitude_constant_shifted_deg)
        north, east, up = a.position_mean_neu_shifted_m
        heading = unwrap_heading(np.asarray(other.heading))
        heading += np.round((parts[0]["heading"][0] - heading[0]) / (2 * np.pi)) * 2 * np.pi
        parts.append({"time": t[outside], "lat": np.asarray(other.lat)[outside] - north / _EARTH_M,
                      "lon": np.asarray(other.lon)[outside] - east / (_EARTH_M * np.cos(np.mean(ins.lat))),
                      "h": np.asarray(other.h)[outside] - up, "roll": np.asarray(other.roll)[outside] - c[0],
                      "pitch": np.asarray(other.pitch)[outside] - c[1], "heading": heading[outside] - c[2]})
        record.note(f"flight line {line.flight_line}: {int(outside.sum())} record(s) of {line.strip}'s INS before or "
                    f"after {group[0].strip}'s ({t[outside].min():.4f}-{t[outside].max():.4f} s)")
    if len(parts) == 1:
        return ins
    merged = {c: np.concatenate([p[c] for p in parts]) for c in columns}
    order = np.argsort(merged["time"], kind="stable")
    return GpsImuStream(**{c: v[order] for c, v in merged.items()}, source=ins.source)


def starttime_step(st: ParGeStatus) -> float:
    """The step of a float32 at the line's STARTTIME (hours), in seconds."""
    return float(np.spacing(np.float32(st.start_hours)) * 3600.0)


def ordered(groups: list[list[PlatformLine]]) -> list[PlatformLine]:
    return [line for group in groups for line in group]


def _angles(s: GpsImuStream) -> np.ndarray:
    return np.column_stack([s.roll, s.pitch, unwrap_heading(np.asarray(s.heading))])


def sensor_mountings(groups: list[list[PlatformLine]], lines: list[PlatformLine]) -> dict[str, SensorMounting]:
    """Each sensor's constant mounting on its (first) flight line's INS (module docstring)."""
    out: dict[str, SensorMounting] = {}
    for group in groups:
        ins = ins_stream(group[0])
        spline = CubicSpline(ins.time, _angles(ins), axis=0)
        for line in group:
            if line.sensor in out:
                continue
            cam = camera_stream(line)
            t = np.asarray(cam.time) + line.time_offset_s
            inside = (t >= ins.time[0]) & (t <= ins.time[-1])
            x = spline(t[inside])
            R_x = rph_to_matrix(x[:, 0], x[:, 1], x[:, 2])
            c = _angles(cam)[inside]
            R_c = rph_to_matrix(c[:, 0], c[:, 1], c[:, 2])
            single = line.result.boresight_deg
            R_single = np.einsum("nij,jk->nik", R_c, small_rotation(np.radians(single)))
            relative = np.einsum("nji,njk->nik", R_x, R_single)
            M = mean_rotation(relative)
            angle = rotation_angles_deg(np.einsum("ji,njk->nik", M, relative))
            rph = np.degrees(matrix_to_rph(M))
            out[line.sensor] = SensorMounting(line.sensor, line.st.camera, line.strip,
                                              (float(rph[0]), float(rph[1]), float(rph[2])),
                                              (float(np.sqrt(np.mean(angle**2))), float(angle.max())),
                                              tuple(float(v) for v in single))  # type: ignore[arg-type]
    return out



def parge_offsets_relative_mounting(reference_offsets_deg, sensor_offsets_deg,
                                    attitudes: GpsImuStream | None = None) -> tuple[float, float, float]:
    """The relative mounting ``R_BS(reference)^T R_BS(sensor)`` (roll, pitch, heading, deg; scangeo's
    convention) that two cameras' PARGE offsets (roll, pitch, heading; PARGE's signs, deg:
    ``aux[0..3].OFFSET``, or a boresight result of the history) say.

    PARGE's attitude arrays are the INS's angles less the offsets (roll positive with the left wing
    down: scangeo's roll gains PARGE's roll offset, its pitch and heading lose theirs). In level
    flight that is the body rotation ``Rz(-h) Ry(-p) Rx(r)``; over the INS attitudes of
    ``attitudes`` (a flight line, scangeo's convention), the constant rotation closest to it."""
    def mounting(o):
        o = np.radians(np.asarray(o, float))
        if attitudes is None:
            return rph_to_matrix(o[0], -o[1], -o[2])
        x = _angles(attitudes)
        R_x = rph_to_matrix(x[:, 0], x[:, 1], x[:, 2])
        R_c = rph_to_matrix(x[:, 0] + o[0], x[:, 1] - o[1], x[:, 2] - o[2])
        return mean_rotation(np.einsum("nji,njk->nik", R_x, R_c))

    return triple_deg(mounting(reference_offsets_deg).T @ mounting(sensor_offsets_deg))



def triple_deg(R: np.ndarray) -> tuple[float, float, float]:
    rph = np.degrees(matrix_to_rph(R))
    return float(rph[0]), float(rph[1]), float(rph[2])


def stored_offsets(line: PlatformLine) -> tuple[float, float, float]:
    """PARGE's stored offsets of the line (roll, pitch, heading; PARGE's signs, deg)."""
    return tuple(float(np.degrees(line.st.offsets[k])) for k in ("roll", "pitch", "heading"))  # type: ignore[return-value]


def boresight_result(line: PlatformLine) -> tuple[float, float, float] | None:
    """The last boresight result of PARGE's history (deg), or None."""
    results = [e.degrees for e in line.st.events if e.kind == "crossbore"]
    return tuple(results[-1]) if results else None  # type: ignore[return-value]


__all__ = ["PlatformLine", "SensorMounting", "boresight_result", "camera_stream", "flight_line_trajectory",
           "group_flight_lines", "held_offsets", "ins_stream", "ordered", "parge_offsets_relative_mounting",
           "sensor_mountings", "starttime_step", "stored_offsets", "triple_deg"]

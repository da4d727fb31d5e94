"""Benchmark: one HySpex-like pushbroom cube georeferenced and orthorectified by scangeo and by gref4hsi.

Run: python tests/benchmarks/peer_gref4hsi.py [--seed 11] [--lines 4000] [--pixels 1800] [--bands 64]
     [--resolution 0.6] [--dem FILE | --dem simulated] [--work DIR] [--venv DIR] [--dem-as-is]

The flight (set-up, not timed; kept in ``--work`` and reused for the same seed and size): the
``pushbroom`` preset made a HySpex VNIR-1800 (``cube.py``'s camera: 1800 px over 33.8 deg, a
constant along-track look angle of 0.0376 deg, 25 lines/s, 700 m above ground at 40 m/s: 0.23 m
across, 1.6 m along track), one strip, over the SRTM tile of ``../shared/data/dtm`` (read-only; a
simulated fractal terrain with ``--dem simulated`` or where the tile is absent), with the preset's
turbulence and lever arm and no calibration error (the measured GPS/IMU and the project DTM, with
their simulated errors, are used by neither tool). The simulator's 11-band image becomes a float32
cube of ``--bands`` bands (the 10 reflective bands interpolated in wavelength, 0.435-2.215 um),
written as ENVI BSQ.

Both tools get the truth: the true trajectory (``truth/trajectory_01.csv``, 100 Hz), the true camera
(its look-angle table), lever arm and boresight, and the true terrain as the DEM.

* scangeo, in a child process: ``rectify_strip`` with the true orientation (``Truth``'s spline), the
  true terrain, the exact inverse map, nearest-neighbour resampling (gref4hsi's only one), the
  ``image_line``/``image_pixel`` layers (the inverse map per cell, for the evaluation).
* gref4hsi 0.2.6, in its own virtual environment (``peer_env.py``): its own formats written by the
  adapter below (not timed): an HDF5 file with the cube, its line times and the navigation (ECEF
  positions, roll/pitch/yaw to NED, as its ``specim_parsing_utils`` writes them), its camera XML
  (``Specim.fov_2_param``, its own fit of the per-pixel across-track angles; the constant along-track
  angle as the boresight's ``rx``; the HSI frame's x right, y back, z down to the body frame by
  ``rz = +90 deg``), the DEM as a GeoTIFF of ellipsoidal heights (``dem_ref = ellipsoid``), a
  constant geoid raster for its height above sea level, and ``configuration.ini``. Timed, in a child
  process: ``parsing_utils.export_pose`` (poses interpolated to the line times),
  ``parsing_utils.export_model`` (DEM -> triangle mesh), ``georeference.main`` (ray tracing onto the
  mesh, view and sun angles), ``orthorectification.main`` (nearest-neighbour resampling of the cube
  onto a north-east grid, ancillary layers ``pixel_nr_grid`` and ``frame_nr_grid``).

gref4hsi places a DEM post at its cell's upper-left corner (``dem_2_mesh``: ``x_origin + x *
x_resolution``), half a cell from where the value belongs; the adapter shifts the DEM's geotransform
by half a cell so the mesh's vertices lie on scangeo's posts (``--dem-as-is``: the GeoTIFF as a user
would give it).

Measured for each child (``os.wait4``): CPU seconds (user + system, its own children included), wall
seconds, peak resident memory. Against the truth (the simulator's ``StripGeometry`` of the true
orientation on the true terrain):

* geolocation: scangeo's inverse map at every output cell (its ``image_line``/``image_pixel``): the
  cell's ground point seen by the truth at (line, pixel) minus the tool's, in lines and pixels; and
  the truth's ground point of the tool's (line, pixel) minus the cell's, horizontally, metres.
  gref4hsi's ray-traced ground point of every image pixel (``points_ecef_crs``): minus the truth's
  ground point of that pixel, horizontally, metres; projected by the truth into the image, minus the
  pixel, in lines and pixels. rms and 99th percentile over all cells/pixels;
* radiometry: each orthoimage against the truth's rendering on the same grid with the same resampling
  (every cell's ground point on the true terrain projected by the truth into the image, the nearest
  pixel's value): rms per band over the cells both fill.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
SRTM = HERE.parents[1] / ".." / "shared" / "data" / "dtm" / "N44E005.hgt"

#: the cube's wavelengths come from the 10 reflective bands of the simulated scene (band centres, um)
REFLECTIVE_UM = (0.435, 0.485, 0.56, 0.615, 0.66, 0.7225, 0.83, 0.98, 1.65, 2.215)
NODATA = -9999.0


# ---------------------------------------------------------------------------------------------
# set-up (scangeo's environment)

def make_flight(root: Path, seed: int, lines: int, pixels: int, dem: Path | None) -> None:
    """The one-strip HySpex-like project with its truth and its 11-band ENVI image."""
    from scangeo.simulate.block import simulate
    from scangeo.simulate.config import load_preset

    over = {
        "sensor": {"pixels": pixels, "fov_deg": 33.8, "along_deg": 0.0376, "smile_deg": 0.0, "across_cubic_deg": 0.0,
                   "across_offset_error_deg": 0.0, "across_scale_error": 0.0, "along_offset_error_deg": 0.0,
                   "boresight_error_deg": [0.0, 0.0, 0.0], "noise_dn": 0.0},
        "flight": {"strips": 1, "lines": lines, "height_above_ground_m": 700.0, "ground_speed_mps": 40.0},
        "terrain": {"resolution_m": 2.5, "dtm_resolution_m": 2.5, "margin_m": 300.0},
        "points": {"check_per_strip": 5, "tie_per_overlap": 0, "height_per_strip": 0, "control_per_band_per_strip": 2},
        "output": {"images": True, "image_format": "ENVI", "truth_ortho": False},
    }
    simulate(root, load_preset("pushbroom", over), seed=seed, dtm_file=str(dem) if dem else None)


def cube_wavelengths(bands: int):
    import numpy as np

    return np.linspace(REFLECTIVE_UM[0], REFLECTIVE_UM[-1], bands)


def write_cube(image: Path, cube: Path, bands: int) -> None:
    """A float32 ENVI BSQ cube of ``bands`` bands from the simulated 11-band uint16 image (reflectance x
    10,000): each band the reflective bands interpolated linearly in wavelength, as reflectance."""
    import numpy as np
    import rasterio

    from scangeo.atomic import atomic_path, write_text

    wl = cube_wavelengths(bands)
    with rasterio.open(image) as src:
        src_bands = {}
        with atomic_path(cube) as tmp, open(tmp, "wb") as f:
            for w in wl:
                i = min(int(np.searchsorted(REFLECTIVE_UM, w, side="right")) - 1, len(REFLECTIVE_UM) - 2)
                a = (w - REFLECTIVE_UM[i]) / (REFLECTIVE_UM[i + 1] - REFLECTIVE_UM[i])
                for k in (i, i + 1):
                    if k not in src_bands:
                        src_bands[k] = src.read(k + 1).astype(np.float32) / np.float32(10000.0)
                for k in list(src_bands):
                    if k < i:
                        del src_bands[k]
                f.write(((1 - a) * src_bands[i] + a * src_bands[i + 1]).astype(np.float32).tobytes())
        lines, pixels = src.height, src.width
    waves = ", ".join(f"{1000 * w:.2f}" for w in wl)
    write_text(cube.with_suffix(".hdr"), "ENVI\n" f"samples = {pixels}\nlines = {lines}\nbands = {bands}\n"
               "header offset = 0\nfile type = ENVI Standard\ndata type = 4\ninterleave = bsq\nbyte order = 0\n"
               f"wavelength units = Nanometers\nwavelength = {{{waves}}}\n")


def write_peer_dem(terrain: Path, out: Path, undulation: float, shift_half_cell: bool) -> None:
    """The true terrain as gref4hsi's DEM: ellipsoidal heights (orthometric + the constant undulation),
    float32 GeoTIFF in the map CRS; the geotransform shifted by half a cell when ``shift_half_cell``
    (gref4hsi puts a post at its cell's upper-left corner)."""
    import rasterio
    from affine import Affine

    from scangeo.atomic import atomic_path

    with rasterio.open(terrain) as src:
        z = src.read(1).astype("float32") + float(undulation)
        t, crs = src.transform, src.crs
    if shift_half_cell:
        t = Affine(t.a, t.b, t.c + 0.5 * t.a, t.d, t.e, t.f + 0.5 * t.e)
    with atomic_path(out) as tmp, rasterio.open(tmp, "w", driver="GTiff", width=z.shape[1], height=z.shape[0], count=1,
                                                dtype="float32", crs=crs, transform=t) as dst:
        dst.write(z, 1)


def write_geoid(out: Path, lat_deg: float, lon_deg: float, undulation: float) -> None:
    """A constant geoid undulation raster (EPSG:4326) around the block: gref4hsi samples it for the
    sensor's height above sea level."""
    import numpy as np
    import rasterio
    from rasterio.transform import from_origin

    from scangeo.atomic import atomic_path

    with atomic_path(out) as tmp, rasterio.open(tmp, "w", driver="GTiff", width=40, height=40, count=1,
                                                dtype="float32", crs="EPSG:4326",
                                                transform=from_origin(lon_deg - 1.0, lat_deg + 1.0, 0.05, 0.05)) as d:
        d.write(np.full((40, 40), undulation, np.float32), 1)


def set_up(args) -> dict:
    """Simulate the flight and write both tools' inputs; a manifest of every path and figure."""
    import tomllib

    import numpy as np

    from scangeo.io.project import Project

    dem = None if args.dem == "simulated" else Path(args.dem)
    if dem is not None and not dem.exists():
        print(f"DEM {dem} not found: a simulated fractal terrain instead")
        dem = None
    tag = f"s{args.seed}_{args.lines}x{args.pixels}_{'srtm' if dem else 'fractal'}"
    work = Path(args.work) / tag
    if "." in str(work):
        sys.exit(f"--work {work}: gref4hsi cuts its file paths at the first '.' (model_path.split('.')): "
                 "give a folder whose path has no dot")
    root = work / "project"
    t = time.perf_counter()
    if not (root / "project.toml").exists():
        if root.exists():
            shutil.rmtree(root)
        make_flight(root, args.seed, args.lines, args.pixels, dem)
    cube = work / "cube" / f"cube{args.bands}.bsq"
    cube.parent.mkdir(parents=True, exist_ok=True)
    if not cube.exists():
        write_cube(root / "images" / "01.bsq", cube, args.bands)
    project = Project.load(root)
    strip = project.strips[0]
    toml = tomllib.loads((root / "project.toml").read_text())
    sensor = toml["sensor"]
    table = np.loadtxt(root / sensor["look_angles"], delimiter=",", skiprows=1) if "look_angles" in sensor else None
    if table is None:
        raise SystemExit(f"{root / 'project.toml'}: expected a pushbroom look-angle table")
    undulation = float(toml["project"].get("geoid_undulation_m", 0.0))
    mission = work / "gref4hsi"
    (mission / "Input").mkdir(parents=True, exist_ok=True)
    peer_dem = mission / "Input" / ("dem_as_is.tif" if args.dem_as_is else "dem.tif")
    write_peer_dem(root / "truth" / "terrain.tif", peer_dem, undulation, not args.dem_as_is)
    lat0, lon0 = np.degrees(project.map_frame.frame.lat0), np.degrees(project.map_frame.frame.lon0)
    write_geoid(mission / "Input" / "geoid.tif", lat0, lon0, undulation)
    line_times = project.timing(strip.id).time_of_line(np.arange(args.lines, dtype=float))
    np.save(work / "line_times.npy", line_times)
    manifest = {
        "root": str(root), "cube": str(cube), "lines": args.lines, "pixels": args.pixels, "bands": args.bands,
        "wavelengths_nm": (1000 * cube_wavelengths(args.bands)).tolist(), "resolution": args.resolution,
        "trajectory": str(root / "truth" / "trajectory_01.csv"), "line_times": str(work / "line_times.npy"),
        "along_deg": table[:, 1].tolist(), "across_deg": table[:, 2].tolist(),
        "lever_arm_m": list(sensor.get("lever_arm_m", [0.0, 0.0, 0.0])),
        "boresight_deg": list(sensor.get("boresight_deg", [0.0, 0.0, 0.0])),
        "dem": str(peer_dem), "geoid": str(mission / "Input" / "geoid.tif"), "mission": str(mission),
        "epsg": int(project.map_frame.crs.to_epsg()), "dem_shifted_half_cell": not args.dem_as_is,
        "max_ray_length_m": 3000.0, "scangeo_out": str(work / "scangeo" / "01.tif"),
    }
    (work / "manifest.json").write_text(json.dumps(manifest, indent=1))
    print(f"set-up in {time.perf_counter() - t:.0f} s: {work}")
    return manifest


# ---------------------------------------------------------------------------------------------
# gref4hsi's side (run with the peer's Python; imports only what gref4hsi's environment has)

def gref4hsi_prepare(manifest_path: str) -> None:
    """The adapter: gref4hsi's HDF5, camera XML and configuration.ini from the manifest."""
    import configparser

    import h5py
    import numpy as np
    from gref4hsi.utils.geometry_utils import CalibHSI
    from gref4hsi.utils.specim_parsing_utils import Specim
    from pyproj import Transformer

    m = json.loads(Path(manifest_path).read_text())
    mission = Path(m["mission"])
    for sub in ("Input/H5", "Input/Calib", "Input/GIS", "Output/3Dmodels", "Output/GIS/FootPrints",
                "Output/GIS/RGBComposites", "Output/GIS/HSIDatacubes", "Output/GIS/AncillaryData", "Intermediate"):
        (mission / sub).mkdir(parents=True, exist_ok=True)
    # navigation: the true trajectory (time, lat, lon, h ellipsoidal, roll, pitch, heading in deg)
    nav = np.genfromtxt(m["trajectory"], delimiter=",", names=True)
    to_ecef = Transformer.from_crs("EPSG:4979", "EPSG:4978", always_xy=True)
    x, y, z = to_ecef.transform(nav["lon"], nav["lat"], nav["h"])
    line_times = np.load(m["line_times"])
    h5 = mission / "Input" / "H5" / "flight_01.h5"
    lines, pixels, bands = m["lines"], m["pixels"], m["bands"]
    cube = np.memmap(m["cube"], np.float32, "r", shape=(bands, lines, pixels))
    with h5py.File(h5, "w", libver="latest") as f:
        f.create_dataset("raw/nav/euler_angles", data=np.column_stack([nav["roll"], nav["pitch"], nav["heading"]]))
        f.create_dataset("raw/nav/position_ecef", data=np.column_stack([x, y, z]))
        f.create_dataset("raw/nav/timestamp", data=nav["time"])
        f.create_dataset("processed/radiance/timestamp", data=line_times)
        f.create_dataset("processed/radiance/exposureTime", data=np.array([10.0]))
        f.create_dataset("processed/radiance/calibration/spectral/band2Wavelength", data=np.array(m["wavelengths_nm"]))
        f.create_dataset("processed/radiance/calibration/spectral/fwhm",
                         data=np.full(bands, float(np.diff(m["wavelengths_nm"]).mean())))
        d = f.create_dataset("processed/radiance/dataCube", shape=(lines, pixels, bands), dtype=np.float32)
        for l0 in range(0, lines, 256):
            d[l0:l0 + 256] = np.ascontiguousarray(np.transpose(cube[:, l0:l0 + 256, :], (1, 2, 0)))
    # camera: gref4hsi's ray in its HSI frame (x right, y back, z down) is (x_norm(u), 0, 1); rotated by
    # Rz(rz) Ry(ry) Rx(rx) into the body frame. rz = +90 deg takes HSI x to body y (right) and HSI y to
    # -body x; rx = the along-track look angle tilts every ray forward by it and scales x_norm by
    # cos(rx), so the fit is of tan(across) * cos(rx)
    along = np.radians(np.asarray(m["along_deg"]))
    if np.ptp(along) > 1e-12:
        raise SystemExit("the adapter maps a constant along-track look angle only (gref4hsi's camera has no smile)")
    rx = float(along.mean())
    x_true = np.tan(np.radians(np.asarray(m["across_deg"]))) * np.cos(rx)
    params = Specim.fov_2_param(fov=np.degrees(np.arctan(x_true)))
    bore = np.radians(np.asarray(m["boresight_deg"]))
    if np.any(bore != 0.0):
        raise SystemExit("the adapter maps a zero boresight only")
    lever = m["lever_arm_m"]
    params.update(rx=rx, ry=0.0, rz=float(np.pi / 2), tx=lever[0], ty=lever[1], tz=lever[2])
    calib = mission / "Input" / "Calib" / "camera.xml"
    CalibHSI(file_name_cal_xml=str(calib), mode="w", param_dict={k: str(v) for k, v in params.items()})
    u = np.arange(pixels) + 0.5
    dc = u - params["cx"]
    x_norm = (dc - params["k1"] * dc**5 - params["k2"] * dc**3 - params["k3"] * dc**2) / params["f"]
    ifov = np.radians(np.median(np.abs(np.diff(m["across_deg"]))))
    fit_px = (np.arctan(x_norm / np.cos(rx)) - np.arctan(x_true / np.cos(rx))) / ifov
    print(f"camera fit (gref4hsi's Specim.fov_2_param): f {params['f']:.3f} px, cx {params['cx']:.4f}, "
          f"k1 {params['k1']:.3e}, k2 {params['k2']:.3e}, k3 {params['k3']:.3e}; across-track angle residual "
          f"rms {np.sqrt(np.mean(fit_px**2)):.2e} px, max {np.abs(fit_px).max():.2e} px")
    config = configparser.ConfigParser()
    s = lambda p: str(p) + "/"  # noqa: E731  (gref4hsi joins folder and file names by +)
    config["General"] = {"mission_dir": s(mission), "pose_export_type": "h5_embedded", "model_export_type": "dem_file",
                         "sensor_type": "HySpex-like (simulated)", "max_ray_length": str(m["max_ray_length_m"]),
                         "blue_wave_length": "480", "green_wave_length": "560", "red_wave_length": "660",
                         "wavelength_unit": "Nanometers", "radiometric_unit": "reflectance"}
    config["Coordinate Reference Systems"] = {"proj_epsg": str(m["epsg"]), "geocsc_epsg_export": "4978",
                                              "pos_epsg_orig": "4978", "dem_epsg": str(m["epsg"]),
                                              "dem_ref": "ellipsoid"}
    out = mission / "Output"
    config["Absolute Paths"] = {
        "calib_folder": s(mission / "Input" / "Calib"), "h5_folder": s(mission / "Input" / "H5"),
        "dem_folder": s(mission / "Input" / "GIS"), "rgb_point_cloud_folder": s(out / "3Dmodels"),
        "footprint_folder": s(out / "GIS" / "FootPrints"), "rgb_composite_folder": s(out / "GIS" / "RGBComposites"),
        "orthorectified_cube_folder": s(out / "GIS" / "HSIDatacubes"), "anc_folder": s(out / "GIS" / "AncillaryData"),
        "dem_path": m["dem"], "hsi_calib_path": str(calib), "model_path": str(mission / "Input" / "GIS" / "model.vtk"),
        "pose_path": str(mission / "Intermediate" / "pose.csv"), "geoid_path": m["geoid"],
    }
    config["HDF.raw_nav"] = {"rotation_reference_type": "eul_ZYX", "eul_zyx": "raw/nav/euler_angles",
                             "eul_is_degrees": "True", "position": "raw/nav/position_ecef",
                             "timestamp": "raw/nav/timestamp", "is_global_rot": "False"}
    config["HDF.hyperspectral"] = {"datacube": "processed/radiance/dataCube",
                                   "exposuretime": "processed/radiance/exposureTime",
                                   "timestamp": "processed/radiance/timestamp", "is_calibrated": "True"}
    config["HDF.processed_nav"] = {"folder": "processed/nav/", "quaternion_ecef": "processed/nav/quaternion_ref_ecef",
                                   "position_ecef": "processed/nav/position_ref_ecef",
                                   "timestamp": "processed/nav/timestamp_hsi"}
    config["HDF.calibration"] = {"band2wavelength": "processed/radiance/calibration/spectral/band2Wavelength",
                                 "fwhm": "processed/radiance/calibration/spectral/fwhm"}
    geo = "processed/georef/"
    config["Georeferencing"] = {  # the template's layers, as a user gets them
        "folder": geo, "position_ecef": "processed/nav/position_hsi_ecef",
        "quaternion_ecef": "processed/nav/quaternion_hsi_ecef", "points_ecef_crs": geo + "points_ecef_crs",
        "points_hsi_crs": geo + "point_hsi_frame", "normals_hsi_crs": geo + "normals_hsi_frame",
        "theta_v": geo + "theta_v", "theta_s": geo + "theta_s", "phi_v": geo + "phi_v", "phi_s": geo + "phi_s",
        "normals_ned_crs": geo + "normals_ned_crs", "unix_time_grid": geo + "unix_time_grid",
        "pixel_nr_grid": geo + "pixel_nr_grid", "frame_nr_grid": geo + "frame_nr_grid",
        "hsi_tide_gridded": geo + "hsi_tide_gridded", "hsi_alts_msl": geo + "hsi_alts_msl"}
    config["Orthorectification"] = {"resample_rgb_only": "False", "resample_ancillary": "True",
                                    "chunk_size_cube_gb": "1", "resolutionhyperspectralmosaic": str(m["resolution"]),
                                    "interleave": "bsq", "ancillary_suffix": "_anc", "nodata": str(int(NODATA)),
                                    "raster_transform_method": "north_east"}
    # the ancillary layers scangeo's rectify writes too: the image position each cell was taken from
    config["Ancillary"] = {"pixel_nr_grid": geo + "pixel_nr_grid", "frame_nr_grid": geo + "frame_nr_grid"}
    with open(mission / "configuration.ini", "w") as f:
        config.write(f)
    print(f"gref4hsi inputs in {mission}")


def gref4hsi_run(config_file: str, times_path: str) -> None:
    """gref4hsi's processing of the mission (the timed child): pose, model, georeference, orthorectify."""
    t0, c0 = time.perf_counter(), time.process_time()
    from gref4hsi.scripts import georeference, orthorectification
    from gref4hsi.utils import parsing_utils

    steps = {"import": (time.perf_counter() - t0, time.process_time() - c0)}
    for name, call in (("export_pose", parsing_utils.export_pose), ("export_model", parsing_utils.export_model),
                       ("georeference", georeference.main), ("orthorectification", orthorectification.main)):
        t, c = time.perf_counter(), time.process_time()
        call(config_file)
        steps[name] = (time.perf_counter() - t, time.process_time() - c)
    Path(times_path).write_text(json.dumps(steps))


def gref4hsi_export(h5_path: str, out: str) -> None:
    """gref4hsi's ray-traced ground points (lines, pixels, 3), ECEF, as a .npy for the evaluation."""
    import h5py
    import numpy as np

    with h5py.File(h5_path, "r") as f:
        np.save(out, f["processed/georef/points_ecef_crs"][()])


# ---------------------------------------------------------------------------------------------
# scangeo's side (the timed child)

def scangeo_run(manifest_path: str, times_path: str) -> None:
    """scangeo's rectification of the cube with the true orientation on the true terrain."""
    t0, c0 = time.perf_counter(), time.process_time()
    from scangeo.io.project import Project
    from scangeo.rectify.core_geometry import CoreStripGeometry
    from scangeo.rectify.options import RectifyOptions
    from scangeo.rectify.strip import rectify_strip
    from scangeo.truth.true_error import Truth

    m = json.loads(Path(manifest_path).read_text())
    steps = {"import": (time.perf_counter() - t0, time.process_time() - c0)}
    t, c = time.perf_counter(), time.process_time()
    truth = Truth.load(Project.load(m["root"]))
    assert truth is not None
    geometry = CoreStripGeometry(truth.geometries["01"], truth.terrain)
    steps["truth"] = (time.perf_counter() - t, time.process_time() - c)
    options = RectifyOptions(resolution=m["resolution"], resampling="nearest", layers=("image_line", "image_pixel"))
    t, c = time.perf_counter(), time.process_time()
    rectify_strip(geometry, m["cube"], m["scangeo_out"], options)
    steps["rectify"] = (time.perf_counter() - t, time.process_time() - c)
    Path(times_path).write_text(json.dumps(steps))


# ---------------------------------------------------------------------------------------------
# evaluation against the truth (scangeo's environment, not timed)

def _stats(v) -> tuple[float, float]:
    import numpy as np

    v = np.abs(np.asarray(v, float))
    v = v[np.isfinite(v)]
    return float(np.sqrt(np.mean(v**2))), float(np.percentile(v, 99))


def evaluate(m: dict, points_ecef_path: Path | None, gref_cube: Path | None, gref_composite: Path | None) -> dict:
    import numpy as np
    import rasterio

    from scangeo.io.project import Project
    from scangeo.truth.true_error import Truth

    truth = Truth.load(Project.load(m["root"]))
    assert truth is not None
    g, terrain = truth.geometries["01"], truth.terrain
    frame = truth.project.map_frame
    lines, pixels, bands = m["lines"], m["pixels"], m["bands"]
    cube = np.memmap(m["cube"], np.float32, "r", shape=(bands, lines, pixels))
    out: dict = {}

    def truth_of_cells(transform, valid):
        """The true (line, pixel) of the ground points of the grid's valid cells (true terrain)."""
        rows, cols = np.nonzero(valid)
        x, y = rasterio.transform.xy(transform, rows, cols)
        x, y = np.asarray(x, float), np.asarray(y, float)
        p = frame.map_to_project(x, y, terrain.height_at_map(x, y))
        lt, pt, status = g.ground_to_image(p)
        return rows, cols, p, lt, pt, status == 0

    def radiometry(read_band, rows, cols, lt, pt, seen):
        li = np.rint(np.where(seen, lt, -1.0)).astype(np.int64)
        pi = np.rint(np.where(seen, pt, -1.0)).astype(np.int64)
        inside = seen & (li >= 0) & (li < lines) & (pi >= 0) & (pi < pixels)
        rms = []
        for b in range(bands):
            tool = read_band(b)[rows, cols]
            ok = inside & np.isfinite(tool) & (tool != NODATA)
            rms.append(float(np.sqrt(np.mean((tool[ok] - np.asarray(cube[b])[li[ok], pi[ok]]) ** 2))))
        return rms, int(ok.sum())

    # scangeo: its inverse map at every cell it filled
    peer = (points_ecef_path, gref_cube, gref_composite, truth_of_cells, radiometry)
    if not Path(m["scangeo_out"]).exists():
        return evaluate_gref4hsi(m, truth, cube, *peer)
    with rasterio.open(Path(m["scangeo_out"]).with_suffix(".layers.tif")) as src:
        line_s, pixel_s, transform = src.read(1).astype(float), src.read(2).astype(float), src.transform
    with rasterio.open(m["scangeo_out"]) as ortho:
        valid = np.isfinite(line_s) & np.isfinite(pixel_s)
        rows, cols, p_cell, lt, pt, seen = truth_of_cells(transform, valid)
        ls, ps = line_s[rows, cols], pixel_s[rows, cols]
        ok = seen
        p_true, st = g.image_to_ground(ls[ok], ps[ok], terrain)
        ground = np.hypot(*(p_true[:, :2] - p_cell[ok, :2]).T)
        out["scangeo"] = {
            "cells": int(valid.sum()), "compared": int(ok.sum()),
            "ground_m": _stats(ground), "along_lines": _stats(ls[ok] - lt[ok]), "across_px": _stats(ps[ok] - pt[ok]),
            "grid": [src.width, src.height],
        }
        out["scangeo"]["band_rms"], out["scangeo"]["radiometry_cells"] = radiometry(
            lambda b: ortho.read(b + 1), rows, cols, lt, pt, seen)
    out.update(evaluate_gref4hsi(m, truth, cube, *peer))
    return out


def evaluate_gref4hsi(m, truth, cube, points_ecef_path, gref_cube, gref_composite, truth_of_cells, radiometry):
    """gref4hsi's geolocation (ray-traced points) and orthoimage against the truth (``evaluate``)."""
    import numpy as np
    import rasterio

    from scangeo.frames import ecef_to_geodetic

    g, terrain, frame = truth.geometries["01"], truth.terrain, truth.project.map_frame
    lines, pixels, bands = m["lines"], m["pixels"], m["bands"]
    out: dict = {}
    # gref4hsi: its ray-traced ground point of every image pixel
    if points_ecef_path is not None:
        pts = np.load(points_ecef_path).reshape(-1, 3)
        hit = np.any(pts != 0.0, axis=1)
        lat, lon, h = ecef_to_geodetic(pts[hit])
        p_g = frame.frame.geodetic_to_project(lat, lon, h)
        li, pi = np.divmod(np.flatnonzero(hit), pixels)
        p_true, st = g.image_to_ground(li.astype(float), pi.astype(float), terrain)
        ok = (st == 0) & np.isfinite(p_true).all(axis=1)
        ground = np.hypot(*(p_g[ok, :2] - p_true[ok, :2]).T)
        lt, pt, status = g.ground_to_image(p_g[ok])
        good = status == 0
        out["gref4hsi"] = {
            "pixels": int(hit.sum()), "of": lines * pixels, "compared": int(ok.sum()),
            "ground_m": _stats(ground), "height_m": _stats(p_g[ok, 2] - p_true[ok, 2]),
            "along_lines": _stats(lt[good] - li[ok][good]), "across_px": _stats(pt[good] - pi[ok][good]),
        }
    if gref_cube is not None and gref_composite is not None:
        with rasterio.open(gref_composite) as comp:
            transform, shape = comp.transform, (comp.height, comp.width)
        data = np.memmap(gref_cube, np.float32, "r", shape=(bands,) + shape)
        valid = np.asarray(data[0]) != NODATA
        rows, cols, _, lt, pt, seen = truth_of_cells(transform, valid)
        out.setdefault("gref4hsi", {})["grid"] = [shape[1], shape[0]]
        out["gref4hsi"]["cells"] = int(valid.sum())
        out["gref4hsi"]["band_rms"], out["gref4hsi"]["radiometry_cells"] = radiometry(
            lambda b: np.asarray(data[b]), rows, cols, lt, pt, seen)
    return out


# ---------------------------------------------------------------------------------------------

def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=11, help="the simulation's seed")
    ap.add_argument("--lines", type=int, default=4000)
    ap.add_argument("--pixels", type=int, default=1800)
    ap.add_argument("--bands", type=int, default=64)
    ap.add_argument("--resolution", type=float, default=0.6, help="output cells of both tools, m")
    ap.add_argument("--dem", default=str(SRTM.resolve()), help="the true terrain: a DEM file, or 'simulated'")
    ap.add_argument("--dem-as-is", action="store_true", help="give gref4hsi the DEM without the half-cell shift")
    ap.add_argument("--work", default="/tmp/scangeo_peer_gref4hsi", help="kept between runs (no dot in the path)")
    ap.add_argument("--venv", default=None, help="gref4hsi's virtual environment (default ~/.cache/scangeo-peers)")
    ap.add_argument("--skip-scangeo", action="store_true")
    ap.add_argument("--skip-gref4hsi", action="store_true")
    args = ap.parse_args()

    from peer_env import PeerUnavailable, ensure, gref4hsi_peer, load_average, peer_environ, run_measured

    peer_python = None
    if not args.skip_gref4hsi:
        try:
            peer = gref4hsi_peer()
            peer_python = ensure(peer, Path(args.venv) if args.venv else None)
        except PeerUnavailable as exc:
            print(f"SKIPPED gref4hsi: {exc}")
            return
    m = set_up(args)
    work = Path(m["root"]).parent
    me = str(Path(__file__).resolve())
    print(f"load average before: {load_average()}; OPENBLAS_CORETYPE={os.environ.get('OPENBLAS_CORETYPE')}")
    results = {}
    if not args.skip_scangeo:
        # warm-up (not timed): numba's compiled kernels loaded or compiled once
        warm = dict(m, scangeo_out=str(work / "scangeo_warm" / "01.tif"), lines=m["lines"])
        (work / "warm.json").write_text(json.dumps(warm))
        subprocess.run([sys.executable, me, "--child", "scangeo-warm", str(work / "warm.json"), "/dev/null"],
                       check=True, env={**os.environ, "PYTHONPATH": str(HERE.parents[1])})
        shutil.rmtree(Path(m["scangeo_out"]).parent, ignore_errors=True)
        r = run_measured([sys.executable, me, "--child", "scangeo-run", str(work / "manifest.json"),
                          str(work / "scangeo_times.json")], env={**os.environ, "PYTHONPATH": str(HERE.parents[1])},
                         log_path=work / "scangeo.log")
        if r.returncode:
            sys.exit(f"scangeo's child failed ({r.returncode}): {work / 'scangeo.log'}")
        results["scangeo"] = r
    points = cube = composite = None
    if peer_python is not None:
        env = peer_environ(gref4hsi_peer(), peer_python)
        mission = Path(m["mission"])
        for old in ("Output", "Intermediate", "Input/H5", "Input/GIS"):
            shutil.rmtree(mission / old, ignore_errors=True)
        subprocess.run([str(peer_python), me, "--child", "gref4hsi-prepare", str(work / "manifest.json")], check=True,
                       env=env)
        r = run_measured([str(peer_python), me, "--child", "gref4hsi-run", str(mission / "configuration.ini"),
                          str(work / "gref4hsi_times.json")], env=env, log_path=work / "gref4hsi.log")
        if r.returncode:
            sys.exit(f"gref4hsi's child failed ({r.returncode}): {work / 'gref4hsi.log'}")
        results["gref4hsi"] = r
        points = work / "gref4hsi_points_ecef.npy"
        subprocess.run([str(peer_python), me, "--child", "gref4hsi-export",
                        str(mission / "Input" / "H5" / "flight_01.h5"), str(points)], check=True, env=env)
        cube = next((mission / "Output" / "GIS" / "HSIDatacubes").glob("flight_01_north_east.[bi][sm][qg]"))
        composite = mission / "Output" / "GIS" / "RGBComposites" / "flight_01_north_east.tif"
    print(f"load average after the runs: {load_average()}")
    ev = evaluate(m, points, cube, composite)
    report(m, results, ev, work)


def report(m: dict, results: dict, ev: dict, work: Path) -> None:
    import numpy as np

    print(f"\nflight: {m['pixels']} px x {m['lines']} lines x {m['bands']} bands float32 "
          f"({m['pixels'] * m['lines'] * m['bands'] * 4 / 2**30:.2f} GiB), cells of {m['resolution']} m; "
          f"gref4hsi's DEM {'shifted by half a cell' if m['dem_shifted_half_cell'] else 'as is'}")
    for tool in ("scangeo", "gref4hsi"):
        times = work / f"{tool}_times.json"
        if tool in results and times.exists():
            steps = json.loads(times.read_text())
            print(f"{tool} steps (wall s / CPU s of the main thread): "
                  + ", ".join(f"{k} {w:.1f}/{c:.1f}" for k, (w, c) in steps.items()))
    print(f"\n{'tool':<10}{'CPU s':>9}{'wall s':>9}{'peak MB':>9}  {'geolocation: ground m rms / p99':<34}"
          f"{'along lines rms / p99':<24}{'across px rms / p99':<22}{'band rms (min-median-max)'}")
    for tool in ("scangeo", "gref4hsi"):
        e, r = ev.get(tool, {}), results.get(tool)
        if r is None:
            continue
        geo = (f"{e['ground_m'][0]:.2e} / {e['ground_m'][1]:.2e}" if "ground_m" in e else "-")
        al = (f"{e['along_lines'][0]:.2e} / {e['along_lines'][1]:.2e}" if "along_lines" in e else "-")
        ac = (f"{e['across_px'][0]:.2e} / {e['across_px'][1]:.2e}" if "across_px" in e else "-")
        b = np.asarray(e.get("band_rms", [np.nan]))
        print(f"{tool:<10}{r.cpu:>9.1f}{r.wall:>9.1f}{r.peak_mb:>9.0f}  {geo:<34}{al:<24}{ac:<22}"
              f"{b.min():.2e} - {np.median(b):.2e} - {b.max():.2e}")
    for tool, e in ev.items():
        print(f"{tool}: " + ", ".join(f"{k} {v}" for k, v in e.items() if k in ("cells", "pixels", "of", "compared",
                                                                              "radiometry_cells", "grid", "height_m")))
    if "scangeo" in results and "gref4hsi" in results:
        s, g = results["scangeo"], results["gref4hsi"]
        es, eg = ev["scangeo"], ev["gref4hsi"]
        print(f"ratios gref4hsi / scangeo: CPU {g.cpu / s.cpu:.1f}x, wall {g.wall / s.wall:.1f}x, peak memory "
              f"{g.peak_mb / s.peak_mb:.1f}x, geolocation rms {eg['ground_m'][0] / es['ground_m'][0]:.0f}x (ground), "
              f"p99 {eg['ground_m'][1] / es['ground_m'][1]:.0f}x")
    measured = {k: vars(v) for k, v in results.items()}
    (work / "results.json").write_text(json.dumps({"evaluation": ev, "measured": measured}, indent=1))
    print()
    for tool in ("scangeo", "gref4hsi"):
        if tool in results:
            r, e = results[tool], ev.get(tool, {})
            print(f"SUMMARY {tool}: {r.cpu:.1f} CPU s, {r.peak_mb:.0f} MB peak, geolocation error against the truth "
                  f"rms {e['ground_m'][0]:.2e} m (p99 {e['ground_m'][1]:.2e} m), across {e['across_px'][0]:.2e} px, "
                  f"along {e['along_lines'][0]:.2e} lines, radiometric rms per band median "
                  f"{np.median(e['band_rms']):.2e}")


def child(argv: list[str]) -> None:
    what = argv[0]
    if what == "gref4hsi-prepare":
        gref4hsi_prepare(argv[1])
    elif what == "gref4hsi-run":
        gref4hsi_run(argv[1], argv[2])
    elif what == "gref4hsi-export":
        gref4hsi_export(argv[1], argv[2])
    elif what == "scangeo-run":
        scangeo_run(argv[1], argv[2])
    elif what == "scangeo-warm":
        import numpy as np

        m = json.loads(Path(argv[1]).read_text())
        from scangeo.io.project import Project
        from scangeo.rectify.core_geometry import CoreStripGeometry
        from scangeo.rectify.options import RectifyOptions
        from scangeo.rectify.strip import rectify_strip
        from scangeo.rectify.strip_run import strip_grid
        from scangeo.truth.true_error import Truth

        truth = Truth.load(Project.load(m["root"]))
        assert truth is not None
        geometry = CoreStripGeometry(truth.geometries["01"], truth.terrain)
        options = RectifyOptions(resolution=m["resolution"], resampling="nearest", layers=("image_line", "image_pixel"))
        xmin, ymin, xmax, ymax = strip_grid(geometry, options).bounds
        rectify_strip(geometry, m["cube"], m["scangeo_out"], options.replace(bounds=(xmin, ymax - 30.0, xmax, ymax)))
        del np
    else:
        raise SystemExit(f"unknown child {what}")


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[1] == "--child":
        child(sys.argv[2:])
    else:
        main()

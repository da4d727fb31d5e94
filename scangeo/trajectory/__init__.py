"""GPS/IMU streams, their files, and the orientation spline."""
from scangeo.trajectory.readers import read_sbet, read_trajectory, read_trajectory_csv, write_trajectory_csv
from scangeo.trajectory.spline import OrientationSpline
from scangeo.trajectory.stream import GpsImuStream, ProjectTrajectory

__all__ = [
    "GpsImuStream", "ProjectTrajectory", "OrientationSpline",
    "read_sbet", "read_trajectory", "read_trajectory_csv", "write_trajectory_csv",
]

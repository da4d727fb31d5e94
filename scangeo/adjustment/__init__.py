"""The line-scanner block: observation groups of scanner images, GPS/IMU samples, ground points and
DTM heights on the least-squares engine (:mod:`scangeo.lsq`), the block's set-up from a project and a
variant (:mod:`scangeo.adjustment.block`), one variant adjusted (:mod:`scangeo.adjustment.results`)
and written (:mod:`scangeo.adjustment.outputs`), reliability and planning, and the drift diagnosis
(:mod:`scangeo.adjustment.diagnosis`).

Its keys are in :mod:`scangeo.adjustment.keys`; the orientation file and the GPS/IMU correction
models one layer below, in :mod:`scangeo.orientation`.
"""

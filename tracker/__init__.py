"""Markerless 3D motion capture by Interval Particle Filtering.

Pure computation: body model and kinematics (``tracker.body``), cameras (``tracker.camera``),
segmentation (``tracker.segmentation``), the silhouette likelihood (``tracker.likelihood``) and
the filters. No database, no web; files only through the readers and writers that take them.
Importing this package is cheap: submodules are imported on demand.
"""

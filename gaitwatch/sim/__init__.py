"""Scene synthesis: camera footage of a known motion, with ground truth (docs/simulation.md).

Modules: ``motion`` (procedural walk, preparing recordings), ``scene`` (settings),
``person`` (the clothed body mesh), ``render`` (z-buffer rasteriser, lights), ``room``
(textured room, furniture), ``synth`` (build and render a scene), ``writer`` (the scene
folder), ``advise`` (camera-placement advice). Independent of the tracker's body model and
rasteriser; uses ``tracker.camera`` for cameras.
"""

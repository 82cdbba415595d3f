"""The camera-coverage planner: floor heat maps of who sees a standing person and how well, and a
mount search for N cameras (issue 20 item 4).

- :mod:`pipeline.planner.room`: the floor polygon the walls enclose, cameras inside it, wall occlusion.
- :mod:`pipeline.planner.coverage`: visibility and the Monte Carlo of the expected 3D joint error.
- :mod:`pipeline.planner.search`: mount candidates and the search for the best N-camera layouts.
- :mod:`pipeline.planner.figures`: the maps as PNG and SVG.
"""

"""Seeing motion: gait diagrams, a live preview and video rendering.

matplotlib and pyvista are imported only inside the functions that draw, so
importing :mod:`quadsim.viz` is cheap.

- :mod:`quadsim.viz.diagram`: footfall diagram, Hildebrand plot, CPG phases
  and spine angle (matplotlib); :func:`footfall_data`
  (:mod:`quadsim.viz.footfalls`) is the pure-numpy measurement behind it.
- :mod:`quadsim.viz.body`: a renderable body (the procedural mesh of
  :mod:`quadsim.mesh`, posed by linear blend skinning).
- :mod:`quadsim.viz.scene`: the pyvista scene (body, scrolling ground grid,
  cameras) shared by the preview and the renderer.
- :mod:`quadsim.viz.preview`: :class:`Preview`, steering a controller live
  in a window.
- :mod:`quadsim.viz.render`: :func:`render_video` of a motion to ``.mp4`` or
  ``.gif`` off screen, streamed to the encoders of :mod:`quadsim.viz.video`,
  on the ground the motion walks on (:mod:`quadsim.viz.terrain`).
"""

from quadsim.viz.body import BodyMesh
from quadsim.viz.diagram import FootfallData, Segment, footfall_data, gait_diagram, gait_figure
from quadsim.viz.preview import Preview
from quadsim.viz.render import render_frames, render_video

__all__ = ["BodyMesh", "FootfallData", "Preview", "Segment", "footfall_data", "gait_diagram",
           "gait_figure", "render_frames", "render_video"]

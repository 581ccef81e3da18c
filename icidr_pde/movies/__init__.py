"""Movies of shear-cell runs, one concept a module.

* :mod:`.schedule` -- the frame times of a run (:func:`~.schedule.frame_times`);
* :mod:`.frames` -- :class:`~.frames.MovieFrames`, the frames collected during a run (a recorder of the run path);
* :mod:`.render` -- the figures of a movie, frame by frame: phi, u, w against z and max|w|(t) (1-D);
  w and phi - phi0 over the cell for runs side by side (2-D);
* :mod:`.sink` -- where the frames go: ffmpeg (MP4) or Pillow (GIF), written under a temporary name;
* :mod:`.registry` -- the paper's supplementary movies 1-6 and the 2-D movie (:class:`~.registry.MovieSpec`).

Frames are snapshots at a fixed interval of simulated time (``frame_dt``), independent of the
snapshot times a user asks for; a failed run ends with its state at t*, titled with the reason.
"""

"""The reproduction report: paper values as data, experiments that call the robots' studies,
a runner with one progress display and a content-hash result cache, and the HTML page.

The robots say what to run (``bipedlab.robots.<name>.reproduce``: ``PAPERS``); this package
names no robot."""
from bipedlab.report.spec import Experiment, Failed, Figure, Measured, NotIdentifiable, Paper, Sensitivity, Skip, dig

__all__ = ["Experiment", "Failed", "Figure", "Measured", "NotIdentifiable", "Paper", "Sensitivity", "Skip", "dig"]

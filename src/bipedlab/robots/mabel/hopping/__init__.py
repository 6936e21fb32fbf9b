"""bipedlab.robots.mabel.hopping."""

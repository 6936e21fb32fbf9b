"""bipedlab.robots.atrias.robot."""

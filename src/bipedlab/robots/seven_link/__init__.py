"""bipedlab.robots.seven_link.robot."""

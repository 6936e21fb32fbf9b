"""bipedlab.robots.mabel.walking.stance."""

"""A biped brought by its user as an MJCF or URDF file (robot word ``model``): the HZD study
(gait design, walking, Poincaré analysis) on the model the file describes, and RABBIT as the
worked example (``data/rabbit.xml``, ``data/rabbit.urdf``)."""

"""One self-contained package per robot, each built on the core (mechanics, contact, sim,
control, gait, viz) and on no other robot: :mod:`.five_link`, :mod:`.mabel`, :mod:`.atrias`,
:mod:`.seven_link`, :mod:`.compass_gait`. Each owns its parameters (with sources), model,
controllers, closed-loop configuration, studies, plots, shipped data and CLI registration."""

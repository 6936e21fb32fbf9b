"""The passive compass-gait walker (Goswami, Thuilot & Espiau), written only against the
robot-agnostic core: :mod:`.model` (model, flow, guard, reset), :mod:`.walker` (step, return
map, period-one gait) and :mod:`.study` (the ``walk`` study)."""
from .model import CompassGaitParams, params
from .walker import Gait, period_one_gait, return_map, step

__all__ = ["CompassGaitParams", "params", "Gait", "period_one_gait", "return_map", "step"]

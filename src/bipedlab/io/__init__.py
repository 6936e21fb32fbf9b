"""Robot descriptions in: planar MJCF and URDF files read through MuJoCo's compiler into the
frozen :class:`bipedlab.mechanics.Model` (:func:`load_model`, :func:`read`). Export is
:func:`bipedlab.mechanics.to_mjcf`. MuJoCo is imported only when a file is read."""
from bipedlab.io.description import Description, load_model, q_from_qpos, read

__all__ = ["Description", "load_model", "q_from_qpos", "read"]

"""System identification of MABEL (Park, Sreenath, Hurst & Grizzle): experiments and estimators.

Experiments (:mod:`.experiments`, on a "true" parameter set from :mod:`.params`, read by the
sensors of :mod:`.sensors`; logs in the CSV format of :mod:`.logs`):

* :func:`bias_experiment` - Appendix A, the rotor alone under an unbiased sinusoid;
* :func:`transmission_experiments` - Section IV, 1/3/5 and 1/3/4 pulleys under the modified chirp;
* :func:`leg_experiments` - Section V, SISO and MIMO with locked coordinates and fixed torso;
* :func:`spring_experiment`, :func:`balance_experiments` - Sections VII-A and VI, static;
* :func:`hopping_experiment` - Section VIII, the 13-DoF model under the hopping controller;
* :func:`generate` - all of them.

Estimators:

* :func:`fit_first_order` (eq. 7) and :func:`kt_alpha` (eqs. 10-12) - :mod:`.transmission`;
* :func:`arx_bias` (eqs. 31-33) - :mod:`.arx`;
* :func:`fit_leg` (eqs. 19-20, exact JAX Jacobians) - :mod:`.friction`;
* :func:`fit_spring` (eq. 24) - :mod:`.springs`;
* :func:`com_check`, :func:`estimate_torso_com` (Section VI) - :mod:`.balance`;
* :func:`fit_cable`, :func:`fit_hopping` (Section VIII-C) - :mod:`.hopping_fit`;
* :func:`identify` - the whole pipeline on a list of logs; :func:`compare` - against a truth
  (:mod:`.pipeline`).

Logs: :func:`read_logs`, :func:`write_logs`, :class:`LogError`; what each estimator needs of
its logs (rows, postures, excitation, rank), checked on reading and before the first fit:
:mod:`.preconditions`.
"""
from bipedlab.robots.mabel.sysid import (
    arx,
    balance,
    experiments,
    friction,
    hopping_fit,
    logs,
    params,
    pipeline,
    preconditions,
    rigs,
)
from bipedlab.robots.mabel.sysid import sensors, springs, transmission
from bipedlab.robots.mabel.sysid.arx import ArxBias, arx_bias
from bipedlab.robots.mabel.sysid.balance import ComCheck, com_check, estimate_torso_com
from bipedlab.robots.mabel.sysid.experiments import (
    Design,
    balance_experiments,
    bias_experiment,
    generate,
    hopping_experiment,
    leg_experiments,
    quick_design,
    spring_experiment,
    transmission_experiments,
)
from bipedlab.robots.mabel.sysid.friction import LegFit, fit_leg
from bipedlab.robots.mabel.sysid.hopping_fit import CableFit, HopFit, fit_cable, fit_hopping
from bipedlab.robots.mabel.sysid.pipeline import TARGETS, Identification, compare, identify
from bipedlab.robots.mabel.sysid.logs import Experiment, LogError, read_log, read_logs, write_log, write_logs
from bipedlab.robots.mabel.sysid.params import MabelParams, perturbed, published
from bipedlab.robots.mabel.sysid.sensors import Sensors
from bipedlab.robots.mabel.sysid.springs import SpringFit, fit_spring
from bipedlab.robots.mabel.sysid.transmission import FirstOrderFit, KtAlpha, fit_first_order, kt_alpha

__all__ = [
    "arx", "balance", "experiments", "friction", "hopping_fit", "logs", "params", "pipeline", "preconditions", "rigs",
    "sensors", "springs", "transmission",
    "ArxBias", "arx_bias", "ComCheck", "com_check", "estimate_torso_com", "Design", "balance_experiments",
    "bias_experiment", "generate", "hopping_experiment", "leg_experiments", "quick_design", "spring_experiment",
    "transmission_experiments", "LegFit", "fit_leg", "CableFit", "HopFit", "fit_cable", "fit_hopping", "TARGETS",
    "Identification", "compare", "identify", "Experiment", "LogError", "read_log", "read_logs", "write_log",
    "write_logs", "MabelParams", "perturbed", "published", "Sensors", "SpringFit", "fit_spring", "FirstOrderFit",
    "KtAlpha", "fit_first_order", "kt_alpha",
]
